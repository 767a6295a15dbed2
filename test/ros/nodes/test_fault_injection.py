"""Faults injected into a real panel_group over DDS, and the pressure loop's reaction to each.

One process hosts seven panels under a simulated clock at 5x. Each tracks closure 0.6, then
gets one fault on ``/facade/inject_fault``: the loop must name it as the model tests say,
take its safe state, and come back after the repair (``restore``) and ``reset_faults``.
"""

import time

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
import numpy as np
import pytest
from ros_graph import domain_for, Graph
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Float64
from std_srvs.srv import Trigger

from flectofold_ros.runtime.interfaces import client, publisher, subscription
from flectofold_ros.wire import contract, panel_states

pytestmark = pytest.mark.graph
PANELS = ['r00c00', 'r00c01', 'r00c02', 'r00c03', 'r00c04', 'r00c05', 'r01c00']
HEALTHY, BIG_LEAK, SMALL_LEAK, SUPPLY, STUCK, FILL, DROPOUT = PANELS
START_S = 1.78e9
SPEEDUP = 5.0
SETPOINT = 0.6
MAX_GAUGE_PA = 12e3
ATMOSPHERE_PA = 101325.0


class FaultProbe:
    """Drives the clock and the setpoints, sends fault requests, keeps what the panels say."""

    def __init__(self, graph):
        node = self.node = graph.node
        self.graph = graph
        self.clock = publisher(node, contract.CLOCK)
        self.inject = publisher(node, contract.INJECT_FAULT)
        self.setpoints = {p: publisher(node, contract.SETPOINT.of(p)) for p in PANELS}
        self.faults = {p: [] for p in PANELS}
        for panel in PANELS:
            subscription(node, contract.FAULT.of(panel),
                         lambda m, p=panel: self.faults[p].append(m.data))
        self.tables, self.panel_status, self.process_status = [], {}, []
        subscription(node, contract.PANEL_STATES, self._on_states)
        subscription(node, contract.DIAGNOSTICS, self._on_diagnostics)
        self.started = time.monotonic()
        node.create_timer(0.02, self._tick)
        node.create_timer(0.5, self._send_setpoints)

    def now_s(self):
        return START_S + SPEEDUP * (time.monotonic() - self.started)

    def _tick(self):
        now = self.now_s()
        self.clock.publish(Clock(clock=Time(sec=int(now), nanosec=int(now % 1 * 1e9))))

    def _send_setpoints(self):
        for publisher_ in self.setpoints.values():
            publisher_.publish(Float64(data=SETPOINT))

    def _on_states(self, message):
        table = panel_states.unpack(message)
        self.tables.append((message.header.stamp.sec + message.header.stamp.nanosec * 1e-9,
                            table))

    def _on_diagnostics(self, message):
        for status in message.status:
            figures = {kv.key: kv.value for kv in status.values}
            if status.hardware_id in PANELS:
                self.panel_status[status.hardware_id] = (status, figures)
            elif 'panels' in figures:
                self.process_status.append((status, figures))

    def send(self, kind, panels, **values):
        self.inject.publish(DiagnosticStatus(
            name=kind, hardware_id=panels,
            values=[KeyValue(key=k, value=str(v)) for k, v in values.items()]))

    def fault(self, panel):
        return self.faults[panel][-1] if self.faults[panel] else None

    def column(self, panel, name, since_s=0.0):
        """``name`` of ``panel`` in every state stamped after ``since_s``."""
        return np.array([table[name][PANELS.index(panel)] for stamp, table in self.tables
                         if stamp > since_s])

    def word_after(self, panel, since_s):
        """``panel``'s fault words in the states stamped after ``since_s``."""
        return {contract.FAULTS[code] for code in self.column(panel, 'fault', since_s)}

    def states_after(self, since_s):
        """Whether a state stamped after ``since_s`` (simulated time) has come."""
        return bool(self.tables) and self.tables[-1][0] > since_s

    def closure(self, panel):
        return self.tables[-1][1]['closure'][PANELS.index(panel)] if self.tables else np.nan

    def injected(self, panel):
        status = self.panel_status.get(panel)
        return status[1][contract.DIAGNOSTIC_INJECTED_FAULTS] if status else None

    def reset(self, panel):
        service = client(self.node, contract.reset_faults_service(panel),
                         contract.RESET_FAULTS_TYPE)
        assert service.wait_for_service(timeout_sec=30.0)
        future = service.call_async(Trigger.Request())
        assert self.graph.spin_until(future.done, 30.0)
        return future.result().message


@pytest.fixture(scope='module')
def faulted():
    """Bring the seven panels to closure 0.6, give each its fault, wait for the reactions."""
    graph = Graph(domain_for(17))
    process = graph.start('panel_group', '--panels', ','.join(PANELS), '--ros-args',
                          '-p', 'use_sim_time:=true', group=True)
    probe = FaultProbe(graph)
    try:
        settled = graph.spin_until(lambda: probe.tables and all(
            abs(probe.closure(p) - SETPOINT) < 0.02 for p in PANELS), 60.0)
        assert settled, (process.poll(), [probe.closure(p) for p in PANELS])
        injected_s = probe.now_s()
        probe.send('leak', BIG_LEAK, conductance_m3_s_pa=5e-8)
        probe.send('leak', SMALL_LEAK, conductance_m3_s_pa=2e-10)
        probe.send('supply_loss', SUPPLY)
        probe.send('sensor_stuck', STUCK)
        probe.send('fill_valve_stuck_open', FILL)
        probe.send('sensor_dropout', DROPOUT, duration_s=4.0)
        expected = {BIG_LEAK: 'leak', SUPPLY: 'supply_lost', STUCK: 'sensor_stuck',
                    FILL: 'fill_valve_stuck', DROPOUT: 'sensor_dropout'}
        named = graph.spin_until(
            lambda: all(probe.fault(p) == f for p, f in expected.items()), 40.0 / SPEEDUP * 3)
        assert named, {p: probe.faults[p] for p in PANELS}
        # the safe states, for a while: 20 s of the panels' simulated time
        safe_since = probe.now_s()
        assert graph.spin_until(lambda: probe.states_after(safe_since + 20.0), 60.0)
        yield graph, process, probe, injected_s
    finally:
        graph.stop(process)
        graph.close()


def test_each_fault_is_named_and_the_healthy_panels_keep_tracking(faulted):
    graph, process, probe, injected_s = faulted
    for panel in (HEALTHY, SMALL_LEAK):  # a leak the fill valve makes up is no fault
        assert set(probe.faults[panel]) == {'none'}, panel
        assert probe.closure(panel) == pytest.approx(SETPOINT, abs=0.02), panel
    assert probe.injected(SMALL_LEAK) == 'leak(2e-10)'
    # the vented panels spring open; stuck and jammed ones cannot show it in their pressure
    for panel in (BIG_LEAK, SUPPLY):
        assert probe.closure(panel) < 0.05, panel
    for panel in (BIG_LEAK, SUPPLY, STUCK, FILL, DROPOUT):
        status, figures = probe.panel_status[panel]
        assert status.level == DiagnosticStatus.ERROR and figures['fault'] != 'none', panel


def test_a_fill_valve_stuck_open_never_takes_the_cushion_past_its_maximum(faulted):
    graph, process, probe, injected_s = faulted
    gauge = probe.column(FILL, 'pressure_pa', injected_s) - ATMOSPHERE_PA
    assert gauge.size > 100
    assert gauge.max() < MAX_GAUGE_PA, gauge.max()
    # The open vent out-flows the jammed fill valve: the panel is held short of closed,
    # it cannot be opened (as in the model's test).
    assert probe.column(FILL, 'closure', injected_s)[-1] < 1.0


def test_a_timed_dropout_ends_by_itself(faulted):
    graph, process, probe, injected_s = faulted
    assert graph.spin_until(lambda: probe.injected(DROPOUT) == 'none', 30.0)
    assert probe.fault(DROPOUT) == 'sensor_dropout'  # latched until reset
    assert probe.reset(DROPOUT) == 'cleared sensor_dropout'
    assert graph.spin_until(lambda: probe.fault(DROPOUT) == 'none' and
                            abs(probe.closure(DROPOUT) - SETPOINT) < 0.02, 30.0)


def test_supply_restore_and_reset_bring_the_panel_back(faulted):
    graph, process, probe, injected_s = faulted
    probe.reset(SUPPLY)
    reset_s = probe.now_s()  # the panel's clock was no further on at the reset
    # the supply is still gone: named again, in the states from 4 s (simulated) on
    assert graph.spin_until(lambda: probe.states_after(reset_s + 2.0 * 2), 30.0)
    assert probe.word_after(SUPPLY, reset_s + 2.0 * 2) == {'supply_lost'}
    assert graph.spin_until(lambda: probe.fault(SUPPLY) == 'supply_lost', 30.0), \
        probe.faults[SUPPLY]
    probe.send('supply_restore', SUPPLY)
    assert graph.spin_until(lambda: probe.injected(SUPPLY) == 'none', 30.0)
    assert probe.reset(SUPPLY) == 'cleared supply_lost'
    assert graph.spin_until(lambda: probe.fault(SUPPLY) == 'none' and
                            abs(probe.closure(SUPPLY) - SETPOINT) < 0.02, 30.0)


def test_restore_repairs_one_panel_and_leaves_the_others_faulted(faulted):
    graph, process, probe, injected_s = faulted
    probe.send('restore', BIG_LEAK)
    assert graph.spin_until(lambda: probe.injected(BIG_LEAK) == 'none', 30.0)
    assert probe.injected(SMALL_LEAK) == 'leak(2e-10)'
    assert probe.injected(STUCK) == 'sensor_stuck'
    assert probe.reset(BIG_LEAK) == 'cleared leak'
    assert graph.spin_until(lambda: probe.fault(BIG_LEAK) == 'none' and
                            abs(probe.closure(BIG_LEAK) - SETPOINT) < 0.02, 30.0)
    probe.reset(STUCK)
    reset_s = probe.now_s()
    # not repaired: named again, in the states from 10 s (simulated) on
    assert graph.spin_until(lambda: probe.states_after(reset_s + 5.0 * 2), 30.0)
    assert probe.word_after(STUCK, reset_s + 5.0 * 2) == {'sensor_stuck'}
    assert graph.spin_until(lambda: probe.fault(STUCK) == 'sensor_stuck', 30.0), \
        probe.faults[STUCK]


def test_a_noisy_sensor_reads_noisier(faulted):
    graph, process, probe, injected_s = faulted
    calm = np.std(probe.column(HEALTHY, 'pressure_pa', injected_s))
    probe.send('sensor_noise', HEALTHY, noise_std_pa=400.0)
    assert graph.spin_until(lambda: probe.injected(HEALTHY) == 'sensor_noise(400)', 30.0)
    noisy_since = probe.now_s()
    assert graph.spin_until(lambda: probe.states_after(noisy_since + 40.0), 60.0)
    noisy = probe.column(HEALTHY, 'pressure_pa', noisy_since)
    assert noisy.size > 200
    assert calm < 60.0 and 300.0 < np.std(noisy) < 800.0, (calm, np.std(noisy))
    assert probe.fault(HEALTHY) == 'none'  # the loop has no noise monitor: it keeps tracking
    assert abs(np.mean(noisy) - np.mean(probe.column(HEALTHY, 'pressure_pa', injected_s))) \
        < 150.0
    probe.send('restore', HEALTHY)
    assert graph.spin_until(lambda: probe.injected(HEALTHY) == 'none', 30.0)


@pytest.mark.parametrize('kind, panels, values, reason', [
    ('explode', HEALTHY, {}, 'unknown fault kind'),
    ('sensor_stuck', 'r09c09', {}, 'unknown panel'),
    ('leak', HEALTHY, {'conductance_m3_s_pa': 'nan'}, 'must lie in'),
    ('leak', HEALTHY, {'conductance_m3_s_pa': '-1e-9'}, 'must lie in'),
    ('sensor_noise', HEALTHY, {'noise_std_pa': 'inf'}, 'must lie in'),
    ('sensor_stuck', ','.join(['r00c00'] * 5000), {}, 'longer than'),
])
def test_a_bad_request_is_refused_counted_and_changes_nothing(faulted, kind, panels, values,
                                                              reason):
    graph, process, probe, injected_s = faulted

    def counts():
        figures = probe.process_status[-1][1]
        return (int(figures[contract.DIAGNOSTIC_FAULT_REQUESTS_REFUSED]),
                int(figures[contract.DIAGNOSTIC_FAULT_REQUESTS_APPLIED]))
    assert graph.spin_until(lambda: probe.process_status, 30.0)
    refused, applied = counts()
    before = {p: probe.injected(p) for p in PANELS}
    probe.send(kind, panels, **values)
    assert graph.spin_until(lambda: counts()[0] == refused + 1, 30.0), counts()
    status, figures = probe.process_status[-1]
    assert reason in figures[contract.DIAGNOSTIC_LAST_FAULT_REFUSAL]
    assert status.level == DiagnosticStatus.WARN and reason in status.message
    assert counts()[1] == applied
    graph.spin_for(1.2)
    assert {p: probe.injected(p) for p in PANELS} == before


def test_a_request_for_another_process_panel_is_neither_applied_nor_refused(faulted):
    graph, process, probe, injected_s = faulted
    assert graph.spin_until(lambda: probe.process_status, 30.0)
    before = dict(probe.process_status[-1][1])
    probe.send('sensor_stuck', 'r05c05')
    graph.spin_for(2.5)
    after = probe.process_status[-1][1]
    for key in (contract.DIAGNOSTIC_FAULT_REQUESTS_REFUSED,
                contract.DIAGNOSTIC_FAULT_REQUESTS_APPLIED):
        assert after[key] == before[key]
