"""ament_python build of flectofold_ros: the ROS nodes and the flectofold_model library."""

from glob import glob
import os

from setuptools import find_packages, setup

PACKAGE = 'flectofold_ros'

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(exclude=['test', 'test.*', 'bench']),
    package_data={'flectofold_model.facade': ['data/*.yaml'],
                  PACKAGE: ['fastdds_panel_process.xml']},
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + PACKAGE]),
        (os.path.join('share', PACKAGE), ['package.xml']),
        (os.path.join('share', PACKAGE, 'msg_docs'), glob('msg_docs/*.md')),
        (os.path.join('share', PACKAGE, 'launch'), glob('launch/*launch.[pxy][yma]*')),
        (os.path.join('share', PACKAGE, 'config'),
         glob('config/*.yaml') + glob('config/*.rviz') + glob('config/*.json')),
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
    # Every executable starts through flectofold_ros.executables, which takes over the stop
    # signals before the heavy imports (see flectofold_ros/runner.py).
    entry_points={
        'console_scripts': [
            'fold_table = flectofold_ros.executables:fold_table',
            'day_report = flectofold_ros.executables:day_report',
            'annual_report = flectofold_ros.executables:annual_report',
            'building_report = flectofold_ros.executables:building_report',
            'panel_node = flectofold_ros.executables:panel_node',
            'panel_group = flectofold_ros.executables:panel_group',
            'sun_position_node = flectofold_ros.executables:sun_position_node',
            'weather_node = flectofold_ros.executables:weather_node',
            'coordinator_node = flectofold_ros.executables:coordinator_node',
            'facade = flectofold_ros.executables:facade',
            'rerun_bridge = flectofold_ros.executables:rerun_bridge',
            'facade_markers = flectofold_ros.executables:facade_markers',
            'bag_recorder = flectofold_ros.executables:bag_recorder',
            'replay = flectofold_ros.executables:replay',
            'bag_reindex = flectofold_ros.executables:bag_reindex',
            'facade_export = flectofold_ros.executables:facade_export',
            'valve_terminal_sim = flectofold_ros.executables:valve_terminal_sim',
            'structure_cache = flectofold_ros.executables:structure_cache',
        ],
    },
)
