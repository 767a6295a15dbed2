"""The day's plan, shared by the facade command and the launch file (pure, no graph)."""

import pytest
from rclpy.utilities import remove_ros_args

from flectofold_model.facade import build_facade, load_facade
from flectofold_ros.bringup.cli import option_name
from flectofold_ros.bringup.plan import (CLOCK_RATE_HZ, MAX_LAG_S, plan_day, PlanError,
                                         ros_argument)


@pytest.fixture(scope='module')
def demonstrator():
    return load_facade()


def day(facade, **settings):
    values = {'facade_file': '', 'date': '2026-06-21', 'start': '12:00', 'end': '15:00',
              'speedup': 360.0, 'panel_processes': 2}
    values.update(settings)
    return plan_day(facade, **values)


def test_the_span_is_local_time_at_the_facade_s_offset(demonstrator):
    plan = day(demonstrator)
    assert plan.start_iso == '2026-06-21T12:00:00+02:00'
    assert plan.end_iso == '2026-06-21T15:00:00+02:00'
    assert plan.end_epoch_s - plan.start_epoch_s == 3 * 3600


def test_settings_scale_with_the_speedup(demonstrator):
    fast, slow = day(demonstrator), day(demonstrator, speedup=10.0)
    assert fast.clock_tick_s == 360.0 / CLOCK_RATE_HZ
    # A tick over a second: the watchdog allows twice the lag the bringup tolerates.
    assert fast.setpoint_timeout_s == 2 * MAX_LAG_S and slow.setpoint_timeout_s == 10.0
    # Once per 10 clock ticks: 5 Hz of wall time, whatever the speed-up.
    assert fast.publish_rate_hz == pytest.approx(1 / 72.0) and slow.publish_rate_hz == 0.5
    assert fast.state_period_s == pytest.approx(72.0)
    # The heartbeat: ten per watchdog time, at least every second of simulated time.
    assert fast.setpoint_period_s == fast.setpoint_timeout_s / 10 == 60.0
    assert slow.setpoint_period_s == 1.0


def test_every_node_gets_its_parameters_as_plain_typed_values(demonstrator):
    plan = day(demonstrator, facade_file='/data/facade.yaml')
    sun = plan.sun_parameters()
    assert sun['mode'] == 'simulated' and sun['latitude_deg'] == demonstrator.site.latitude_deg
    counts = {'start.wait_for_panels', 'start.wait_for_sun_listeners'}
    assert all(type(value) in (float, str) for name, value in sun.items() if name not in counts)
    assert all(type(sun[name]) is int for name in counts)  # integer parameters
    panel = plan.panel_parameters()
    assert panel == {'use_sim_time': True, 'facade_file': '/data/facade.yaml',
                     'setpoint_timeout_s': plan.setpoint_timeout_s,
                     'publish_rate_hz': plan.publish_rate_hz}
    assert plan.coordinator_parameters()['setpoint_period_s'] == plan.setpoint_period_s


@pytest.mark.parametrize('facade_file', ['', '/data/my facade.yaml'])
def test_child_commands_are_valid_ros_arguments(demonstrator, facade_file):
    plan = day(demonstrator, facade_file=facade_file)
    commands = [plan.panel_group_command(0), plan.panel_group_command(1),
                plan.recorder_command('/out/bag'), plan.bridge_command('', 'none')]
    for command in commands:
        assert command[1:4] == ['-m', 'flectofold_ros', command[3]]
        remove_ros_args(args=command)  # rcl parses every -p name:=value, or raises
    group = commands[0]
    assert group[4:6] == ['--group', '0/2']
    assert (group[6:8] == ['--facade', facade_file]) == bool(facade_file)


@pytest.mark.parametrize('value, text', [
    (True, 'true'), (False, 'false'), (3, '3'), (0.1, '0.1'), (360.0, '360.0'),
    ('', "''"), ("it's", "'it''s'"), ('true', "'true'"), ('1.5', "'1.5'")])
def test_parameter_values_keep_their_type_on_the_command_line(value, text):
    assert ros_argument(value) == text


@pytest.mark.parametrize('settings, message', [
    ({'speedup': 0.5}, r'--speedup must lie in \[1, 10000\], got 0.5'),
    ({'speedup': 'fast'}, "--speedup must be a number, got 'fast'"),
    ({'panel_processes': 40}, r'--panel-processes must lie in \[0, 36\]'),
    ({'panel_processes': '2.5'}, '--panel-processes must be a whole number'),
    ({'end': '11:00'}, '--end 11:00 must be after --start 12:00'),
    ({'date': '2026-13-01'}, "--date '2026-13-01' is not a date"),
    ({'start': '25:00'}, "--start '25:00' is not a local time"),
])
def test_bad_settings_name_the_option_as_the_command_line_spells_it(demonstrator, settings,
                                                                    message):
    with pytest.raises(PlanError, match=message):
        day(demonstrator, name=option_name, **settings)


def test_the_launch_file_spells_settings_as_launch_arguments(small_facade_text):
    facade = build_facade(small_facade_text('shading_target: 0.9'))
    with pytest.raises(PlanError, match=r'panel_processes must lie in \[1, 4\]'):
        day(facade, panel_processes='0', least_processes=1)
    with pytest.raises(PlanError, match='end 15:00 must be after start 16:00'):
        day(facade, start='16:00')
