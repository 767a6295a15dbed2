"""ament_python build of flectofold_ros: the ROS nodes and the flectofold_model library."""

from glob import glob
import os

from setuptools import find_packages, setup

PACKAGE = 'flectofold_ros'

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(exclude=['test', 'test.*', 'bench']),
    package_data={'flectofold_model': ['data/*.yaml']},
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + PACKAGE]),
        (os.path.join('share', PACKAGE), ['package.xml']),
        (os.path.join('share', PACKAGE, 'msg_docs'), glob('msg_docs/*.md')),
        (os.path.join('share', PACKAGE, 'launch'), glob('launch/*launch.[pxy][yma]*')),
    ],
    # Python dependencies are pinned in requirements.txt (the venv) and named as rosdep keys
    # in package.xml (apt installs); setuptools only needs itself, as for every ament package.
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='Flectofold maintainers',
    maintainer_email='maintainers@flectofold.org',
    description='Kinetic facade arrays of Flectofold panels on ROS 2.',
    license='Apache-2.0',
    extras_require={'test': ['pytest']},
    entry_points={
        'console_scripts': [
            'fold_table = flectofold_ros.fold_table:main',
            'day_report = flectofold_ros.day_report:main',
            'panel_node = flectofold_ros.panel_node:main',
            'panel_group = flectofold_ros.panel_group:main',
            'sun_position_node = flectofold_ros.sun_position_node:main',
            'coordinator_node = flectofold_ros.coordinator_node:main',
            'facade = flectofold_ros.facade:main',
            'rerun_bridge = flectofold_ros.rerun_bridge:main',
            'bag_recorder = flectofold_ros.bag_recorder:main',
            'replay = flectofold_ros.replay:main',
        ],
    },
)
