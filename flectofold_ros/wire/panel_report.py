"""What a panel process reports on ``/diagnostics``: the figures and the rules of its levels.

A panel process sends one REP-107 status per panel (component ``pressure loop``) and one for
itself (``panel process``); their keys are ``msg_docs/panel_node.md``'s, the ones other tools
read are named in :mod:`flectofold_ros.wire.contract`. :class:`ProcessReport` keeps the
process's counts between two reports and builds each status's level, message and figures;
the node turns them into messages (:mod:`flectofold_ros.runtime.diagnostics`).
"""

import math
from typing import Any, Optional

import numpy as np

from flectofold_model._validate import FloatArray, IntArray
from flectofold_model.control import Fault, PanelLoops, SetpointGuards, SetpointState
from flectofold_ros.wire import contract

#: REP-107 levels, as ``diagnostic_msgs/DiagnosticStatus`` gives them (one byte each).
OK, WARN, ERROR = b'\x00', b'\x01', b'\x02'
#: A loop further behind its clock than this says it is overloaded [s].
OVERLOADED_S = 1.0


class ProcessReport:
    """A panel process's counts between two reports and the content of its statuses.

    Parameters
    ----------
    count : int
        The process's panels.
    control_period_s : float
        The loop's period [s], against which the tick's jitter is measured.
    """

    def __init__(self, count: int, control_period_s: float) -> None:
        self.control_period_s = control_period_s
        self.tick_intervals_s: list[float] = []
        self._last_tick_s: Optional[float] = None
        self.tick_cpu_s = 0.0
        """CPU time of the ticks so far [s]."""
        self.states_published = 0
        """Facade-level states published."""
        self.states_skipped = 0
        """States the loop kept that a late tick did not publish."""
        self.fault_requests_applied = self.fault_requests_refused = 0
        self.setpoint_messages_refused = 0
        self.last_fault_refusal = self.last_setpoints_refusal = ''
        self._fault_refusals_since = self._setpoint_refusals_since = 0
        self.rejected_since_report = np.zeros(count, dtype=np.int64)
        """Setpoints refused per panel since its last status."""

    def tick(self, now_s: float) -> None:
        """Count a tick at ``now_s`` [s of ROS time]."""
        if self._last_tick_s is not None and now_s > self._last_tick_s:
            self.tick_intervals_s.append(now_s - self._last_tick_s)
        self._last_tick_s = now_s

    def refuse_fault_request(self, reason: str) -> None:
        """Count a refused fault request."""
        self.fault_requests_refused += 1
        self._fault_refusals_since += 1
        self.last_fault_refusal = reason

    def refuse_setpoints(self, reason: str) -> None:
        """Count a refused ``/facade/setpoints`` message."""
        self.setpoint_messages_refused += 1
        self._setpoint_refusals_since += 1
        self.last_setpoints_refusal = reason

    def panel(self, index: int, loops: PanelLoops, guards: SetpointGuards,
              states: Optional[IntArray], tracked: FloatArray,
              feedback: tuple[FloatArray, FloatArray],
              injected: str) -> tuple[bytes, str, dict[str, Any]]:
        """Return panel ``index``'s status: level, message, figures.

        Parameters
        ----------
        index : int
            The panel's row in ``loops`` and ``guards``.
        loops : flectofold_model.control.PanelLoops
        guards : flectofold_model.control.SetpointGuards
        states : numpy.ndarray
            The guards' states now (:meth:`SetpointGuards.states`), or None before the clock.
        tracked : numpy.ndarray
            The closures the loop tracks [closure].
        feedback : tuple of numpy.ndarray
            The loop's current closure [closure] and fold angle [rad]
            (:meth:`PanelLoops.current_feedback`).
        injected : str
            The panel's injected simulated faults, ``'none'`` if none.

        The level is the worst that applies, its message the first of: a circuit fault
        (ERROR); a setpoint timeout, refused setpoints since the last status, a supply too
        weak for the setpoint, an overloaded loop, an injected fault (WARN).
        """
        controller = loops.controller
        fault = controller.fault_at(index)
        state = SetpointGuards.STATES[states[index]] if states is not None \
            else SetpointState.WAITING
        rejected = self.rejected_since_report[index]
        level, message = OK, state.value
        if state is SetpointState.TIMED_OUT:
            level, message = WARN, (
                f'no setpoint for {guards.timeout_s:g} s: {guards.safe_behaviour.value}')
        elif rejected:
            level, message = WARN, (
                f'rejected {rejected} setpoint(s): {guards.last_rejection[index]}')
        elif controller.limited_by_supply[index]:
            level, message = WARN, 'supply too weak for the setpoint'
        if loops.behind_s > OVERLOADED_S and level == OK:
            level, message = WARN, (
                f'overloaded: the simulation is {loops.behind_s:.1f} s behind the clock')
        if injected != 'none' and level == OK:
            level, message = WARN, f'simulated fault injected: {injected}'
        if fault is not Fault.NONE:
            level, message = ERROR, f'circuit fault: {fault.value}'
        closure, fold_angle = feedback
        figures: dict[str, Any] = {
            'setpoint': float(guards.last_valid[index]),
            'tracked_closure': float(tracked[index]),
            'closure': float(closure[index]), 'fold_angle_rad': float(fold_angle[index]),
            'pressure_gauge_pa': float(controller.filtered_gauge_pa[index]),
            'target_gauge_pa': float(controller.target_gauge_pa[index]),
            'fault': fault.value, 'setpoint_state': state.value,
            contract.DIAGNOSTIC_SETPOINTS_REJECTED: int(guards.rejected[index]),
            'last_rejection': guards.last_rejection[index],
            contract.DIAGNOSTIC_FREE_AIR_NL: float(loops.free_air_used_nl[index]),
            contract.DIAGNOSTIC_INJECTED_FAULTS: injected,
        }
        return level, message, figures

    def reported(self, panels: range) -> None:
        """Start the panels of range ``panels`` counting afresh: their statuses went out."""
        self.rejected_since_report[panels.start:panels.stop] = 0

    def process(self, loops: PanelLoops,
                panel_count: int) -> tuple[bytes, str, dict[str, Any]]:
        """Return the process's status before its domain's: level, message, figures.

        The tick's jitter (|interval - period|, median and 99th percentile) covers the ticks
        since the last call. A fieldbus driver adds its link and timing; a lost link is an
        ERROR.
        """
        intervals = np.array(self.tick_intervals_s)
        self.tick_intervals_s = []
        jitter = np.abs(intervals - self.control_period_s)
        p50, p99 = (np.percentile(jitter, [50, 99]) if len(jitter) else (math.nan, math.nan))
        figures: dict[str, Any] = {
            'panels': panel_count, 'ticks': len(intervals),
            contract.DIAGNOSTIC_TICK_JITTER_P50_S: float(p50),
            contract.DIAGNOSTIC_TICK_JITTER_P99_S: float(p99),
            'tick_cpu_s': self.tick_cpu_s,
            'states_published': self.states_published,
            contract.DIAGNOSTIC_STATES_SKIPPED: self.states_skipped,
            'sim_time_skipped_s': loops.skipped_s,
            'loop_time_s': loops.time_s if loops.time_s is not None else math.nan,
            contract.DIAGNOSTIC_BEHIND_S: loops.behind_s,
            contract.DIAGNOSTIC_FAULT_REQUESTS_APPLIED: self.fault_requests_applied,
            contract.DIAGNOSTIC_FAULT_REQUESTS_REFUSED: self.fault_requests_refused,
            contract.DIAGNOSTIC_LAST_FAULT_REFUSAL: self.last_fault_refusal,
            contract.DIAGNOSTIC_SETPOINT_MESSAGES_REFUSED: self.setpoint_messages_refused,
            contract.DIAGNOSTIC_LAST_SETPOINTS_REFUSAL: self.last_setpoints_refusal,
        }
        level, message = OK, f'{panel_count} panels'
        statistics = getattr(loops.driver, 'statistics', None)
        if statistics is not None:
            figures.update(statistics(self.control_period_s))
            if loops.driver.comms_lost:
                level, message = ERROR, f'{message}; comms lost: {figures["modbus_last_error"]}'
        return level, message, figures

    def refusals(self, level: bytes, message: str) -> tuple[bytes, str]:
        """Add the refusals since the last call to a status: WARN at least after any."""
        for count, what, reason in (
                (self._fault_refusals_since, 'fault request(s)', self.last_fault_refusal),
                (self._setpoint_refusals_since, 'setpoints message(s)',
                 self.last_setpoints_refusal)):
            if count:
                level, message = max(level, WARN), f'{message}; refused {count} {what}: {reason}'
        self._fault_refusals_since = self._setpoint_refusals_since = 0
        return level, message
