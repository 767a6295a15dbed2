"""Panel nodes hardware-in-the-loop: a panel_group drives valve_terminal_sim over Modbus TCP."""

import time

from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
import pytest
from ros_graph import domain_for, Graph
from std_msgs.msg import Float64
from terminal_process import (EXAMPLE_MAP, read_registers, REGULATOR_MAP, Terminal,
                              UNHURRIED_TIMEOUT_S)

from flectofold_model.actuation import DEMONSTRATOR_PLANT
from flectofold_ros.runtime.interfaces import client, publisher, subscription
from flectofold_ros.wire import contract

pytestmark = pytest.mark.graph
PANELS = ('r00c00', 'r00c01')


class Probe:
    """Sends setpoints to both panels; keeps their closure, fault and the process's figures."""

    def __init__(self, graph):
        node = graph.node
        self.graph = graph
        self.setpoints = {p: publisher(node, contract.SETPOINT.of(p)) for p in PANELS}
        self.closure = {p: [] for p in PANELS}
        self.fault = {p: [] for p in PANELS}
        for panel in PANELS:
            subscription(node, contract.CLOSURE.of(panel),
                         lambda m, p=panel: self.closure[p].append(m.data))
            subscription(node, contract.FAULT.of(panel),
                         lambda m, p=panel: self.fault[p].append(m.data))
        self.process = []
        subscription(node, contract.DIAGNOSTICS, self._on_diagnostics)
        self.inject = publisher(node, contract.INJECT_FAULT)
        self.reset = {p: client(node, contract.reset_faults_service(p),
                                contract.RESET_FAULTS_TYPE) for p in PANELS}

    def _on_diagnostics(self, message):
        for status in message.status:
            figures = {kv.key: kv.value for kv in status.values}
            if 'panels' in figures:
                self.process.append((status, figures))

    def hold(self, closure, condition, timeout_s):
        """Send ``closure`` to both panels at 5 Hz until ``condition()``."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            for publisher_ in self.setpoints.values():
                publisher_.publish(Float64(data=closure))
            if self.graph.spin_until(condition, 0.2):
                return True
        return False

    def tracking(self, closure, tolerance=0.03):
        return all(self.closure[p] and abs(self.closure[p][-1] - closure) < tolerance
                   for p in PANELS)

    def faulted(self, word):
        return all(self.fault[p] and self.fault[p][-1] == word for p in PANELS)

    def comms(self, word):
        return bool(self.process) and self.process[-1][1].get('comms') == word

    def reset_all(self):
        from std_srvs.srv import Trigger
        for panel, service in self.reset.items():
            assert service.wait_for_service(timeout_sec=10.0)
            future = service.call_async(Trigger.Request())
            assert self.graph.spin_until(future.done, 10.0)


def _panels(graph, port, *extra, map_file=EXAMPLE_MAP):
    return graph.start('panel_group', '--panels', ','.join(PANELS), '--ros-args',
                       '-p', 'hardware:=modbus', '-p', f'modbus.map_file:={map_file}',
                       '-p', f'modbus.port:={port}', '-p', 'diagnostics_period_s:=0.5',
                       '-p', f'modbus.timeout_s:={UNHURRIED_TIMEOUT_S}', *extra)


def test_a_facade_runs_hardware_in_the_loop_through_the_terminal_and_survives_its_loss():
    graph = Graph(domain_for(26))
    terminal = Terminal('--panels', ','.join(PANELS), env=graph.env)
    port = terminal.port
    try:
        panels = _panels(graph, port)
        probe = Probe(graph)
        assert probe.hold(0.6, lambda: probe.tracking(0.6), 60.0), probe.closure
        fill_0, vent_0, fill_1, vent_1 = read_registers(port, 0, 4)
        assert vent_0 == vent_1 == 0 or fill_0 == fill_1 == 0  # a loop, not both open
        assert graph.spin_until(lambda: probe.comms('ok'), 30.0)
        status, figures = probe.process[-1]
        assert status.level == DiagnosticStatus.OK, status.message
        # Timings, not latency limits (a loaded machine holds replies and ticks): measured, and
        # an exchange within the Modbus timeout, a loop at its period (0.1 s by default).
        round_trip, jitter_p50, jitter_p99 = (float(figures[key]) for key in (
            'modbus_round_trip_p50_s', 'loop_period_jitter_p50_s', 'loop_period_jitter_p99_s'))
        assert 0.0 < round_trip < UNHURRIED_TIMEOUT_S, figures
        assert 0.0 < jitter_p50 < 0.05 and jitter_p50 <= jitter_p99 < 1.0, figures
        assert int(figures['modbus_exchanges']) > 10

        # fault injection is for simulated cushions only
        probe.inject.publish(DiagnosticStatus(name='sensor_dropout', hardware_id=PANELS[0],
                                              values=[KeyValue(key='duration_s', value='1')]))
        assert graph.spin_until(lambda: probe.process and 'simulated' in probe.process[-1][1]
                                .get(contract.DIAGNOSTIC_LAST_FAULT_REFUSAL, ''), 30.0)

        terminal.kill()  # the terminal loses power
        assert probe.hold(0.6, lambda: probe.faulted('comms_lost'), 30.0), probe.fault
        assert graph.spin_until(lambda: probe.comms('lost'), 30.0)
        assert probe.process[-1][0].level == DiagnosticStatus.ERROR
        assert 'comms lost' in probe.process[-1][0].message

        terminal = Terminal('--panels', ','.join(PANELS), port=port, env=graph.env)
        assert probe.hold(0.6, lambda: probe.comms('ok'), 60.0)
        assert read_registers(port, 0, 4) == [0, 10000, 0, 10000]  # the latched vent
        probe.reset_all()
        assert probe.hold(0.3, lambda: probe.tracking(0.3) and probe.faulted('none'), 60.0), \
            (probe.closure, probe.fault)
        code, output = graph.stop(panels)
        assert code == 0, output
        assert read_registers(port, 0, 4) == [0, 0, 0, 0], output  # closing shuts the valves
    finally:
        terminal.kill()
        graph.close()


def test_a_facade_tracks_through_pressure_regulators_set_to_its_targets():
    from flectofold_model.control import ControllerParameters, PressureController
    from flectofold_model.control.panel_loops import facade_actuation
    from flectofold_model.facade import load_facade
    from flectofold_ros.hardware.register_map import load_register_map
    _, cushion_map = facade_actuation(load_facade(), PANELS)
    targets_pa = PressureController(cushion_map, DEMONSTRATOR_PLANT, ControllerParameters()) \
        .pressure_for_closure([0.3, 0.3])
    counts = [int(c.regulator.encode(p)) for c, p in
              zip(load_register_map(REGULATOR_MAP).channels, targets_pa)]
    graph = Graph(domain_for(28))
    terminal = Terminal('--panels', ','.join(PANELS), map_file=REGULATOR_MAP, env=graph.env)
    try:
        panels = _panels(graph, terminal.port, map_file=REGULATOR_MAP)
        probe = Probe(graph)
        assert probe.hold(0.3, lambda: probe.tracking(0.3), 60.0), probe.closure
        assert read_registers(terminal.port, 0, 2) == counts
        assert graph.spin_until(lambda: probe.comms('ok'), 30.0)
        code, output = graph.stop(panels)
        assert code == 0, output
        assert read_registers(terminal.port, 0, 2) == counts, output  # closing holds the air
    finally:
        terminal.kill()
        graph.close()


@pytest.mark.parametrize('arguments, reason', [
    ([], 'needs modbus.map_file'),
    (['-p', 'modbus.map_file:=/nonexistent/map.yaml'], 'cannot be read'),
    (['-p', f'modbus.map_file:={EXAMPLE_MAP}', '-p', 'modbus.port:=0'], 'modbus.port'),
    (['-p', f'modbus.map_file:={EXAMPLE_MAP}', '-p', 'modbus.host:=a b'], 'modbus host'),
    (['-p', f'modbus.map_file:={EXAMPLE_MAP}', '-p', 'use_sim_time:=true'], 'wall clock'),
    (['-p', f'modbus.map_file:={REGULATOR_MAP}', '-p', 'control.hold_band_pa:=0.0'],
     'hold_band_pa > 0'),
])
def test_bad_modbus_settings_are_refused_at_start_in_one_line(arguments, reason):
    graph = Graph(domain_for(27))
    try:
        process = graph.start('panel_group', '--panels', ','.join(PANELS), '--ros-args',
                              '-p', 'hardware:=modbus', *arguments)
        code, output = process.wait(timeout=60.0), process.stdout.read()
    finally:
        graph.close()
    lines = output.strip().splitlines()
    assert code == 2 and len(lines) == 1 and 'Traceback' not in output, output
    assert lines[0].startswith('panel_group: ') and reason in lines[0], output


def test_a_map_with_another_channel_count_is_refused():
    graph = Graph(domain_for(27))
    try:
        process = graph.start('panel_node', '--ros-args', '-r', '__ns:=/facade/r00c00',
                              '-p', 'hardware:=modbus', '-p', f'modbus.map_file:={EXAMPLE_MAP}')
        code, output = process.wait(timeout=60.0), process.stdout.read()
    finally:
        graph.close()
    assert code == 2 and '2 channel(s) for 1 panel(s)' in output, output
