"""ModbusCushions and PanelLoops against valve_terminal_sim in a separate process."""

import math
import time

import numpy as np
import pytest
from terminal_process import EXAMPLE_MAP, read_registers, Terminal, UNHURRIED_TIMEOUT_S

from flectofold_model.control import ControllerParameters, Fault, PanelLoops
from flectofold_ros.hardware.modbus_driver import ModbusCushions, validate_endpoint
from flectofold_ros.hardware.register_map import load_register_map, parse

pytestmark = pytest.mark.graph
PERIOD_S = 0.1


def _driver(port, register_map=None, **kwargs):
    kwargs.setdefault('timeout_s', UNHURRIED_TIMEOUT_S)
    return ModbusCushions(register_map or load_register_map(EXAMPLE_MAP), '127.0.0.1', port,
                          **kwargs)


def _loops(model, driver):
    actuation, cushion_map = model
    return PanelLoops(actuation, driver, PERIOD_S, ControllerParameters(hold_band_pa=60.0),
                      cushion_map=cushion_map)


def _run(loops, seconds, condition=lambda: False):
    """Run the loop on the wall clock for ``seconds`` or until ``condition()``."""
    deadline = time.monotonic() + seconds
    loops.advance_to(time.monotonic())
    while time.monotonic() < deadline and not condition():
        time.sleep(PERIOD_S)
        loops.advance_to(time.monotonic())
    return condition()


def test_written_openings_land_in_the_terminal_registers_and_move_its_plant():
    terminal = Terminal()
    try:
        driver = _driver(terminal.port)
        first = driver.read_pressure_pa()
        assert not driver.comms_lost and np.all(np.isfinite(first))
        assert np.all(driver.read_supply_pa() > 150e3)
        for _ in range(10):
            driver.read_pressure_pa()
            driver.write_valves([1.0, 0.0], [0.0, 0.25])
            time.sleep(PERIOD_S)
        assert read_registers(terminal.port, 0, 4) == [10000, 0, 0, 2500]
        filled = driver.read_pressure_pa()
        assert filled[0] > first[0] + 150.0  # 1 s of a wide open fill valve (noise: 20 Pa)
        assert driver.exchanges == 10 and driver.failures == 0
        figures = driver.statistics(PERIOD_S)
        assert 0.0 < figures['modbus_round_trip_p50_s'] < UNHURRIED_TIMEOUT_S, figures
        driver.close()
        assert read_registers(terminal.port, 0, 4) == [0, 0, 0, 0]  # closing shuts the valves
    finally:
        assert terminal.stop() == 0, ''.join(terminal.lines)


def test_the_loop_tracks_a_setpoint_through_the_terminal(model):
    terminal = Terminal()
    try:
        loops = _loops(model, _driver(terminal.port))
        loops.set_setpoints([0.6, 0.3])
        assert _run(loops, 20.0, lambda: np.all(np.abs(loops.closure - [0.6, 0.3]) < 0.03)), \
            loops.closure
        assert all(f is Fault.NONE for f in loops.fault)
        loops.close()
    finally:
        terminal.stop()


def test_a_killed_terminal_latches_comms_lost_and_a_restarted_one_gets_the_safe_action(model):
    terminal = Terminal()
    port = terminal.port
    try:
        driver = _driver(port, max_backoff_s=0.4)
        loops = _loops(model, driver)
        loops.set_setpoints([0.8, 0.8])
        # some 3 s of exchanges (counted, not timed: a loaded machine stretches them)
        assert _run(loops, 60.0, lambda: driver.exchanges >= 30 and not driver.comms_lost)
        terminal.kill()
        assert _run(loops, 20.0, lambda: all(f is Fault.COMMS_LOST for f in loops.fault))
        assert driver.comms_lost and np.all(np.isnan(loops.measured_pa))
        skipped = driver.writes_skipped
        # nothing is written while the link is down
        assert _run(loops, 20.0, lambda: driver.writes_skipped > skipped)
        # the loop's command is the safe one: fill shut, vent open
        command = loops.controller.last_command
        assert np.all(command.fill_opening == 0.0) and np.all(command.vent_opening == 1.0)
        terminal = Terminal(port=port)
        assert _run(loops, 30.0, lambda: not driver.comms_lost)
        _run(loops, 0.5)
        # back: the latched fault's vent reaches the terminal, the fill stays shut
        assert read_registers(port, 0, 4) == [0, 10000, 0, 10000]
        assert all(f is Fault.COMMS_LOST for f in loops.fault)
        loops.reset_faults()
        assert _run(loops, 20.0, lambda: np.all(np.abs(loops.closure - 0.8) < 0.03)), \
            loops.closure
        assert driver.reconnects >= 2
        loops.close()
    finally:
        terminal.kill()


def test_a_wrong_unit_id_is_comms_lost_with_the_modbus_exception_and_writes_nothing(model):
    terminal = Terminal()
    try:
        document = _wrong_unit_map()
        driver = _driver(terminal.port, parse(document, 'unit7.yaml'))
        loops = _loops(model, driver)
        loops.set_setpoints([1.0, 1.0])
        _run(loops, 1.0)
        assert driver.comms_lost and driver.exchanges == 0
        assert 'unit 7' in driver.last_error and 'exception 11' in driver.last_error, \
            driver.last_error
        assert all(f is Fault.COMMS_LOST for f in loops.fault)
        assert read_registers(terminal.port, 0, 4) == [0, 0, 0, 0]
    finally:
        terminal.stop()


def _wrong_unit_map():
    from flectofold_model.safe_yaml import read_yaml
    document = read_yaml(EXAMPLE_MAP)
    document['unit_id'] = 7
    return document


def test_a_slow_terminal_times_out_into_comms_lost_and_never_gets_a_fill_command(model):
    terminal = Terminal('--response-delay-s', '0.2')
    try:
        driver = _driver(terminal.port, timeout_s=0.05)
        loops = _loops(model, driver)
        loops.set_setpoints([1.0, 1.0])
        started = time.monotonic()
        _run(loops, 2.0)
        elapsed_s = time.monotonic() - started
        assert driver.comms_lost and driver.exchanges == 0, driver.last_error
        assert all(f is Fault.COMMS_LOST for f in loops.fault)
        # The back-off (0.1 s, doubling to 2 s) skips the periods between attempts: only
        # attempts at 0, 0.1, 0.3, 0.7, 1.5 s... time out, not one per period (14 in 2 s
        # without it). Counted, so a loaded machine that stretches the run stretches the bound.
        attempts = 2 + math.log2(elapsed_s / 0.1 + 1.0) + elapsed_s / 2.0
        assert driver.failures <= attempts, (driver.failures, elapsed_s)
        assert read_registers(terminal.port, 0, 4) == [0, 0, 0, 0]  # no fill ever written
    finally:
        terminal.stop()


def test_an_out_of_range_sensor_count_is_a_dropout_and_that_panel_fills_no_more(model):
    terminal = Terminal('--force-input', '0=32767')  # channel 0's cushion sensor: overrange
    try:
        driver = _driver(terminal.port)
        loops = _loops(model, driver)
        loops.set_setpoints([1.0, 0.5])
        assert _run(loops, 20.0, lambda: loops.fault[0] is Fault.SENSOR_DROPOUT)
        assert loops.fault[1] is Fault.NONE
        assert not driver.comms_lost and math.isnan(driver.read_pressure_pa()[0])
        _run(loops, 0.3)
        fill, vent = read_registers(terminal.port, 0, 2)
        assert fill == 0 and vent == 10000
    finally:
        terminal.stop()


@pytest.mark.parametrize('host, port', [('', 502), ('a b', 502), ('h', 0), ('h', 70000),
                                        ('h', True), (None, 502)])
def test_a_bad_endpoint_is_refused(host, port):
    with pytest.raises(ValueError, match='modbus (host|port)'):
        validate_endpoint(host, port)


def test_the_terminal_refuses_bad_input_in_one_line_and_stops_cleanly_on_sigterm(tmp_path):
    import signal
    import subprocess
    import sys
    bad = tmp_path / 'map.yaml'
    bad.write_text(EXAMPLE_MAP.read_text().replace('unit_id: 1', 'unit_id: 0'))
    result = subprocess.run([sys.executable, '-m', 'flectofold_ros', 'valve_terminal_sim',
                             '--map', str(bad), '--port', '0'], capture_output=True, text=True,
                            timeout=60)
    assert result.returncode == 2, result
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith('valve_terminal_sim: ') and \
        'unit_id' in lines[0], result.stderr
    terminal = Terminal()
    assert terminal.host == '127.0.0.1'
    taken = subprocess.run([sys.executable, '-m', 'flectofold_ros', 'valve_terminal_sim',
                            '--map', str(EXAMPLE_MAP), '--port', str(terminal.port)],
                           capture_output=True, text=True, timeout=60)
    assert taken.returncode == 2 and taken.stderr.count('\n') == 1 and \
        'cannot listen' in taken.stderr, taken
    assert terminal.stop(signal.SIGTERM) == 0
    assert 'Traceback' not in ''.join(terminal.lines)
