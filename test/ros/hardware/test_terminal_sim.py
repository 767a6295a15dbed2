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
