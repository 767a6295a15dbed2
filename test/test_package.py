"""The package as ROS tools see it: package.xml, the colcon install layout, lint, purity."""

import os
from pathlib import Path
import shutil
import subprocess
import sys

from catkin_pkg.package import parse_package
import pytest

ROOT = Path(__file__).resolve().parents[1]
EXECUTABLES = ['fold_table', 'day_report', 'panel_node', 'panel_group', 'sun_position_node',
               'coordinator_node', 'facade', 'rerun_bridge', 'bag_recorder', 'replay']
IGNORED_IN_COPY = shutil.ignore_patterns('.venv', '.git', 'build', 'install', 'log', 'out',
                                         '__pycache__', '*.egg-info', '.pytest_cache')


def venv_tool(name):
    tool = Path(sys.executable).parent / name
    assert tool.exists(), f'{name} is not installed next to {sys.executable}: run ./run test'
    return str(tool)


def test_package_xml_is_format_3_ament_python():
    package = parse_package(str(ROOT / 'package.xml'))
    package.validate()
    assert package.name == 'flectofold_ros'
    assert package.package_format == 3
    assert package.get_build_type() == 'ament_python'
    exec_depends = {dependency.name for dependency in package.exec_depends}
    assert {'rclpy', 'std_msgs', 'sensor_msgs', 'geometry_msgs',
            'diagnostic_msgs'} <= exec_depends
    assert all('@' in maintainer.email for maintainer in package.maintainers)


def test_setup_cfg_puts_scripts_where_ros2_run_looks():
    text = (ROOT / 'setup.cfg').read_text()
    assert 'script_dir=$base/lib/flectofold_ros' in text
    assert 'install_scripts=$base/lib/flectofold_ros' in text
    assert (ROOT / 'resource' / 'flectofold_ros').is_file()


@pytest.fixture(scope='module')
def colcon_install(tmp_path_factory):
    workspace = tmp_path_factory.mktemp('colcon_ws')
    shutil.copytree(ROOT, workspace / 'src' / 'flectofold_ros', ignore=IGNORED_IN_COPY)
    listed = subprocess.run([venv_tool('colcon'), 'list'], cwd=workspace, capture_output=True,
                            text=True, check=True).stdout
    assert '(ros.ament_python)' in listed, listed
    build = subprocess.run([venv_tool('colcon'), 'build'], cwd=workspace, capture_output=True,
                           text=True, timeout=300)
    assert build.returncode == 0, build.stdout + build.stderr
    return workspace / 'install' / 'flectofold_ros'


def test_colcon_installs_the_ament_layout(colcon_install):
    assert (colcon_install / 'share' / 'ament_index' / 'resource_index' / 'packages'
            / 'flectofold_ros').is_file()
    assert (colcon_install / 'share' / 'flectofold_ros' / 'package.xml').is_file()
    assert list((colcon_install / 'share' / 'flectofold_ros' / 'msg_docs').glob('*.md'))
    for name in EXECUTABLES:
        assert os.access(colcon_install / 'lib' / 'flectofold_ros' / name, os.X_OK)


def test_ros2_run_finds_and_starts_every_executable(colcon_install):
    """Resolve executables the way ``ros2 run`` does: ament index prefix, then lib/<pkg>/."""
    site_packages = next((colcon_install / 'lib').glob('python3*/site-packages'))
    environment = {**os.environ, 'AMENT_PREFIX_PATH': str(colcon_install),
                   'PYTHONPATH': str(site_packages)}
    lookup = subprocess.run(
        [sys.executable, '-c', 'from ament_index_python.packages import get_package_prefix;'
         'print(get_package_prefix("flectofold_ros"))'],
        env=environment, cwd=colcon_install, capture_output=True, text=True, check=True)
    prefix = Path(lookup.stdout.strip())
    assert prefix == colcon_install
    origin = subprocess.run([sys.executable, '-c', 'import flectofold_model; '
                             'print(flectofold_model.__file__)'], env=environment,
                            cwd=colcon_install, capture_output=True, text=True,
                            check=True).stdout
    assert origin.startswith(str(site_packages)), origin
    for name in EXECUTABLES:
        run = subprocess.run([str(prefix / 'lib' / 'flectofold_ros' / name), '--help'],
                             env=environment, cwd=colcon_install, capture_output=True,
                             text=True, timeout=60)
        assert run.returncode == 0, run.stderr
        assert 'usage' in run.stdout


def test_executables_are_console_scripts_in_the_venv():
    for name in EXECUTABLES:
        run = subprocess.run([venv_tool(name), '--help'], capture_output=True, text=True,
                             timeout=60)
        assert run.returncode == 0, run.stderr


def test_model_library_never_imports_rclpy():
    for path in (ROOT / 'flectofold_model').rglob('*.py'):
        assert 'rclpy' not in path.read_text(), path
    check = subprocess.run(
        [sys.executable, '-c', 'import sys, flectofold_model, flectofold_model.mesh;'
         'assert "rclpy" not in sys.modules'], cwd=ROOT, capture_output=True, text=True)
    assert check.returncode == 0, check.stderr


def test_flake8_with_the_ament_configuration():
    lint = subprocess.run([venv_tool('flake8'), '.'], cwd=ROOT, capture_output=True, text=True)
    assert lint.returncode == 0, lint.stdout + lint.stderr
