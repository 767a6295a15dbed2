"""The simulated terminal's registers and its fieldbus-loss fail-safe (no server, no process)."""

import numpy as np
from pymodbus.constants import ExcCodes
import pytest
from terminal_process import EXAMPLE_MAP

from flectofold_model.facade import load_facade
from flectofold_ros.hardware.register_map import load_register_map
from flectofold_ros.hardware.terminal_sim import SimulatedTerminal, terminal_plant


class Clock:
    def __init__(self):
        self.now_s = 100.0

    def __call__(self):
        return self.now_s


@pytest.fixture()
def terminal():
    register_map = load_register_map(EXAMPLE_MAP)
    clock = Clock()
    return SimulatedTerminal(register_map, terminal_plant(register_map, load_facade()),
                             clock=clock), clock


def test_without_writes_for_the_fail_safe_timeout_fill_shuts_and_vent_opens(terminal):
    terminal, clock = terminal
    assert terminal.put('holding', 0, [10000, 0, 10000, 0]) is None
    clock.now_s += 0.4
    terminal.advance()
    assert not terminal.fail_safe_active
    np.testing.assert_array_equal(terminal.openings()[0], [1.0, 1.0])
    clock.now_s += 0.2  # 0.6 s since the write > timeout_s 0.5
    terminal.advance()
    fill, vent = terminal.openings()
    assert terminal.fail_safe_active and np.all(fill == 0.0) and np.all(vent == 1.0)
    terminal.put('holding', 0, [0, 0, 0, 0])  # the next write takes over again
    assert not terminal.fail_safe_active


def test_the_plant_moves_with_the_wall_clock_and_the_openings(terminal):
    terminal, clock = terminal
    before = terminal.map.decode_inputs(terminal.get('input', 0, 3))[0]
    terminal.put('holding', 0, [10000, 0, 0, 0])
    clock.now_s += 0.3
    after = terminal.map.decode_inputs(terminal.get('input', 0, 3))[0]
    assert after[0] > before[0] + 60.0 and abs(after[1] - before[1]) < 100.0


def test_requests_outside_the_map_or_out_of_range_are_modbus_exceptions(terminal):
    terminal, _ = terminal
    assert terminal.get('input', 2, 2) is ExcCodes.ILLEGAL_ADDRESS
    assert terminal.get('coils', 0, 1) is ExcCodes.ILLEGAL_FUNCTION
    assert terminal.put('holding', 3, [0, 0]) is ExcCodes.ILLEGAL_ADDRESS
    assert terminal.put('holding', 0, [10001]) is ExcCodes.ILLEGAL_VALUE
    assert terminal.outputs == [0, 0, 0, 0]


def test_a_forced_input_holds_its_count(terminal):
    terminal, _ = terminal
    forced = SimulatedTerminal(terminal.map, terminal.plant, forced_inputs={1: 32767})
    assert forced.get('input', 1, 1) == [32767]
    with pytest.raises(ValueError, match='not in the input block'):
        SimulatedTerminal(terminal.map, terminal.plant, forced_inputs={9: 0})


@pytest.fixture()
def mixed():
    """Build a terminal: channel 0 has valves (outputs 0, 1), channel 1 a regulator (output 2)."""
    from flectofold_model.safe_yaml import read_yaml
    from flectofold_ros.hardware.register_map import parse
    document = read_yaml(EXAMPLE_MAP)
    channel = document['channels'][1]
    del channel['fill'], channel['vent']
    channel['regulator'] = {'address': 2, 'gauge_pa_per_count': 2.0, 'max_count': 10000}
    register_map = parse(document, 'mixed.yaml')
    clock = Clock()
    return SimulatedTerminal(register_map, terminal_plant(register_map, load_facade()),
                             clock=clock), clock


def _hold(terminal, clock, outputs, seconds):
    """Write ``outputs`` every 0.1 s for ``seconds`` of the terminal's clock."""
    for _ in range(round(seconds / 0.1)):
        assert terminal.put('holding', 0, outputs) is None
        for _ in range(10):
            clock.now_s += 0.01
            terminal.advance()


def test_a_regulator_channel_holds_its_setpoint_and_a_valve_channel_its_openings(mixed):
    terminal, clock = mixed
    _hold(terminal, clock, [0, 10000, 750], 8.0)  # channel 1: 1500 Pa gauge
    pressure = terminal.plant.gauge_pressure_pa
    assert pressure[1] == pytest.approx(1500.0, abs=5.0) and pressure[0] < 5.0
    fill, vent = terminal.openings()
    assert (fill[0], vent[0]) == (0.0, 1.0) and fill[1] < 0.05 and vent[1] == 0.0
    assert terminal.setpoints_gauge_pa()[1] == 1500.0
    _hold(terminal, clock, [0, 10000, 250], 8.0)  # down to 500 Pa: the regulator exhausts
    assert terminal.plant.gauge_pressure_pa[1] == pytest.approx(500.0, abs=5.0)


def test_the_fail_safe_sets_a_regulator_to_0_pa_and_it_exhausts(mixed):
    terminal, clock = mixed
    _hold(terminal, clock, [0, 0, 750], 8.0)
    held = terminal.plant.gauge_pressure_pa[1]
    clock.now_s += 0.6  # no write for longer than timeout_s 0.5
    terminal.advance()
    assert terminal.fail_safe_active and terminal.setpoints_gauge_pa()[1] == 0.0
    fill, vent = terminal.openings()
    assert fill[1] == 0.0 and vent[1] == 1.0
    for _ in range(100):
        clock.now_s += 0.01
        terminal.advance()
    assert terminal.plant.gauge_pressure_pa[1] < held - 100.0


def test_a_setpoint_count_outside_the_regulator_range_is_refused(mixed):
    terminal, _ = mixed
    assert terminal.put('holding', 0, [0, 0, 10001]) is ExcCodes.ILLEGAL_VALUE
    assert terminal.put('holding', 2, [10000]) is None and terminal.outputs == [0, 0, 10000]
