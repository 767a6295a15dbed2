"""The simulated clock misbehaves under a real panel process: pauses, jumps forward and back.

A ``panel_group`` on ``use_sim_time`` follows the test's ``/clock``. Through a pause, a jump of
three hours forward and one of four hours back it keeps publishing its state, stamped on the
new time. Of a jump forward the loop simulates at most an hour (``max_catch_up_s``); the rest
is reported (``sim_time_skipped_s``, the plant held through it), and the watchdog's safe state
follows until setpoints come again. Throughout, every panel is in a documented state and no
cushion is above the loop's maximum (``max_gauge_pa``, 12 kPa, ``actuation.md``).
"""

import time

from builtin_interfaces.msg import Time
import numpy as np
import pytest
from ros_graph import domain_for, Graph
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Float64

from flectofold_ros.runtime.interfaces import publisher, subscription
from flectofold_ros.wire import contract, panel_states

pytestmark = pytest.mark.graph
PANELS = ('r00c00', 'r00c01')
ATMOSPHERE_PA, MAX_GAUGE_PA = 101325.0, 12e3
START_S = 1_800_000_000.0


class ClockedPanels:
    """The test's clock, setpoints to both panels, and every state the process publishes."""

    def __init__(self, graph):
        self.graph, self.now_s = graph, START_S
        self.clock = publisher(graph.node, contract.CLOCK)
        self.setpoints = [publisher(graph.node, contract.SETPOINT.of(panel)) for panel in PANELS]
        self.states, self.skipped_s = [], 0.0
        subscription(graph.node, contract.PANEL_STATES, self._on_states)
        subscription(graph.node, contract.DIAGNOSTICS, self._on_diagnostics)

    def _on_states(self, message):
        self.states.append((panel_states.stamp_ns(message.header) * 1e-9,
                            panel_states.unpack(message).copy()))

    def _on_diagnostics(self, message):
        for status in message.status:
            for item in status.values:
                if item.key == 'sim_time_skipped_s':
                    self.skipped_s = max(self.skipped_s, float(item.value))

    def tick(self, sim_step_s):
        self.now_s += sim_step_s
        seconds = int(self.now_s)
        self.clock.publish(Clock(clock=Time(sec=seconds,
                                            nanosec=int((self.now_s - seconds) * 1e9))))

    def run(self, wall_s, closure=None, speed=4.0, clock=True):
        """Run the clock at ``speed`` for ``wall_s`` (or hold it), sending ``closure``."""
        deadline = time.monotonic() + wall_s
        while time.monotonic() < deadline:
            if clock:
                self.tick(0.05 * speed)
            if closure is not None:
                for setpoint in self.setpoints:
                    setpoint.publish(Float64(data=closure))
            self.graph.spin_for(0.05)

    def run_until(self, condition, closure=None, speed=4.0, timeout_s=60.0):
        """Run the clock as :meth:`run` until ``condition()`` holds; return whether it did.

        The clock advances per step, not per wall second: a slow machine takes more wall time
        for the same simulated time, and the panels' states say when they got there.
        """
        deadline = time.monotonic() + timeout_s
        while not condition() and time.monotonic() < deadline:
            self.run(0.05, closure, speed)
        return condition()

    def newest(self):
        return self.states[-1] if self.states else (None, None)

    def newest_after(self, since_s):
        """Return the newest state's table if it is stamped after ``since_s``, else None."""
        stamp_s, table = self.newest()
        return table if stamp_s is not None and stamp_s > since_s else None

    def all_status(self, word, since_s=0.0):
        """Whether both panels have status ``word`` in the newest state after ``since_s``."""
        table = self.newest_after(since_s)
        return table is not None and status_words(table) == [word] * 2

    def check_invariants(self):
        """Every state so far: a documented status and fault, the cushion below its maximum."""
        for _, table in self.states:
            assert np.all(table['status'] < len(contract.STATUSES)), table['status']
            assert np.all(table['fault'] < len(contract.FAULTS)), table['fault']
            gauge = table['pressure_pa'] - ATMOSPHERE_PA
            assert np.all(np.nan_to_num(gauge) <= MAX_GAUGE_PA), gauge


def status_words(table):
    return [contract.STATUSES[code] for code in table['status'].tolist()]


def test_pauses_and_jumps_of_the_clock_keep_the_panels_safe_and_publishing():
    graph = Graph(domain_for(53))
    try:
        process = graph.start('panel_group', '--panels', ','.join(PANELS), '--ros-args',
                              '-p', 'use_sim_time:=true', '-p', 'setpoint_timeout_s:=5.0')
        panels = ClockedPanels(graph)
        deadline = time.monotonic() + 120
        while not panels.states and time.monotonic() < deadline:
            panels.run(0.5, closure=0.6)
        assert panels.states, 'the panel process never published its state'
        filled_from_s = panels.now_s  # 32 s simulated: they fill toward 0.6
        assert panels.run_until(lambda: panels.newest_after(filled_from_s + 32.0) is not None,
                                closure=0.6)
        stamp_s, table = panels.newest()
        assert status_words(table) == ['tracking'] * 2
        assert np.all(table['closure'] > 0.3), table['closure']

        # a pause: the clock stops for 3 s of wall time; no state of a new instant, no timeout
        before = len(panels.states)
        paused_at_s = panels.now_s
        panels.run(3.0, closure=0.6, clock=False)
        assert all(stamp <= paused_at_s + 1e-6 for stamp, _ in panels.states[before:])
        assert panels.run_until(lambda: panels.all_status('tracking', paused_at_s),
                                closure=0.6), panels.newest()

        # three hours forward, no setpoints: the loop simulates the last hour of it (its
        # catch-up limit), the plant holds through the rest; the watchdog vents
        panels.now_s += 3 * 3600.0
        assert panels.run_until(
            lambda: panels.all_status('setpoint_timeout', paused_at_s + 3 * 3600.0)
            and panels.skipped_s > 3600.0), (panels.newest(), panels.skipped_s)
        assert 2 * 3600.0 - 10.0 < panels.skipped_s < 2 * 3600.0 + 10.0, panels.skipped_s
        # setpoints again: tracking again
        assert panels.run_until(lambda: panels.all_status('tracking'), closure=0.5), \
            panels.newest()

        # four hours back (a bag replayed in a loop): the loop restarts its clock there
        panels.now_s -= 4 * 3600.0
        back_at_s = panels.now_s
        # tracking, in states on the new time (within its first minute, not the old time)
        assert panels.run_until(lambda: panels.newest()[0] < back_at_s + 60.0
                                and panels.all_status('tracking', back_at_s),
                                closure=0.5), (panels.newest(), back_at_s)
        panels.check_invariants()
        assert process.poll() is None, 'the panel process died'
        code, output = graph.stop(process)
    finally:
        graph.close()
    assert code == 0 and 'Traceback' not in output, output
    assert 'the clock jumped' in output
