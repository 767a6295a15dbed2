"""What a panel process publishes of its loop's states, and when (``msg_docs/panel_node.md``).

:class:`PanelOutputs` takes the states a process's loop kept since the last tick and
publishes them: the facade-level topics (``/facade/panel_states``, ``/facade/joint_states``)
at ``publish_rate_hz`` (:class:`~flectofold_model.control.PublishDecimator`); each panel's own
state topics at that rate while it moves and at a heartbeat at rest
(:class:`~flectofold_model.control.decimation.Heartbeats`); each panel's latched ``fault`` and
``status`` where they changed.
"""

import array

import numpy as np
from rclpy.time import Time
from sensor_msgs.msg import JointState, PointCloud2, PointField

from flectofold_model.control import PublishDecimator
from flectofold_model.control.decimation import Heartbeats
from flectofold_model.control.panel_loops import LoopSample
from flectofold_ros.runtime.interfaces import publisher
from flectofold_ros.wire import contract, panel_states

#: A tick publishes at most this many of the states its loop kept since the last one (the
#: newest): a loop catching up hours keeps thousands, which would starve the process.
MAX_STATES_PER_TICK = 20
_FAULT_STATUS = contract.STATUSES.index(contract.STATUS_FAULT)


class PanelOutputs:
    """A panel process's state publishing.

    Parameters
    ----------
    settings : rclpy.node.Node
        The process's settings node, which publishes the facade-level topics.
    panels : list of PanelNode
        The panels, in the order of the loop's rows; each publishes its own topics.
    positions_enu : numpy.ndarray
        The panels' origins in the site's frame (N, 3) [m].
    kind : str
        The panel kind (its flaps name the joints).
    state_period_s, heartbeat_s : float
        Time between two published states [s]; at rest, between two of a panel's own [s].
    slack_s : float
        How early a state may be and still be due [s].
    report : flectofold_ros.wire.panel_report.ProcessReport
        Counts the states published and skipped.
    """

    def __init__(self, settings, panels, positions_enu, kind, state_period_s, heartbeat_s,
                 slack_s, report):
        count = len(panels)
        self.panels, self.report = panels, report
        self._decimator = PublishDecimator(state_period_s, slack_s)
        self._heartbeats = Heartbeats(count, heartbeat_s, slack_s)
        self._last_sequence = 0
        self._published_fault = np.full(count, -1)
        self._published_status = np.full(count, -1)
        ids = [panel.panel_id for panel in panels]
        self._table = panel_states.new_table(count)
        self._table['x'], self._table['y'], self._table['z'] = positions_enu.T
        self._table['row'], self._table['column'] = panel_states.id_numbers(ids)
        self._cloud = PointCloud2()
        self._joint_states = JointState(name=[
            name for panel_id in ids for name in contract.flap_joint_names(panel_id, kind)])
        self._flaps_per_panel = len(contract.FLAPS[kind])
        self._cloud_publisher = publisher(settings, contract.PANEL_STATES)
        self._joints_publisher = publisher(settings, contract.FACADE_JOINT_STATES)

    def latched(self, fault, status, fault_action):
        """Publish each panel's ``fault`` and ``status`` (codes) where they changed.

        A panel with a fault has the status ``fault``; a new fault is logged as an error with
        the ``fault_action`` taken.
        """
        status = np.where(fault != 0, _FAULT_STATUS, status)
        self._table['fault'], self._table['status'] = fault, status
        for index in np.flatnonzero(fault != self._published_fault).tolist():
            word = contract.FAULTS[fault[index]]
            self.panels[index].publish_fault(word)
            if word != contract.NO_FAULT:
                self.panels[index].get_logger().error(f'circuit fault {word}: {fault_action}')
        for index in np.flatnonzero(status != self._published_status).tolist():
            self.panels[index].publish_status(contract.STATUSES[status[index]])
        self._published_fault[:], self._published_status[:] = fault, status

    def samples(self, loops, setpoints):
        """Publish the states ``loops`` kept since the last call; ``setpoints`` tracked now.

        The facade-level topics carry each state due at the rate (of more than
        :data:`MAX_STATES_PER_TICK`, the newest, counting the rest as skipped), each with
        its own stamp; the panels' own topics the newest only, so that a late tick does not
        publish a thousand panels' states several times over and fall later still.
        """
        samples = loops.samples_since(self._last_sequence, MAX_STATES_PER_TICK)
        if samples:
            self.report.states_skipped += samples[0].sequence - self._last_sequence - 1
        due = []
        for sample in samples:
            self._last_sequence = sample.sequence
            if self._decimator.due(sample.time_s):
                self._facade_state(sample, setpoints)
                due.append(sample)
        if due:
            self._panel_states(due[-1], np.logical_or.reduce([s.active for s in due]))

    def first_state(self, loops, now_s, setpoints):
        """Publish the loop's present state at ``now_s`` [s]: the panels are up.

        As soon as the process knows the time, also while a bringup holds its clock at the
        start of the day (then the loop runs no period and keeps no state).
        """
        closure, fold_angle = loops.current_feedback()
        sample = LoopSample(0, now_s, closure, fold_angle, loops.measured_pa,
                            loops.controller.active)
        self._facade_state(sample, setpoints)
        self._panel_states(sample, sample.active)

    def _panel_states(self, sample, active):
        stamp = _stamp(sample.time_s)
        due = self._heartbeats.due(sample.time_s, active, np.isfinite(sample.measured_pa))
        for index in np.flatnonzero(due).tolist():
            self.panels[index].publish_state(stamp, float(sample.closure[index]),
                                             float(sample.fold_angle_rad[index]),
                                             float(sample.measured_pa[index]))

    def _facade_state(self, sample, setpoints):
        stamp = _stamp(sample.time_s)
        table = self._table
        table['closure'], table['fold_angle_rad'] = sample.closure, sample.fold_angle_rad
        table['pressure_pa'], table['setpoint'] = sample.measured_pa, setpoints
        table['active'] = sample.active
        self._cloud_publisher.publish(panel_states.fill_message(self._cloud, table, stamp,
                                                                PointField))
        joints = self._joint_states
        joints.header.stamp = stamp
        joints.position = array.array('d', np.repeat(sample.fold_angle_rad,
                                                     self._flaps_per_panel).tobytes())
        self._joints_publisher.publish(joints)
        self.report.states_published += 1


def _stamp(time_s):
    return Time(nanoseconds=round(time_s * 1e9)).to_msg()
