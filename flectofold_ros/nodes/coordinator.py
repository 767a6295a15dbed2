"""The facade coordinator: sun, wind, overrides and panel faults in; every panel's setpoint out.

Each ``control.period_s`` of ROS time it runs
:class:`flectofold_model.scheduling.FacadeSchedule` on the latest sun vector and publishes
every panel's commanded closure in one ``/facade/setpoints`` message; between decisions it
repeats it every ``setpoint_period_s`` as the panels' watchdog heartbeat. The storm latch is
not left to the decision period: each wind sample goes to it on arrival, a short timer
evaluates it while a trip or release is due, and a change is decided and published at once.
What to report, when to decide and the look-ahead grid are the schedule's
(:class:`~flectofold_model.scheduling.storm.StormEvents`,
:meth:`~flectofold_model.scheduling.FacadeSchedule.sun_window`); the node feeds it ROS time
[s] and wind [m/s] and publishes and logs what it returns.
Topics, parameters and QoS: ``msg_docs/coordinator_node.md``.
"""

from collections import Counter
import math
import sys

from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from sensor_msgs.msg import JointState

from flectofold_model.facade import DEFAULT_FACADE, load_facade
from flectofold_model.scheduling import FacadeSchedule
from flectofold_model.scheduling.facade_schedule import representative_panel
from flectofold_model.scheduling.predictive import DEFAULT_CONTROLLER
from flectofold_model.scheduling.scheduler import OverrideRefused
from flectofold_model.shading import ShadingTable
from flectofold_ros.runtime import diagnostics
from flectofold_ros.runtime.domain_watch import Presence, report_domain, SourceGuard, StartCheck
from flectofold_ros.runtime.interfaces import publisher, subscription
from flectofold_ros.runtime.parameters import declare_all, double, string
from flectofold_ros.runtime.runner import Program, run_nodes
from flectofold_ros.wire import contract, facade_setpoints, panel_states, presence

USAGE = 'coordinator_node [--ros-args -p name:=value ...]'

#: name -> Spec.
PARAMETERS = {
    'facade_file': string('', 'Facade description YAML; empty: the embedded demonstrator'),
    'setpoint_period_s': double(1.0, 'Heartbeat: every setpoint is repeated this often [s]',
                                0.05, 3600.0),
    'sun_timeout_s': double(900.0, 'A sun vector older than this is not used [s]',
                            1.0, 86400.0),
    'weather_timeout_s': double(60.0, 'A wind or DNI reading older than this is dropped [s]',
                                1.0, 86400.0),
    'override_duration_s': double(0.0, 'Life of an override [s]; 0: the facade default',
                                  0.0, 604800.0),
    'storm_check_period_s': double(
        0.5, 'While the storm latch is due to trip or release, it is evaluated this often '
        '[s of ROS time]', 0.01, 10.0),
    'diagnostics_period_s': double(1.0, 'Period of /diagnostics, wall clock [s]', 0.1, 60.0),
}


class CoordinatorNode(Node):
    """Node ``coordinator`` in namespace ``/facade`` (panel topics are ``<id>/...``)."""

    def __init__(self, **kwargs):
        kwargs.setdefault('namespace', contract.FACADE_NODE_NAMESPACE)
        super().__init__(contract.COORDINATOR_NODE, **kwargs)
        declare_all(self, PARAMETERS)
        path = self._value('facade_file') or DEFAULT_FACADE
        self.facade = load_facade(path)
        self.period_s = float(self.facade.control.get('period_s', 60.0))
        look_ahead_s = float(self.facade.control.get('look_ahead_s', 0.0))
        self.schedule = None
        self._table = ShadingTable(representative_panel(self.facade))  # seconds: not in a callback
        self.commanded = None
        self.last_result = None
        self.decisions = 0
        self.air_used_nl = 0.0
        self.peak_filling = 0
        self.rejected = Counter()
        self.overrides_refused_in_storm = 0
        self._sun_decided = False
        self._sun = None
        self._dni = None
        self._faulted = dict.fromkeys(self.facade.panel_ids, False)
        self._setpoints = publisher(self, contract.FACADE_SETPOINTS)
        self.presence = None
        """Its process's :class:`~flectofold_ros.runtime.domain_watch.Presence` when it runs
        alone."""
        watched = [contract.SUN.name, contract.WIND_SPEED.name, contract.DNI.name,
                   contract.FACADE_SETPOINTS.name]
        if self._value('use_sim_time'):
            watched.append(contract.CLOCK.name)
        self.sources = SourceGuard(self, watched, who=self._who)
        self._index = panel_states.index_lookup(self.facade.panel_ids)
        subscription(self, contract.PANEL_STATES, self._on_panel_states, contract.OBSERVER)
        subscription(self, contract.SUN, self._on_sun)
        subscription(self, contract.WIND_SPEED, self._on_wind)
        subscription(self, contract.DNI, self._on_dni)
        subscription(self, contract.OVERRIDE, self._on_override)
        subscription(self, contract.OVERRIDE_CLEAR, self._on_override_clear)
        self._diagnostics = publisher(self, contract.DIAGNOSTICS)
        self.create_timer(self.period_s, self._decide)
        self.create_timer(self._value('setpoint_period_s'), self._heartbeat)
        self._storm_timer = self.create_timer(self._value('storm_check_period_s'),
                                              self._check_storm)
        self._storm_timer.cancel()
        self.create_timer(self._value('diagnostics_period_s'), self._report,
                          clock=Clock(clock_type=ClockType.STEADY_TIME))
        self.controller = self.facade.control.get('controller', DEFAULT_CONTROLLER)
        self.get_logger().info(f'{self.facade.name}: {len(self.facade)} panels, a decision '
                               f'every {self.period_s:g} s, controller {self.controller}'
                               + (f', look-ahead {look_ahead_s:g} s'
                                  if self.controller == 'target' else ''))

    def _value(self, name):
        return self.get_parameter(name).value

    def _now_s(self):
        return self.get_clock().now().nanoseconds * 1e-9

    # -- inputs -----------------------------------------------------------------------------

    def _reject(self, topic, reason):
        self.rejected[topic] += 1
        self.get_logger().warning(f'rejected {topic}: {reason}', throttle_duration_sec=1.0)

    def _who(self, node_name):
        return self.presence.who(node_name) if self.presence is not None else node_name

    def _two_sources(self, topic):
        """Refuse a message of ``topic`` (policy hold) while two publish it."""
        if self.sources.doubled(topic):
            self.sources.refuse(topic)
            return True
        return False

    def _on_sun(self, message):
        if self._two_sources(contract.SUN.name):
            return  # held: a stale sun holds the last commands
        v = message.vector
        vector = (v.x, v.y, v.z)
        if not all(math.isfinite(c) for c in vector) or abs(math.hypot(*vector) - 1.0) > 1e-6:
            self._reject('sun', f'not a finite unit vector: {vector}')
            return
        self._sun = (vector, self._now_s())
        if not self._sun_decided:
            self._decide()

    def _on_reading(self, name, message, low, high):
        value = message.data
        if not math.isfinite(value) or not low <= value <= high:
            self._reject(name, f'{value} is outside [{low:g}, {high:g}]')
            return None
        return value, self._now_s()

    def _on_wind(self, message):
        reading = self._on_reading('wind_speed', message, 0.0, 100.0)
        if reading is None:
            return
        if reading[1] <= 0.0 or not self._ensure_schedule(reading[1]):
            return
        if reading[0] < self.schedule.parameters.wind_on_m_s and \
                self._two_sources(contract.WIND_SPEED.name):
            return  # storm_only: a second source can trip the latch, never keep or release it
        update = self.schedule.storm.observe_wind(*reading)
        if update is None:
            self._reject('wind_speed', f'the clock went back to {reading[1]:.3f} s')
            return
        self._storm_changed(update)

    def _on_dni(self, message):
        if self._two_sources(contract.DNI.name):
            return
        self._dni = self._on_reading('dni', message, 0.0, 1500.0) or self._dni

    def _on_panel_states(self, message):
        try:
            table = panel_states.unpack(message)
        except ValueError as error:
            self._reject('panel_states', str(error))
            return
        index = panel_states.indices(table, self._index)
        known = index >= 0
        for panel_index, fault in zip(index[known].tolist(), table['fault'][known].tolist()):
            self._faulted[self.facade.panel_ids[panel_index]] = fault != 0

    def _selection(self, name):
        if name == contract.ALL_PANELS:
            return list(range(len(self.facade)))
        if name in self._faulted:
            return [self.facade.panel_ids.index(name)]
        raise ValueError(f'unknown panel {name!r}')

    def _on_override(self, message):
        if self.schedule is None:
            self._reject('override', 'no schedule yet (waiting for the sun)')
            return
        if len(message.name) != len(message.position):
            self._reject('override', 'name and position differ in length')
            return
        self._check_storm()
        if self.schedule.scheduler.storm_latched:
            self._refuse_in_storm(message.name)
            return
        duration = self._value('override_duration_s') or None
        for name, closure in zip(message.name, message.position):
            try:
                panels = self._selection(name)
                self.schedule.scheduler.set_override(closure, self._decision_time(), panels,
                                                     duration_s=duration)
            except OverrideRefused:
                self._refuse_in_storm(message.name)
                return
            except (ValueError, TypeError) as error:
                self._reject('override', f'{name}: {error}')
                continue
            self.get_logger().info(f'override {name}: closure {closure:g}')
        self._decide()

    def _refuse_in_storm(self, names):
        self.overrides_refused_in_storm += 1
        self._reject('override', f'{", ".join(names)}: refused, storm latch set (wind above '
                     f'{self.schedule.parameters.wind_on_m_s:g} m/s); an override is not '
                     'kept for after the storm')

    def _on_override_clear(self, message):
        if self.schedule is None:
            return
        for name in (n.strip() for n in message.data.split(',') if n.strip()):
            try:
                self.schedule.scheduler.clear_override(panels=self._selection(name))
            except ValueError as error:
                self._reject('override_clear', str(error))
        self._decide()

    # -- storm ------------------------------------------------------------------------------

    def _check_storm(self):
        """Evaluate the storm latch now (the storm timer, and before an override)."""
        now = self._now_s()
        if self.schedule is None or now <= 0.0:
            return
        update = self.schedule.storm.advance(now)
        if update is not None:
            self._storm_changed(update)

    def _storm_changed(self, update):
        """Log and decide what an evaluation of the latch asks; run the timer while one is due."""
        self._log_storm_change(update.change)
        if update.decide:
            self._decide()
        if self.schedule.storm.due_s is None:
            self._storm_timer.cancel()
        elif self._storm_timer.is_canceled():
            self._storm_timer.reset()

    def _log_storm_change(self, change):
        if change is not None:
            self.get_logger().warning(change.describe())

    # -- decisions --------------------------------------------------------------------------

    def _ensure_schedule(self, now):
        """Make the schedule at the first sun vector or wind sample; return whether it exists."""
        if self.schedule is None and now > 0.0:
            self.schedule = FacadeSchedule(self.facade, start_s=now, table=self._table,
                                           wind_timeout_s=self._value('weather_timeout_s'))
        return self.schedule is not None

    def _decision_time(self):
        return max(self._now_s(), self.schedule.scheduler.last_step_s)

    def _fresh(self, reading, timeout_s):
        if reading is None or self._now_s() - reading[1] > timeout_s:
            return None
        return reading[0]

    def _decide(self):
        """Decide every panel's closure; without a fresh sun only for the storm (others hold)."""
        now = self._now_s()
        sun = self._fresh(self._sun, self._value('sun_timeout_s'))
        if now <= 0.0 or (sun is None and (self.schedule is None
                                           or not self.schedule.storm.decision_due)):
            return
        self._ensure_schedule(now)
        if now < self.schedule.scheduler.earliest_step_s:
            return
        faulted = [self._faulted[p] for p in self.facade.panel_ids]
        result = self.schedule.step(
            now, None if sun is None else self.schedule.sun_window(now, sun),
            dni_w_m2=self._fresh(self._dni, self._value('weather_timeout_s')), faulted=faulted)
        self._log_storm_change(self.schedule.storm.report())
        self._sun_decided = self._sun_decided or sun is not None
        self.last_result, self.commanded = result, result.closure
        self.decisions += 1
        self.air_used_nl += result.air_used_nl
        self.peak_filling = max(self.peak_filling, int(result.filling.sum()))
        self._heartbeat()

    def _heartbeat(self):
        if self.commanded is None:
            return
        message = JointState()
        message.header.stamp = self.get_clock().now().to_msg()
        message.name, message.position = facade_setpoints.fields(self.facade.panel_ids,
                                                                 self.commanded)
        self._setpoints.publish(message)

    # -- diagnostics ------------------------------------------------------------------------

    def _report(self):
        self._diagnostics.publish(diagnostics.diagnostic_array(self, [self.diagnostic_status()]))

    def figures(self):
        """Return the schedule's figures so far: decisions, moves per panel, fills, air."""
        moves = (self.schedule.scheduler.moves_today if self.schedule is not None
                 else None)
        return {'decisions': self.decisions,
                'moves_mean': float(moves.mean()) if moves is not None else math.nan,
                'moves_max': int(moves.max()) if moves is not None else 0,
                'peak_filling': self.peak_filling, 'air_used_nl': self.air_used_nl}

    def diagnostic_status(self):
        """Return the schedule's REP-107 status."""
        level, message = diagnostics.OK, 'scheduling'
        if self.schedule is None:
            level, message = diagnostics.WARN, 'waiting for the sun'
        elif self._fresh(self._sun, self._value('sun_timeout_s')) is None:
            level, message = diagnostics.WARN, 'sun vector stale: holding the schedule'
        values = {'controller': self.controller, 'decisions': self.decisions,
                  'air_budget_used_nl': f'{self.air_used_nl:.1f}',
                  'faulted_panels': sum(self._faulted.values()),
                  'rejected_inputs': sum(self.rejected.values()),
                  'overrides_refused_in_storm': self.overrides_refused_in_storm}
        if self.schedule is not None:
            storm = self.schedule.storm.status(self._now_s())
            values.update(storm_latched=storm.latched,
                          wind_m_s='stale' if storm.wind_m_s is None else f'{storm.wind_m_s:.1f}',
                          storm_change_due_in_s=('none' if storm.due_in_s is None
                                                 else f'{storm.due_in_s:.1f}'),
                          mean_commanded_closure=(
                              f'{self.schedule.scheduler.commanded_closure.mean():.3f}'))
            if storm.latched:
                level, message = diagnostics.WARN, 'storm: panels at the storm position'
        level, message = report_domain(self.presence, self.sources, level, message, values)
        if self.last_result is not None:
            reasons = Counter(reason.value for reason in self.last_result.reason)
            values.update({f'reason_{name}': count for name, count in reasons.items()})
        return diagnostics.status(self, level, 'schedule', self.facade.name, message, values)


def start_coordinator():
    """Create the coordinator of a process of its own; refuse beside another one.

    ``ValueError`` (exit 2) when another live coordinator is heard on the domain
    (:mod:`flectofold_ros.wire.presence`). The check listens on a node of its own, so that no
    second ``/facade/setpoints`` publisher shows on the graph meanwhile.
    """
    StartCheck('coordinator_start_check').refuse(presence.this_process(
        presence.COORDINATOR, '', [f'{contract.FACADE_NODE_NAMESPACE}/'
                                   f'{contract.COORDINATOR_NODE}']))
    node = CoordinatorNode()
    node.presence = Presence(node, presence.this_process(
        presence.COORDINATOR, node.facade.name, [node.get_fully_qualified_name()]))
    node.presence.announce()
    return Program([node])


def main(args=None):
    """``ros2 run flectofold_ros coordinator_node --ros-args -p use_sim_time:=true``."""
    return run_nodes('coordinator_node', args, start_coordinator, USAGE, PARAMETERS)


if __name__ == '__main__':
    sys.exit(main())
