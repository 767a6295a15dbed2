"""launch/facade.launch.py: the launch actions it generates from a facade description.

ros2 launch and launch_ros are not needed: where they cannot be imported, minimal stand-in
modules that record their arguments take their place.
"""

import fnmatch
import importlib.util
from pathlib import Path
import shutil
import sys
import types

import pytest

from flectofold_model.facade.description import DEFAULT_FACADE, FacadeError, load_facade
from flectofold_ros.nodes.panel_group import group_slice
from flectofold_ros.wire import contract

LAUNCH_FILE = Path(__file__).resolve().parents[3] / 'launch' / 'facade.launch.py'
SETUP_GLOB = '*launch.[pxy][yma]*'  # setup.py installs launch/<this> to share/.../launch


class _Recorder:
    def __init__(self, *args, **kwargs):
        self.args, self.kwargs = args, kwargs


class _LaunchDescription(_Recorder):
    def __init__(self, entities=(), **kwargs):
        super().__init__(**kwargs)
        self.entities = list(entities)


class _DeclareLaunchArgument(_Recorder):
    def __init__(self, name, default_value=None, **kwargs):
        super().__init__(**kwargs)
        self.name, self.default_value = name, default_value


class _OpaqueFunction(_Recorder):
    def __init__(self, *, function, args=None, kwargs=None):
        super().__init__(function=function)
        self.function, self.function_args = function, args or []
        self.function_kwargs = kwargs or {}

    def execute(self, context):
        return self.function(context, *self.function_args, **self.function_kwargs)


class _SetEnvironmentVariable(_Recorder):
    def __init__(self, name, value, **kwargs):
        super().__init__(**kwargs)
        self.name, self.value = name, value


class _UnsetEnvironmentVariable(_Recorder):
    def __init__(self, name, **kwargs):
        super().__init__(**kwargs)
        self.name = name


class _LaunchConfiguration(_Recorder):
    def __init__(self, variable_name, **kwargs):
        super().__init__(**kwargs)
        self.variable_name = variable_name

    def perform(self, context):
        return context.launch_configurations[self.variable_name]


def _install_stand_ins():
    """Put stand-in launch / launch_ros modules in sys.modules unless the real ones import."""
    try:
        # A bare ``import launch`` is not enough: run from the repository, the launch/
        # directory of launch files imports as an empty namespace package.
        from launch import LaunchDescription  # noqa: F401
        from launch_ros.actions import Node  # noqa: F401
        return False
    except ImportError:
        for name in ('launch', 'launch.actions', 'launch.substitutions', 'launch_ros',
                     'launch_ros.actions'):
            sys.modules.pop(name, None)
    modules = {name: types.ModuleType(name) for name in
               ('launch', 'launch.actions', 'launch.substitutions', 'launch_ros',
                'launch_ros.actions')}
    modules['launch'].LaunchDescription = _LaunchDescription
    modules['launch.actions'].DeclareLaunchArgument = _DeclareLaunchArgument
    modules['launch.actions'].OpaqueFunction = _OpaqueFunction
    modules['launch.actions'].SetEnvironmentVariable = _SetEnvironmentVariable
    modules['launch.actions'].UnsetEnvironmentVariable = _UnsetEnvironmentVariable
    modules['launch.substitutions'].LaunchConfiguration = _LaunchConfiguration
    modules['launch_ros.actions'].Node = _Recorder
    modules['launch'].actions = modules['launch.actions']
    modules['launch'].substitutions = modules['launch.substitutions']
    modules['launch_ros'].actions = modules['launch_ros.actions']
    sys.modules.update(modules)
    return True


STAND_INS = _install_stand_ins()


def _load_launch_module():
    spec = importlib.util.spec_from_file_location('facade_launch', LAUNCH_FILE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope='module')
def launch_module():
    module = _load_launch_module()
    node_class = module.Node

    class RecordingNode(node_class):
        """The Node the launch file uses (the real one if present), keeping its kwargs."""

        def __init__(self, **kwargs):
            super().__init__(**kwargs)
            self.kwargs = kwargs

    module.Node = RecordingNode
    return module


def _context(configurations):
    if STAND_INS:
        return types.SimpleNamespace(launch_configurations=dict(configurations))
    from launch import LaunchContext
    context = LaunchContext()
    context.launch_configurations.update(configurations)
    return context


def _text(default_value, context):
    if isinstance(default_value, str):
        return default_value
    return ''.join(substitution.perform(context) for substitution in default_value)


def _defaults(description):
    context = _context({})
    return {entity.name: _text(entity.default_value, context)
            for entity in description.entities if hasattr(entity, 'default_value')}


def _opaque(description):
    from launch.actions import OpaqueFunction
    functions = [e for e in description.entities if isinstance(e, OpaqueFunction)]
    assert len(functions) == 1
    return functions[0]


def _nodes(launch_module, **overrides):
    description = launch_module.generate_launch_description()
    configurations = dict(_defaults(description), **overrides)
    return _opaque(description).execute(_context(configurations))


def _by_executable(nodes, executable):
    return [node.kwargs for node in nodes if node.kwargs['executable'] == executable]


def _parameters(kwargs):
    (parameters,) = kwargs['parameters']
    return parameters


def _check_bringup(nodes, facade, groups, facade_file):
    assert all(node.kwargs['package'] == 'flectofold_ros' for node in nodes)
    (sun,) = _by_executable(nodes, 'sun_position_node')
    sun_parameters = _parameters(sun)
    assert sun_parameters['latitude_deg'] == pytest.approx(facade.site.latitude_deg)
    assert sun_parameters['longitude_deg'] == pytest.approx(facade.site.longitude_deg)
    assert sun_parameters['mode'] == 'simulated'
    assert all(type(value) in (float, str, int) for value in sun_parameters.values())
    # the day starts when every panel reports and the coordinator (+ observers) listen
    observers = len(_by_executable(nodes, 'bag_recorder') + _by_executable(nodes, 'rerun_bridge'))
    assert sun_parameters['start.wait_for_panels'] == len(facade)
    assert sun_parameters['start.wait_for_sun_listeners'] == 1 + observers
    offset = f'{int(facade.utc_offset_h):+03d}:00'
    assert sun_parameters['start_time'] == f'2026-06-21T12:00:00{offset}'
    assert sun_parameters['end_time'] == f'2026-06-21T15:00:00{offset}'
    assert sun_parameters['speedup'] == 360.0

    (coordinator,) = _by_executable(nodes, 'coordinator_node')
    assert coordinator['namespace'] == '/facade'
    coordinator_parameters = _parameters(coordinator)
    assert coordinator_parameters['use_sim_time'] is True
    assert coordinator_parameters['facade_file'] == facade_file
    assert coordinator_parameters['setpoint_period_s'] > 0

    panel_groups = _by_executable(nodes, 'panel_group')
    assert len(panel_groups) == groups
    assert len(nodes) == groups + 2
    covered = []
    for kwargs in panel_groups:
        assert 'name' not in kwargs  # a node-name remap would rename every panel node
        arguments = kwargs['arguments']
        assert arguments[0] == '--group'
        group, of = (int(part) for part in arguments[1].split('/'))
        assert of == groups
        assert arguments[2:] == (['--facade', facade_file] if facade_file else [])
        parameters = _parameters(kwargs)
        assert parameters['use_sim_time'] is True
        assert parameters['facade_file'] == facade_file
        assert parameters['setpoint_timeout_s'] > 0 and parameters['publish_rate_hz'] > 0
        covered += group_slice(facade.panel_ids, group, groups)
    assert sorted(group for group in (int(k['arguments'][1].split('/')[0])
                                      for k in panel_groups)) == list(range(groups))
    assert sorted(covered) == sorted(facade.panel_ids)  # every panel exactly once


@pytest.fixture
def small_facade_file(tmp_path, small_facade_text):
    path = tmp_path / 'small.yaml'
    path.write_text(small_facade_text('shading_target: 0.9'))
    return path


def test_launch_file_is_installed_by_setup_glob():
    assert LAUNCH_FILE.is_file()
    assert fnmatch.fnmatch(LAUNCH_FILE.name, SETUP_GLOB)


def test_declares_the_bringup_defaults(launch_module):
    defaults = _defaults(launch_module.generate_launch_description())
    assert defaults == {'facade_file': '', 'date': '2026-06-21', 'start': '12:00',
                        'end': '15:00', 'speedup': '360.0', 'panel_processes': '2',
                        'record_bag': '', 'rerun_viewer': '', 'rrd_path': '',
                        'weather_file': '', 'markers': 'false', 'site_profile': ''}


def test_defaults_launch_the_embedded_demonstrator(launch_module):
    nodes = _nodes(launch_module)
    _check_bringup(nodes, load_facade(DEFAULT_FACADE), 2, '')


def test_facade_file_and_three_panel_processes(launch_module, small_facade_file):
    nodes = _nodes(launch_module, facade_file=str(small_facade_file), panel_processes='3')
    facade = load_facade(small_facade_file)
    assert len(facade) == 4
    _check_bringup(nodes, facade, 3, str(small_facade_file))


def test_bad_facade_path_raises_facade_error(launch_module, tmp_path):
    missing = tmp_path / 'missing.yaml'
    with pytest.raises(FacadeError, match='missing.yaml'):
        _nodes(launch_module, facade_file=str(missing))


@pytest.mark.parametrize('processes', ['5', '0'])
def test_panel_processes_outside_the_panel_count_raises(launch_module, small_facade_file,
                                                        processes):
    with pytest.raises(ValueError, match=r'panel_processes must lie in \[1, 4\]'):
        _nodes(launch_module, facade_file=str(small_facade_file), panel_processes=processes)


@pytest.mark.parametrize('overrides, message', [
    ({'speedup': '0.5'}, 'speedup must lie in'),
    ({'speedup': 'fast'}, 'speedup must be a number'),
    ({'start': '16:00'}, 'end 15:00 must be after start 16:00'),
])
def test_bad_day_arguments_name_the_launch_argument(launch_module, overrides, message):
    with pytest.raises(ValueError, match=message):
        _nodes(launch_module, **overrides)


def test_the_recorder_and_the_bridge_on_request(launch_module, tmp_path):
    nodes = _nodes(launch_module, record_bag=str(tmp_path / 'bag'), rerun_viewer='none',
                   rrd_path=str(tmp_path / 'day.rrd'))
    (recorder,) = _by_executable(nodes, 'bag_recorder')
    assert _parameters(recorder) == {'use_sim_time': True, 'output': str(tmp_path / 'bag')}
    (bridge,) = _by_executable(nodes, 'rerun_bridge')
    assert _parameters(bridge) == {'use_sim_time': True, 'viewer': 'none', 'facade_file': '',
                                   'rrd_path': str(tmp_path / 'day.rrd')}
    assert len(_nodes(launch_module)) == 4  # neither by default
    (sun,) = _by_executable(nodes, 'sun_position_node')
    assert _parameters(sun)['start.wait_for_sun_listeners'] == 3  # coordinator and both


def test_the_markers_on_request_listen_to_the_sun_too(launch_module):
    nodes = _nodes(launch_module, markers='true')
    (markers,) = _by_executable(nodes, 'facade_markers')
    assert markers['namespace'] == '/facade'
    assert _parameters(markers) == {'use_sim_time': True, 'facade_file': ''}
    (sun,) = _by_executable(nodes, 'sun_position_node')
    assert _parameters(sun)['start.wait_for_sun_listeners'] == 2  # coordinator, markers
    assert not _by_executable(_nodes(launch_module), 'facade_markers')
    with pytest.raises(ValueError, match='markers must be true or false'):
        _nodes(launch_module, markers='yes')


def test_the_weather_node_on_request_follows_the_clock_and_respawns(launch_module, tmp_path):
    weather_file = tmp_path / 'site.epw'
    (weather,) = _by_executable(_nodes(launch_module, weather_file=str(weather_file)),
                                'weather_node')
    assert _parameters(weather) == {'use_sim_time': True, 'weather_file': str(weather_file)}
    assert weather['name'] == contract.WEATHER_NODE and weather['respawn']
    assert not _by_executable(_nodes(launch_module), 'weather_node')


def test_panel_processes_and_the_coordinator_respawn_the_clock_does_not(launch_module):
    nodes = _nodes(launch_module, record_bag='/tmp/unused_bag', rerun_viewer='none')
    respawned = {node.kwargs['executable'] for node in nodes if node.kwargs.get('respawn')}
    assert respawned == {'panel_group', 'coordinator_node'}
    for kwargs in (node.kwargs for node in nodes):
        if kwargs.get('respawn'):
            assert kwargs['respawn_delay'] > 0 and kwargs['respawn_max_retries'] >= 1


def test_a_site_profile_puts_every_node_on_it_with_a_port_of_its_own(launch_module, tmp_path):
    from xml.etree import ElementTree
    from flectofold_ros.sitenet import certificates, fastdds_profile
    certificates.make_authority(tmp_path, bits=2048)
    certificates.make_host(tmp_path, 'facade-1', '10.0.0.1', bits=2048)
    profile = tmp_path / 'facade-1.xml'
    profile.write_text(fastdds_profile.host_profile(tmp_path, 'facade-1', '10.0.0.1', 45100,
                                                    [('10.0.0.2', 45100)]))
    actions = _nodes(launch_module, site_profile=str(profile))
    nodes = [action for action in actions if 'executable' in getattr(action, 'kwargs', {})]
    assert len(nodes) == len(_nodes(launch_module)) == 4  # sun, coordinator, 2 panel groups
    if not STAND_INS:  # the real actions keep their values as substitutions
        return
    profiles, ports = [], []
    for action in actions:
        if getattr(action, 'name', None) == 'FASTRTPS_DEFAULT_PROFILES_FILE':
            profiles.append(action.value)
        elif action in nodes:
            root = ElementTree.parse(profiles[-1]).getroot()
            ports.append(int(next(e.text for e in root.iter() if e.tag.endswith('}port'))))
            ignoring = any(e.text == 'fastdds.ignore_local_endpoints' for e in root.iter())
            assert ignoring == (action.kwargs['executable'] == 'panel_group')
            dialled = [(e[0].text, int(e[1].text)) for e in root.iter()
                       if e.tag.endswith('}tcpv4')]
            assert dialled == [('10.0.0.2', 45100)] + [
                ('10.0.0.1', port) for port in range(45100, 45104) if port != ports[-1]]
    assert ports == [45100, 45101, 45102, 45103]
    shutil.rmtree(Path(profiles[-1]).parent)  # the launch file leaves them to its processes
    values = {a.name: a.value for a in actions[:4] if hasattr(a, 'value')}
    assert values['ROS_AUTOMATIC_DISCOVERY_RANGE'] == 'SUBNET'
    assert {a.name for a in actions if a not in nodes and not hasattr(a, 'value')} == \
        {'ROS_STATIC_PEERS', 'FASTDDS_BUILTIN_TRANSPORTS'}


def test_a_site_profile_that_is_not_there_is_refused_naming_the_argument(launch_module,
                                                                         tmp_path):
    with pytest.raises(ValueError, match='site_profile: .*cannot be read'):
        _nodes(launch_module, site_profile=str(tmp_path / 'absent.xml'))
