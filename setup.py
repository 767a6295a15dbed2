"""ament_python build of flectofold_ros: the ROS nodes and the flectofold_model library."""

import ast
from glob import glob
import os

from setuptools import find_packages, setup

PACKAGE = 'flectofold_ros'


def console_scripts(path=os.path.join(PACKAGE, 'runtime', 'executables.py')):
    """Return ``NAME = flectofold_ros.runtime.executables:NAME`` for each of ``EXECUTABLES``.

    ``flectofold_ros.runtime.executables.EXECUTABLES`` is the one list of the executables; it is
    read from the source as a literal, since building must not import the package.
    """
    with open(path, encoding='utf-8') as source:
        tree = ast.parse(source.read(), path)
    for statement in tree.body:
        if isinstance(statement, ast.Assign) and \
                [getattr(target, 'id', None) for target in statement.targets] == ['EXECUTABLES']:
            return [f'{name} = {PACKAGE}.runtime.executables:{name}'
                    for name in ast.literal_eval(statement.value)]
    raise SystemExit(f'setup.py: {path} assigns no EXECUTABLES literal')


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
    # Every executable starts through flectofold_ros.runtime.executables, which takes over the stop
    # signals before the heavy imports (see flectofold_ros/runtime/runner.py).
    entry_points={'console_scripts': console_scripts()},
)
