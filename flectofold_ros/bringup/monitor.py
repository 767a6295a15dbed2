"""What the bringup knows of its facade's day, learnt from the topics as any other node would.

The monitor subscribes to ``/clock``, to every panel's ``joint_states`` (its stamp is the loop
time of the state), ``closure``, ``fault``, ``status`` and ``setpoint`` (what the coordinator
commands), and to ``/diagnostics`` for the panels' cumulative counters (air drawn, setpoints
refused). It never looks inside another node. The bringup asks it whether the graph is ready,
how far the slowest panel loop trails the clock, and for the progress line and summary.
"""

from dataclasses import dataclass, field
import math

from rclpy.node import Node

from flectofold_ros import contract
from flectofold_ros.bringup.plan import local_time, observed_topics
from flectofold_ros.interfaces import subscription


@dataclass
class PanelView:
    """The last of each thing a panel said, as the monitor heard it."""

    state_stamp_s: float = None
    """Loop time of the newest state (``joint_states`` stamp) [s]."""
    closure: float = None
    setpoint: float = None
    fault: str = contract.NO_FAULT
    status: str = ''
    counters: dict = field(default_factory=dict)
    """Cumulative figures from the panel's ``/diagnostics`` status, by contract key."""
    behind_s: float = 0.0
    """Largest lag behind the clock the panel's simulation reported [s]."""


class Monitor(Node):
    """Node ``/facade/facade_monitor``: listens to the day of ``facade``."""

    COUNTERS = (contract.DIAGNOSTIC_FREE_AIR_NL, contract.DIAGNOSTIC_SETPOINTS_REJECTED)

    def __init__(self, facade, **kwargs):
        super().__init__(contract.MONITOR_NODE, namespace=contract.FACADE_NODE_NAMESPACE,
                         **kwargs)
        self.facade = facade
        self.clock_s = None
        self.panels = {panel_id: PanelView() for panel_id in facade.panel_ids}
        self._listening = {topic.of(panel_id).name for panel_id in facade.panel_ids
                           for topic in (contract.JOINT_STATES, contract.CLOSURE)}
        subscription(self, contract.CLOCK, self._on_clock)
        subscription(self, contract.DIAGNOSTICS, self._on_diagnostics, contract.OBSERVER)
        for panel_id, view in self.panels.items():
            subscription(self, contract.JOINT_STATES.of(panel_id), self._on_state(view),
                         contract.OBSERVER)
            for topic, key in ((contract.CLOSURE, 'closure'), (contract.SETPOINT, 'setpoint'),
                               (contract.FAULT, 'fault'), (contract.STATUS, 'status')):
                subscription(self, topic.of(panel_id), self._setter(view, key))

    # -- inputs -----------------------------------------------------------------------------

    def _on_clock(self, message):
        self.clock_s = message.clock.sec + message.clock.nanosec * 1e-9

    @staticmethod
    def _on_state(view):
        def on_state(message):
            stamp = message.header.stamp
            view.state_stamp_s = stamp.sec + stamp.nanosec * 1e-9
        return on_state

    @staticmethod
    def _setter(view, key):
        def on_message(message):
            setattr(view, key, message.data)
        return on_message

    def _on_diagnostics(self, message):
        for status in message.status:
            view = self.panels.get(status.hardware_id)
            if view is None:
                continue
            for item in status.values:
                if item.key in self.COUNTERS:
                    view.counters[item.key] = _number(item.value)
                elif item.key == contract.DIAGNOSTIC_BEHIND_S:
                    view.behind_s = max(view.behind_s, _number(item.value))

    # -- questions --------------------------------------------------------------------------

    def ready(self, observers):
        """Every panel publishes its state; the coordinator and ``observers`` more listen.

        Until then the bringup holds the clock at the start of the day, so nothing misses it.
        """
        if self.count_subscribers(contract.SUN.name) < 1 + observers:
            return False
        return all(self.count_publishers(topic) >= 1 and
                   self.count_subscribers(topic) >= observers + (topic in self._listening)
                   for topic in observed_topics(self.facade))

    def reporting(self):
        """Panels heard from (a state, at least once)."""
        return sum(view.state_stamp_s is not None for view in self.panels.values())

    def lag_s(self, start_s):
        """How far the slowest panel's newest state trails the clock [s], or NaN.

        A panel that has published no state yet counts as at ``start_s``, the start of the
        day: its loop has not shown it got any further.
        """
        if self.clock_s is None:
            return math.nan
        return self.clock_s - min(start_s if view.state_stamp_s is None else view.state_stamp_s
                                  for view in self.panels.values())

    def caught_up(self, end_s, state_period_s):
        """Whether every panel published a state of the day's last ``state_period_s``."""
        stamps = [view.state_stamp_s for view in self.panels.values()]
        return all(stamp is not None and stamp >= end_s - state_period_s - 1.0
                   for stamp in stamps)

    def faults(self):
        """Return the faults the panels report, sorted."""
        return sorted({view.fault for view in self.panels.values()} - {contract.NO_FAULT})

    def values(self, key):
        """Return the panels' last ``key`` (a :class:`PanelView` attribute), where heard."""
        return [getattr(view, key) for view in self.panels.values()
                if getattr(view, key) is not None]

    def counter_total(self, key):
        """Sum of a cumulative counter over the panels that reported it."""
        return sum(view.counters[key] for view in self.panels.values() if key in view.counters)

    def largest_behind_s(self):
        """Largest lag behind the clock any panel's simulation reported [s]."""
        return max(view.behind_s for view in self.panels.values())

    def tracking_error(self):
        """Largest ``|closure - setpoint|`` over the panels that reported both, or NaN."""
        errors = [abs(view.closure - view.setpoint) for view in self.panels.values()
                  if view.closure is not None and view.setpoint is not None]
        return max(errors) if errors else math.nan

    # -- text -------------------------------------------------------------------------------

    def starting_line(self, observers):
        up = sum(self.count_publishers(contract.CLOSURE.of(p).name) >= 1
                 for p in self.facade.panel_ids)
        heard = min(self.count_subscribers(contract.CLOSURE.of(p).name)
                    for p in self.facade.panel_ids) - 1
        return (f'starting: panels up {up}/{len(self.facade)}, observers subscribed '
                f'{max(heard, 0)}/{observers}, sun listeners '
                f'{self.count_subscribers(contract.SUN.name)}/{1 + observers}')

    def progress_line(self, start_s):
        local = local_time(self.clock_s, self.facade.utc_offset_h) if self.clock_s else '-'
        closures, commanded = self.values('closure'), self.values('setpoint')
        closure = f'{sum(closures) / len(closures):.2f}' if closures else '-'
        wanted = f'{sum(commanded) / len(commanded):.2f}' if commanded else '-'
        faulted = sum(view.fault != contract.NO_FAULT for view in self.panels.values())
        return (f'sim {local} | panels reporting {self.reporting()}/{len(self.facade)} | '
                f'closure {closure} (commanded {wanted}) | faults {faulted} | loop lag '
                f'{self.lag_s(start_s):.0f} s sim')


def _number(text):
    try:
        return float(text)
    except ValueError:
        return math.nan
