"""The package as ROS tools see it: package.xml, the colcon install layout, lint, purity."""

import ast
import os
from pathlib import Path
import shutil
import subprocess
import sys

from catkin_pkg.package import parse_package
import pytest
from setup_script import console_scripts

from flectofold_ros.runtime import executables

ROOT = Path(__file__).resolve().parents[1]
EXECUTABLES = sorted(executables.EXECUTABLES)
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
    assert all('@' in maintainer.email for maintainer in package.maintainers)


def test_every_executable_is_a_console_script_through_the_signal_safe_entry_point():
    assert console_scripts() == {name: f'flectofold_ros.runtime.executables:{name}'
                                 for name in EXECUTABLES}


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


@pytest.mark.graph
def test_colcon_installs_the_ament_layout(colcon_install):
    assert (colcon_install / 'share' / 'ament_index' / 'resource_index' / 'packages'
            / 'flectofold_ros').is_file()
    assert (colcon_install / 'share' / 'flectofold_ros' / 'package.xml').is_file()
    assert list((colcon_install / 'share' / 'flectofold_ros' / 'msg_docs').glob('*.md'))
    for name in EXECUTABLES:
        assert os.access(colcon_install / 'lib' / 'flectofold_ros' / name, os.X_OK)


@pytest.mark.graph
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


@pytest.mark.graph
def test_executables_are_console_scripts_in_the_venv():
    for name in EXECUTABLES:
        run = subprocess.run([venv_tool(name), '--help'], capture_output=True, text=True,
                             timeout=60)
        assert run.returncode == 0, run.stderr


#: The parts that must run without rclpy: the model and, by folder, the ROS package's pure
#: floors (what goes on the wire, recording, Rerun, commands, hardware); and, module by module,
#: the pure parts of the bringup and of the runtime (the runner imports rclpy when it runs a
#: node, not before).
RCLPY_FREE = ['flectofold_model', 'flectofold_ros.wire', 'flectofold_ros.recording',
              'flectofold_ros.rerun', 'flectofold_ros.commands', 'flectofold_ros.hardware',
              'flectofold_ros.bringup.plan', 'flectofold_ros.bringup.supervision',
              'flectofold_ros.bringup.fault_script', 'flectofold_ros.runtime.runner',
              'flectofold_ros.runtime.executables', 'flectofold_ros.runtime.parameters',
              'flectofold_ros.sitenet', 'flectofold_ros.bms']


def modules_of(dotted):
    path = ROOT.joinpath(*dotted.split('.'))
    if path.is_dir():
        return list(path.rglob('*.py'))
    return [path.with_suffix('.py')]


@pytest.mark.parametrize('part', RCLPY_FREE)
def test_the_pure_parts_never_import_rclpy(part):
    for path in modules_of(part):  # at import time; run_nodes imports rclpy when called
        imported = {name.split('.')[0] for name in imported_modules(path, lazy=False)}
        assert 'rclpy' not in imported, path
    names = [f'{part}.{p.relative_to(ROOT.joinpath(*part.split("."))).with_suffix("")}'
             .replace('/', '.').replace('.__init__', '')
             for p in modules_of(part)] if ROOT.joinpath(*part.split('.')).is_dir() else [part]
    check = subprocess.run(
        [sys.executable, '-c', 'import importlib, sys\n'
         f'for name in {names!r}: importlib.import_module(name)\n'
         'assert "rclpy" not in sys.modules, "rclpy was imported"'],
        cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert check.returncode == 0, check.stderr


def imported_modules(path, lazy=True):
    """Absolute module names a Python file imports; ``lazy``: in functions too."""
    tree = ast.parse(path.read_text())
    names = set()
    for node in (ast.walk(tree) if lazy else tree.body):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0:
            names.add(node.module)
    return names


#: The packages whose modules the import rules below hold for.
OWN_PACKAGES = ('flectofold_model', 'flectofold_ros')


def own_modules():
    """Return the dotted name -> file of every module of :data:`OWN_PACKAGES`."""
    modules = {}
    for package in OWN_PACKAGES:
        for path in (ROOT / package).rglob('*.py'):
            parts = path.relative_to(ROOT).with_suffix('').parts
            modules['.'.join(parts[:-1] if parts[-1] == '__init__' else parts)] = path
    return modules


def own_imports(name, path, modules):
    """Return the imports of own modules in a file (in functions too) and the names bound.

    The imports are ``(line, module, name)``: ``from a.b import c`` takes name ``c`` of
    ``a.b``, or is module ``a.b.c`` itself (name None) where that is a module; ``import a.b``
    is ``a.b``. A submodule's parent packages are not counted: Python imports them first, in
    any order of the modules. The names bound are local name -> own module, for reading
    their attributes.
    """
    package = name if path.name == '__init__.py' else name.rpartition('.')[0]
    imports, bound = [], {}
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name in modules:
                    imports.append((node.lineno, alias.name, None))
                    top = alias.name.split('.')[0]
                    bound[alias.asname or top] = alias.name if alias.asname else top
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ''
            if node.level:
                parents = package.split('.')[:len(package.split('.')) - node.level + 1]
                base = '.'.join(parents + ([node.module] if node.module else []))
            for alias in node.names:
                if f'{base}.{alias.name}' in modules:
                    imports.append((node.lineno, f'{base}.{alias.name}', None))
                    bound[alias.asname or alias.name] = f'{base}.{alias.name}'
                elif base in modules:
                    imports.append((node.lineno, base, alias.name))
    return [entry for entry in imports if entry[1] != name], bound


def is_private(name):
    return name.startswith('_') and not (name.startswith('__') and name.endswith('__'))


def module_named(expression, bound):
    """Return the own module an expression (``a``, ``a.b``) names through imports, or None."""
    if isinstance(expression, ast.Name):
        return bound.get(expression.id)
    if isinstance(expression, ast.Attribute):
        owner = module_named(expression.value, bound)
        return None if owner is None else f'{owner}.{expression.attr}'
    return None


def test_no_module_of_the_package_uses_a_private_name_of_another():
    """Keep ``_``-names in their module: none imported from it, none read as ``module._name``.

    What another module needs is public (no leading underscore); dunder names do not count.
    """
    modules = own_modules()
    found = []
    for name, path in modules.items():
        where = path.relative_to(ROOT)
        imports, bound = own_imports(name, path, modules)
        found += [f'{where}:{line}: imports {imported} from {module}'
                  for line, module, imported in imports
                  if imported is not None and is_private(imported)]
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Attribute) and is_private(node.attr):
                owner = module_named(node.value, bound)
                if owner in modules and owner != name:
                    found.append(f'{where}:{node.lineno}: reads {owner}.{node.attr}')
    assert not found, '\n'.join(found)


def test_the_package_modules_import_each_other_without_a_circle():
    """No import circle among the package's own modules, imports within functions included."""
    modules = own_modules()
    graph = {name: sorted({module for _, module, _ in own_imports(name, path, modules)[0]})
             for name, path in modules.items()}
    circle = import_circle(graph)
    assert not circle, 'import circle: ' + ' -> '.join(circle)


def import_circle(graph):
    """Return a circle of ``graph`` (its modules, the first again at the end), else []."""
    state, trail = {}, []  # state: 'open' while on the trail, then 'done'

    def visit(node):
        state[node] = 'open'
        trail.append(node)
        for following in graph[node]:
            if state.get(following) == 'open':
                return trail[trail.index(following):] + [following]
            if following not in state:
                circle = visit(following)
                if circle:
                    return circle
        trail.pop()
        state[node] = 'done'
        return []

    for node in sorted(graph):
        if node not in state:
            circle = visit(node)
            if circle:
                return circle
    return []


#: Top-level module -> rosdep key of the package that provides it.
ROSDEP_KEYS = {
    'numpy': 'python3-numpy', 'scipy': 'python3-scipy', 'numba': 'python3-numba',
    'pandas': 'python3-pandas',
    'yaml': 'python3-yaml', 'ruamel': 'python3-ruamel.yaml', 'matplotlib': 'python3-matplotlib',
    'rosbags': 'python3-rosbags-pip', 'pvlib': 'python3-pvlib-pip', 'mcap': 'python3-mcap-pip',
    'pygltflib': 'python3-pygltflib-pip',
    'pyenergyplus': 'python3-pyenergyplus-lbnl-pip', 'pyradiance': 'python3-pyradiance-pip',
    'pymodbus': 'python3-pymodbus',
    'rerun': 'python3-rerun-sdk-pip', 'rerun_cli': 'python3-rerun-sdk-pip',
    'launch_ros': 'launch_ros', 'cryptography': 'python3-cryptography',
    'bacpypes3': 'python3-bacpypes3-pip', 'cvxopt': 'python3-cvxopt',
    'threadpoolctl': 'python3-threadpoolctl',
}
#: ROS packages whose Python module has the package's name.
ROS_PACKAGES = {'rclpy', 'builtin_interfaces', 'rcl_interfaces', 'std_msgs', 'std_srvs',
                'geometry_msgs', 'sensor_msgs', 'diagnostic_msgs', 'rosgraph_msgs',
                'visualization_msgs', 'launch'}


def test_package_xml_names_every_module_the_code_imports():
    own = {'flectofold_model', 'flectofold_ros'}
    imported = set()
    for path in [*ROOT.glob('flectofold_*/**/*.py'), *ROOT.glob('launch/*.py')]:
        imported |= {name.split('.')[0] for name in imported_modules(path)}
    third_party = sorted(imported - own - set(sys.stdlib_module_names))
    unknown = [name for name in third_party if name not in ROSDEP_KEYS and
               name not in ROS_PACKAGES]
    assert not unknown, f'map these imports to rosdep keys here and in package.xml: {unknown}'
    package = parse_package(str(ROOT / 'package.xml'))
    exec_depends = {dependency.name for dependency in package.exec_depends}
    needed = {ROSDEP_KEYS.get(name, name) for name in third_party}
    # Interfaces the contract names are imported by name (flectofold_ros.runtime.interfaces).
    needed |= {type_name.split('/')[0] for type_name in contract_types()}
    assert needed <= exec_depends, sorted(needed - exec_depends)
    assert exec_depends <= needed, f'not imported: {sorted(exec_depends - needed)}'


def contract_types():
    from flectofold_ros.wire import contract
    topics = [value for value in vars(contract).values()
              if isinstance(value, (contract.Topic, contract.PanelTopic))]
    return {topic.msgtype for topic in topics} | {contract.RESET_FAULTS_TYPE}


def test_package_xml_names_what_the_tests_and_lint_use():
    package = parse_package(str(ROOT / 'package.xml'))
    test_depends = {dependency.name for dependency in package.test_depends}
    linters = {line.split('==')[0].strip().replace('_', '-') for line in
               (ROOT / 'requirements.txt').read_text().splitlines()
               if line.startswith('flake8')}
    assert {f'python3-{name}' for name in linters} <= test_depends
    assert {'python3-pytest', 'python3-pytest-xdist', 'python3-catkin-pkg',
            'python3-colcon-common-extensions', 'ament_index_python'} <= test_depends


def test_graph_tests_are_marked():
    """Tests that start ROS processes or contexts carry the ``graph`` marker.

    ``./run test -m "not graph"`` is the fast inner loop; it must not start ROS.
    """
    for path in (ROOT / 'test').rglob('test_*.py'):
        text = path.read_text()
        starts_ros = 'ros_graph' in imported_modules(path) or 'rclpy.init' in text or \
            'rclpy.context' in imported_modules(path)
        if starts_ros:
            assert 'pytestmark = pytest.mark.graph' in text, path


def test_flake8_with_the_ament_configuration():
    lint = subprocess.run([venv_tool('flake8'), '.'], cwd=ROOT, capture_output=True, text=True)
    assert lint.returncode == 0, lint.stdout + lint.stderr
