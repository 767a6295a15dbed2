"""What the bringup knows of its facade's day, learnt from the topics as any other node would.

The monitor subscribes to ``/clock``, to ``/facade/panel_states`` (every panel of each panel
process in one message: its stamp is the loop time of the state; closure, tracked setpoint,
fault and status) and to ``/diagnostics`` for the panels' cumulative counters (air drawn,
setpoints refused). Three subscriptions, whatever the number of panels; it never looks inside
another node. The bringup asks it whether the graph is ready, how far the slowest panel loop
trails the clock, and for the progress line and summary.
"""

import math
import time

import numpy as np
from rclpy.node import Node

from flectofold_ros.bringup.plan import local_time
from flectofold_ros.runtime.interfaces import subscription
from flectofold_ros.wire import contract, panel_states


#: Name ending of a panel process's own status on /diagnostics (``panel.py``).
PROCESS_STATUS = ': panel process'


class Monitor(Node):
    """Node ``/facade/facade_monitor``: listens to the day of ``facade``."""

    COUNTERS = (contract.DIAGNOSTIC_FREE_AIR_NL, contract.DIAGNOSTIC_SETPOINTS_REJECTED)

    def __init__(self, facade, **kwargs):
        super().__init__(contract.MONITOR_NODE, namespace=contract.FACADE_NODE_NAMESPACE,
                         **kwargs)
        self.facade = facade
        self.clock_s = None
        count = len(facade)
        self._lookup = {panel_id: i for i, panel_id in enumerate(facade.panel_ids)}
        self._index = panel_states.index_lookup(facade.panel_ids)
        self.state_stamp_s = np.full(count, np.nan)
        """Loop time of each panel's newest state [s]; NaN until heard."""
        self.closure = np.full(count, np.nan)
        self.setpoint = np.full(count, np.nan)
        """The closure each panel tracks, as it reports it."""
        self.fault = np.zeros(count, dtype=np.uint8)
        self.status = np.zeros(count, dtype=np.uint8)
        self.counters = {key: np.full(count, np.nan) for key in self.COUNTERS}
        self.restarted_at_s = np.full(count, np.nan)
        """Clock when each panel was last forgotten [s]: its restarted loop starts there."""
        self.lost = np.zeros(count, dtype=bool)
        """Panels whose process is dead for good: left out of readiness, lag and catching up."""
        self.behind_s = 0.0
        """Largest lag behind the clock any panel process's simulation reported [s]."""
        self.process_heard_s = {}
        """Panel process (settings node name) -> monotonic time of its last /diagnostics."""
        self.first_state_wall_s = np.full(count, np.nan)
        """Monotonic time of each panel's first state since it was last forgotten [s]."""
        self.foreign = 0
        """``panel_states`` messages or points that are not of this facade, ignored."""
        self.own_clock = None
        """``own_clock(ns)``: whether a ``/clock`` value is the bringup's (None: take any)."""
        self.foreign_clock = 0
        """``/clock`` messages that were not the bringup's, ignored."""
        subscription(self, contract.CLOCK, self._on_clock)
        subscription(self, contract.DIAGNOSTICS, self._on_diagnostics, contract.OBSERVER)
        subscription(self, contract.PANEL_STATES, self._on_panel_states, contract.OBSERVER)

    # -- inputs -----------------------------------------------------------------------------

    def _on_clock(self, message):
        if self.own_clock is not None and \
                not self.own_clock(message.clock.sec * 1_000_000_000 + message.clock.nanosec):
            self.foreign_clock += 1  # a second clock on the domain: not this day's time
            return
        self.clock_s = message.clock.sec + message.clock.nanosec * 1e-9

    def _on_panel_states(self, message):
        try:
            table = panel_states.unpack(message)
        except ValueError:
            self.foreign += 1
            return
        index = panel_states.indices(table, self._index)
        known = index >= 0
        self.foreign += int(np.count_nonzero(~known))
        index, table = index[known], table[known]
        first = self.first_state_wall_s[index]
        self.first_state_wall_s[index] = np.where(np.isnan(first), time.monotonic(), first)
        self.state_stamp_s[index] = panel_states.stamp_ns(message.header) * 1e-9
        self.closure[index], self.setpoint[index] = table['closure'], table['setpoint']
        self.fault[index], self.status[index] = table['fault'], table['status']

    def forget(self, panel_ids):
        """Drop what is known of ``panel_ids`` (their process died): unheard until they report.

        Their restarted loop starts at the clock of now, not at the start of the day: until
        they report, they trail the clock from here (:meth:`lag_s`).
        """
        index = self._indices(panel_ids)
        for values in (self.state_stamp_s, self.closure, self.setpoint, self.first_state_wall_s):
            values[index] = np.nan
        self.restarted_at_s[index] = np.nan if self.clock_s is None else self.clock_s
        self.fault[index], self.status[index] = 0, 0

    def heard(self, panel_ids):
        """Whether every one of ``panel_ids`` has reported since it was last forgotten."""
        return bool(np.all(np.isfinite(self.state_stamp_s[self._indices(panel_ids)])))

    def silent_s(self, process_name, panel_ids):
        """Wall seconds panel process ``process_name`` has been silent on /diagnostics.

        Counted from its last status there; before its first, from when the last of its
        panels ``panel_ids`` first reported a state (a process stopped between its panels'
        first states and its first status is silent too); 0 while neither has happened.
        """
        return silence_s(time.monotonic(), self.process_heard_s.get(process_name),
                         self.first_state_wall_s[self._indices(panel_ids)])

    def reported(self, process_name, panel_ids):
        """Whether panel process ``process_name`` or one of its panels has reported yet."""
        return process_name in self.process_heard_s or bool(
            np.isfinite(self.first_state_wall_s[self._indices(panel_ids)]).any())

    def lose(self, panel_ids):
        """Count ``panel_ids`` lost for good."""
        self.forget(panel_ids)
        self.lost[self._indices(panel_ids)] = True

    def _indices(self, panel_ids):
        return np.array([self._lookup[panel_id] for panel_id in panel_ids], dtype=np.intp)

    def _on_diagnostics(self, message):
        for status in message.status:
            if status.name.endswith(PROCESS_STATUS):
                self.process_heard_s[status.hardware_id] = time.monotonic()
            i = self._lookup.get(status.hardware_id)
            for item in status.values:
                if item.key == contract.DIAGNOSTIC_BEHIND_S:  # a panel process's figure
                    self.behind_s = max(self.behind_s, _number(item.value))
                elif i is not None and item.key in self.COUNTERS:
                    self.counters[item.key][i] = _number(item.value)

    # -- questions --------------------------------------------------------------------------

    def ready(self, observers):
        """Every panel heard; the coordinator and ``observers`` more listen.

        Until then the bringup holds the clock at the start of the day, so nothing misses it.
        """
        return (self.count_subscribers(contract.SUN.name) >= 1 + observers and
                self.count_subscribers(contract.PANEL_STATES.name) >= 1 + observers and
                self.reporting() == len(self.facade) - self.lost_count())

    def lost_count(self):
        """Panels lost for good."""
        return int(np.count_nonzero(self.lost))

    def reporting(self):
        """Panels heard from (a state, at least once)."""
        return int(np.count_nonzero(np.isfinite(self.state_stamp_s)))

    def lag_s(self, start_s):
        """How far the slowest panel's newest state trails the clock [s], or NaN.

        See :func:`trailing_s`.
        """
        return trailing_s(self.clock_s, self.state_stamp_s, self.restarted_at_s, start_s,
                          self.lost)

    def caught_up(self, end_s, state_period_s):
        """Whether every panel published a state of the day's last ``state_period_s``."""
        stamps = self.state_stamp_s[~self.lost]
        return bool(np.all(stamps >= end_s - state_period_s - 1.0))

    def faults(self):
        """Return the faults the panels report, sorted."""
        return sorted({contract.FAULTS[code] if code < len(contract.FAULTS) else 'unknown'
                       for code in self.fault.tolist()} - {contract.NO_FAULT})

    def statuses(self):
        """Return the status word of every panel heard."""
        heard = np.isfinite(self.state_stamp_s)
        return [contract.STATUSES[code] if code < len(contract.STATUSES) else 'unknown'
                for code in self.status[heard].tolist()]

    def counter_total(self, key):
        """Sum of a cumulative counter over the panels that reported it."""
        values = self.counters[key]
        return float(values[np.isfinite(values)].sum())

    def largest_behind_s(self):
        """Largest lag behind the clock any panel's simulation reported [s]."""
        return self.behind_s

    def tracking_error(self):
        """Largest ``|closure - tracked setpoint|`` over the panels heard, or NaN."""
        error = np.abs(self.closure - self.setpoint)
        error = error[np.isfinite(error)]
        return float(error.max()) if len(error) else math.nan

    # -- text -------------------------------------------------------------------------------

    def starting_line(self, observers):
        listeners = self.count_subscribers(contract.PANEL_STATES.name) - 1
        return (f'starting: panels ready {self.reporting()}/{len(self.facade)} (in '
                f'{self.count_publishers(contract.PANEL_STATES.name)} processes), observers '
                f'subscribed {max(listeners, 0)}/{observers}, sun listeners '
                f'{self.count_subscribers(contract.SUN.name)}/{1 + observers}')

    def progress_line(self, start_s):
        local = local_time(self.clock_s, self.facade.utc_offset_h) if self.clock_s else '-'
        heard = np.isfinite(self.state_stamp_s)
        closure = f'{self.closure[heard].mean():.2f}' if heard.any() else '-'
        wanted = f'{self.setpoint[heard].mean():.2f}' if heard.any() else '-'
        faulted = int(np.count_nonzero(self.fault))
        lost = f' ({self.lost_count()} lost)' if self.lost.any() else ''
        return (f'sim {local} | panels reporting {self.reporting()}/{len(self.facade)}{lost} | '
                f'closure {closure} (tracking {wanted}) | faults {faulted} | loop lag '
                f'{self.lag_s(start_s):.0f} s sim')


def trailing_s(clock_s, stamp_s, restarted_at_s, start_s, lost):
    """How far the slowest panel's newest state trails the clock [s], or NaN with no clock.

    A panel that has published no state yet counts as at the start of the day, ``start_s``
    (its loop has not shown it got any further), or, if its process was restarted, as at
    the clock of the restart, ``restarted_at_s``, where its new loop starts. Counting a
    restarted panel from the start of the day would hold the clock for a lag that is not
    there, and a held clock gives the new loop no period to report: nothing would move again.
    Panels ``lost`` for good are left out; with none left, nothing trails (0).
    """
    if clock_s is None:
        return math.nan
    unheard = np.where(np.isfinite(restarted_at_s), restarted_at_s, start_s)
    stamps = np.where(np.isfinite(stamp_s), stamp_s, unheard)[~np.asarray(lost)]
    return clock_s - float(stamps.min()) if len(stamps) else 0.0


def silence_s(now_s, last_status_s, first_states_s):
    """Seconds a panel process has been silent on /diagnostics at ``now_s``.

    Counted from ``last_status_s``, its last status there; with none yet (None), from the
    latest of ``first_states_s``, when each of its panels first reported a state: a process
    that stops between its panels' first states and its first status is silent too. 0 while
    neither has happened (a process still starting is not silent). All on one clock [s].
    """
    if last_status_s is None:
        if np.isnan(first_states_s).any():
            return 0.0
        last_status_s = float(np.max(first_states_s))
    return now_s - last_status_s


def _number(text):
    try:
        return float(text)
    except ValueError:
        return math.nan
