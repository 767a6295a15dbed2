"""Regulator channels: ModbusCushions and PanelLoops against valve_terminal_sim in a process."""

import time

import numpy as np
import pytest
from terminal_process import (EXAMPLE_MAP, read_registers, REGULATOR_MAP, Terminal,
                              UNHURRIED_TIMEOUT_S)
import yaml

from flectofold_model.actuation import ATMOSPHERIC_PRESSURE_PA
from flectofold_model.control import ControllerParameters, Fault, PanelLoops, SafeAction
from flectofold_model.safe_yaml import read_yaml
from flectofold_ros.hardware.modbus_driver import _pymodbus_client, ModbusCushions
from flectofold_ros.hardware.register_map import load_register_map

pytestmark = pytest.mark.graph
PERIOD_S = 0.1


@pytest.fixture()
def mixed_map(tmp_path):
    """Write the example valve map, channel 1's valves replaced by a regulator at address 2."""
    document = read_yaml(EXAMPLE_MAP)
    channel = document['channels'][1]
    del channel['fill'], channel['vent']
    channel['regulator'] = {'address': 2, 'gauge_pa_per_count': 2.0, 'max_count': 10000}
    path = tmp_path / 'mixed.yaml'
    path.write_text(yaml.safe_dump(document))
    return path


class RecordingClient:
    """The driver's pymodbus client, keeping every block it is asked to write."""

    def __init__(self, host, port, timeout_s):
        self.client = _pymodbus_client(host, port, timeout_s)
        self.writes = []

    def __getattr__(self, name):
        return getattr(self.client, name)

    def write_registers(self, address, values, **options):
        self.writes.append(list(values))
        return self.client.write_registers(address, values, **options)


def _loops(model, port, map_file=REGULATOR_MAP, **options):
    clients = []

    def recording(host, port_, timeout_s):
        clients.append(RecordingClient(host, port_, timeout_s))
        return clients[-1]

    options.setdefault('timeout_s', UNHURRIED_TIMEOUT_S)  # none of these tests is about timeouts
    driver = ModbusCushions(load_register_map(map_file), '127.0.0.1', port,
                            client_factory=recording, **options)
    actuation, cushion_map = model
    loops = PanelLoops(actuation, driver, PERIOD_S, ControllerParameters(hold_band_pa=60.0),
                       cushion_map=cushion_map)
    return loops, clients[0]


def _run(loops, seconds, condition=lambda: False, each=lambda: None):
    """Run the loop on the wall clock for ``seconds`` or until ``condition()``."""
    deadline = time.monotonic() + seconds
    loops.advance_to(time.monotonic())
    while time.monotonic() < deadline and not condition():
        time.sleep(PERIOD_S)
        loops.advance_to(time.monotonic())
        each()
    return condition()


def _counts(loops, gauge_pa):
    """Return the regulator channels' setpoint registers for setpoints (N,) [Pa gauge]."""
    return [int(c.regulator.encode(p)) for c, p in zip(loops.driver.map.channels, gauge_pa)
            if c.regulator is not None]


def test_the_setpoint_registers_follow_the_loop_reference_and_the_panels_track(model):
    terminal = Terminal(map_file=REGULATOR_MAP)
    try:
        loops, _ = _loops(model, terminal.port)
        loops.set_setpoints([0.6, 0.3])
        seen = []

        def compare():  # the registers hold what this period wrote: the reference, in counts
            reference = np.clip(loops.controller.reference_gauge_pa, 0.0, None)
            seen.append((read_registers(terminal.port, 0, 2), _counts(loops, reference),
                         loops.time_s))

        assert _run(loops, 20.0, lambda: seen and seen[-1][0][0] > seen[0][0][0] + 500,
                    each=compare), seen
        assert all(registers == wanted for registers, wanted, _ in seen), seen
        # ramping: 2000 Pa/s is 1000 counts/s of the loop's clock (not a jump, not a crawl)
        rate = (seen[-1][0][0] - seen[0][0][0]) / (seen[-1][2] - seen[0][2])
        assert 500.0 < rate < 1100.0, (rate, seen)
        assert _run(loops, 20.0, lambda: np.all(np.abs(loops.closure - [0.6, 0.3]) < 0.03)), \
            loops.closure
        assert all(f is Fault.NONE for f in loops.fault)
        at_target = _counts(loops, loops.controller.target_gauge_pa)
        assert read_registers(terminal.port, 0, 2) == at_target
        loops.close()
        # closing leaves the regulators at their setpoints: they hold the air
        assert read_registers(terminal.port, 0, 2) == at_target
    finally:
        assert terminal.stop() == 0, ''.join(terminal.lines)


def test_a_vent_safe_action_writes_0_pa_and_a_hold_keeps_the_setpoint_it_had(model):
    terminal = Terminal(map_file=REGULATOR_MAP)
    try:
        loops, _ = _loops(model, terminal.port)
        loops.set_safe_action(SafeAction.HOLD, [1])
        loops.set_setpoints([0.6, 0.6])
        assert _run(loops, 20.0, lambda: np.all(np.abs(loops.closure - 0.6) < 0.03))
        before = read_registers(terminal.port, 0, 2)
        assert min(before) > 1000, before
        pressure = loops.measured_pa.copy()
        loops.controller.latch_fault(Fault.LEAK)  # as the loop's own monitors would
        loops.set_setpoints([0.9, 0.9])  # the held one must not go there
        # the regulator exhausts it
        assert _run(loops, 20.0, lambda: loops.measured_pa[0] < pressure[0] - 300.0), \
            (loops.measured_pa, pressure)
        assert read_registers(terminal.port, 0, 2) == [0, before[1]]
        assert abs(loops.measured_pa[1] - pressure[1]) < 100.0  # and holds this one
        loops.reset_faults()
        assert _run(loops, 20.0, lambda: np.all(np.abs(loops.closure - 0.9) < 0.03)), \
            loops.closure
        loops.close()
    finally:
        terminal.stop()


def test_a_killed_terminal_latches_comms_lost_and_a_restarted_one_gets_0_pa_first(model):
    terminal = Terminal(map_file=REGULATOR_MAP)
    port = terminal.port
    try:
        loops, client = _loops(model, port, max_backoff_s=0.4)
        driver = loops.driver
        loops.set_setpoints([0.8, 0.8])
        assert _run(loops, 60.0, lambda: not driver.comms_lost and client.writes and
                    min(client.writes[-1]) > 1000), client.writes[-1:]
        terminal.kill()
        assert _run(loops, 20.0, lambda: all(f is Fault.COMMS_LOST for f in loops.fault))
        written, skipped = len(client.writes), driver.writes_skipped
        assert _run(loops, 20.0, lambda: driver.writes_skipped >= skipped + 5)  # 5 periods
        assert len(client.writes) == written
        terminal = Terminal(port=port, map_file=REGULATOR_MAP)
        assert _run(loops, 30.0, lambda: not driver.comms_lost)
        assert client.writes[written] == [0, 0]  # the first write once back: the vent
        _run(loops, 0.5)
        assert read_registers(port, 0, 2) == [0, 0]
        assert all(f is Fault.COMMS_LOST for f in loops.fault)
        loops.reset_faults()
        assert _run(loops, 20.0, lambda: np.all(np.abs(loops.closure - 0.8) < 0.03)), \
            loops.closure
        loops.close()
    finally:
        terminal.kill()


def test_after_a_link_loss_the_first_write_is_0_pa_to_vent_and_what_was_left_to_hold(model):
    import signal
    terminal = Terminal(map_file=REGULATOR_MAP)
    try:
        loops, client = _loops(model, terminal.port, max_backoff_s=0.2)
        loops.set_safe_action(SafeAction.HOLD, [1])
        loops.set_setpoints([0.8, 0.8])
        assert _run(loops, 20.0, lambda: np.all(np.abs(loops.closure - 0.8) < 0.03))
        held = client.writes[-1][1]
        # The link is lost for longer than the fail-safe timeout: the terminal lets air out.
        terminal.process.send_signal(signal.SIGSTOP)
        try:
            _run(loops, 1.0)  # at least: longer than the fail-safe's 0.5 s
            assert _run(loops, 20.0, lambda: all(f is Fault.COMMS_LOST for f in loops.fault))
            written = len(client.writes)
        finally:
            terminal.process.send_signal(signal.SIGCONT)
        assert _run(loops, 30.0, lambda: len(client.writes) > written)
        vent, hold = client.writes[written]
        left_pa = loops.measured_pa[1] - ATMOSPHERIC_PRESSURE_PA  # read just before that write
        assert vent == 0, client.writes[written - 1:]
        # the held channel stays at what was left, not refilled to what it held
        assert hold == _counts(loops, [0.0, left_pa])[1] and hold < held - 100, (held, hold)
        loops.close()
    finally:
        terminal.stop()


def test_a_mixed_terminal_tracks_through_its_valves_and_its_regulator(model, mixed_map):
    terminal = Terminal(map_file=mixed_map)
    try:
        loops, client = _loops(model, terminal.port, mixed_map)
        loops.set_setpoints([0.6, 0.3])
        assert _run(loops, 20.0, lambda: np.all(np.abs(loops.closure - [0.6, 0.3]) < 0.03)), \
            loops.closure
        assert all(f is Fault.NONE for f in loops.fault)
        assert all(len(block) == 3 for block in client.writes)  # one write, both kinds
        fill, vent, setpoint = read_registers(terminal.port, 0, 3)
        assert fill <= 10000 and vent <= 10000
        assert [setpoint] == _counts(loops, loops.controller.target_gauge_pa)
        loops.close()
    finally:
        terminal.stop()
