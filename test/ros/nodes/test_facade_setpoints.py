"""``/facade/setpoints``: one message commands the panels of every process, or none of them.

``msg_docs/panel_node.md``: each panel process takes its own panels' entries as if they had
come on their ``setpoint`` topics (a refused closure is that panel's refusal); a message
whose lists do not pair up, that names a panel twice or that names no panel of the facade is
refused whole by every process and counted in its ``/diagnostics``.
"""

import math
import re

import pytest
from ros_graph import domain_for, Graph
from sensor_msgs.msg import JointState

from flectofold_ros.runtime.interfaces import publisher, subscription
from flectofold_ros.wire import contract, panel_states

pytestmark = pytest.mark.graph
PROCESSES = {'panel_group_a': ['r00c00', 'r00c01'], 'panel_group_b': ['r01c00', 'r01c01']}
PANELS = [panel for panels in PROCESSES.values() for panel in panels]


class Probe:
    """Sends facade setpoints; keeps each panel's tracked setpoint and the processes' status."""

    def __init__(self, graph):
        self.graph = graph
        self.setpoints = publisher(graph.node, contract.FACADE_SETPOINTS)
        self.tracked = {}
        self.panels = {}  # panel id -> its last status values
        self.reports = {name: [] for name in PROCESSES}  # process -> [(level, message, values)]
        lookup = panel_states.index_lookup(PANELS)
        subscription(graph.node, contract.PANEL_STATES, lambda m: self._on_states(m, lookup),
                     contract.OBSERVER)
        subscription(graph.node, contract.DIAGNOSTICS, self._on_diagnostics)

    def _on_states(self, message, lookup):
        table = panel_states.unpack(message)
        for index, setpoint in zip(panel_states.indices(table, lookup), table['setpoint']):
            if index >= 0:
                self.tracked[PANELS[index]] = float(setpoint)

    def _on_diagnostics(self, message):
        for status in message.status:
            values = {kv.key: kv.value for kv in status.values}
            if status.hardware_id in PROCESSES:
                self.reports[status.hardware_id].append((ord(status.level), status.message,
                                                         values))
            elif status.hardware_id in PANELS:
                self.panels[status.hardware_id] = values

    def send(self, names, positions):
        self.setpoints.publish(JointState(name=names, position=positions))

    def tracks(self, wanted):
        return all(self.tracked.get(p) == pytest.approx(v, abs=1e-6) for p, v in wanted.items())

    def send_until_tracked(self, names, positions, wanted, timeout_s=20.0):
        """Send (again each second: the first may go before every process matched) until seen."""
        for _ in range(int(timeout_s)):
            self.send(names, positions)
            if self.graph.spin_until(lambda: self.tracks(wanted), 1.0):
                return True
        return False

    def refused(self, process):
        reports = self.reports[process]
        return _refused(reports[-1]) if reports else 0

    def report_of_refusal(self, process, refused_before):
        """Return the first report of ``process`` with more refusals than ``refused_before``."""
        return next((report for report in self.reports[process]
                     if _refused(report) > refused_before), None)


def _refused(report):
    return int(report[2][contract.DIAGNOSTIC_SETPOINT_MESSAGES_REFUSED])


def test_one_message_commands_the_panels_of_two_processes_and_a_bad_one_none_of_them():
    graph = Graph(domain_for(41))
    try:
        groups = [graph.start('panel_group', '--panels', ','.join(panels), '--name', name,
                              '--ros-args', '-p', 'setpoint_timeout_s:=120.0',
                              '-p', 'diagnostics_period_s:=0.5')
                  for name, panels in PROCESSES.items()]
        probe = Probe(graph)
        assert graph.spin_until(lambda: len(probe.tracked) == len(PANELS)
                                and all(probe.reports.values()), 60.0), \
            [graph.stop(group)[1] for group in groups]

        first = dict(zip(PANELS, [0.2, 0.4, 0.6, 0.8]))
        assert probe.send_until_tracked(PANELS, list(first.values()), first), probe.tracked

        # Only some panels named: the others keep theirs.
        assert probe.send_until_tracked(['r01c01'], [0.1], {**first, 'r01c01': 0.1})
        first['r01c01'] = 0.1

        # A NaN for one panel is that panel's refusal; the others take theirs.
        rejected_before = int(probe.panels['r00c00'].get(
            contract.DIAGNOSTIC_SETPOINTS_REJECTED, 0))
        taken = {**first, 'r00c01': 0.5, 'r01c00': 0.5, 'r01c01': 0.5}
        assert probe.send_until_tracked(PANELS, [math.nan, 0.5, 0.5, 0.5], taken), probe.tracked
        assert graph.spin_until(lambda: int(probe.panels['r00c00'].get(
            contract.DIAGNOSTIC_SETPOINTS_REJECTED, 0)) > rejected_before, 5.0)

        # Messages refused whole, by both processes: nothing moves.
        bad = [(PANELS + ['r99c99'], [0.9] * 5, 'r99c99 not of this facade'),
               (PANELS, [0.9] * 3, '4 name.*3 position'),
               (['r00c00', 'r01c00', 'r00c00'], [0.9] * 3, 'r00c00 named more than once')]
        for names, positions, reason in bad:
            refused = {name: probe.refused(name) for name in PROCESSES}
            probe.send(names, positions)
            assert graph.spin_until(lambda: all(probe.refused(name) > refused[name]
                                                for name in PROCESSES), 10.0), probe.reports
            for name in PROCESSES:
                level, message, values = probe.report_of_refusal(name, refused[name])
                assert level == 1, (name, message)  # WARN in the report after the refusal
                assert re.search(reason, values[contract.DIAGNOSTIC_LAST_SETPOINTS_REFUSAL]), \
                    values
            graph.spin_for(0.5)
            assert probe.tracks(taken), probe.tracked

        codes = [graph.stop(group) for group in groups]
    finally:
        graph.close()
    assert all(code == 0 for code, _ in codes), codes
