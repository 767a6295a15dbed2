"""The sun's direction for the facade site, on the ROS clock or through a simulated day.

Mode ``wall`` follows the node's ROS clock (the system clock, or ``/clock`` with
``use_sim_time``, e.g. a bag replay). Mode ``simulated`` makes the node the clock source: it
publishes ``/clock`` running ``speedup`` times the steady clock from ``start_time`` to
``end_time``. Topics, parameters and QoS: ``msg_docs/sun_position.md``.
"""

from collections import OrderedDict
import sys

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Vector3, Vector3Stamped
from rcl_interfaces.msg import SetParametersResult
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rosgraph_msgs.msg import Clock as ClockMessage

from flectofold_model.environment import (epoch_from_iso, SimulatedClock, Site, sun_vector_enu,
                                          SunEphemeris)
from flectofold_ros.runtime.interfaces import publisher, subscription
from flectofold_ros.runtime.parameters import choice, declare_all, double, integer, string
from flectofold_ros.runtime.runner import configure_or_destroy, Program, run_nodes
from flectofold_ros.wire import contract, panel_states

MODES = ('wall', 'simulated')
#: A tick later than this many periods (a starved process) advances simulated time by this
#: many only: the clock slows down rather than leaping ahead of the nodes it drives. Five (0.1 s
#: at 50 Hz) absorbs the jitter of a busy process on two cores without losing pace.
LONGEST_TICKS = 5.0
#: Rate of the repeated final /clock once the simulated day is over [Hz].
FINISHED_CLOCK_RATE_HZ = 1.0
#: Distinct /clock values the node remembers having sent (:meth:`SunPositionNode.sent_clock`):
#: 80 s of its 50 Hz clock, far longer than a message takes to arrive on a busy machine.
SENT_CLOCK_KEPT = 4096
# builtin_interfaces/Time has an int32 ``sec``, and rclpy refuses negative times.
TIME_RANGE_ISO = ('1970-01-01T00:00:00Z', '2038-01-19T03:14:07Z')
NS_PER_S = 10**9
_SIM_TIME_REFUSED = ('use_sim_time must be false in mode simulated: the node publishes /clock '
                     'itself, from the steady clock')
_ISO = 'ISO 8601 with a UTC offset, e.g. 2026-06-21T04:00:00+02:00'
USAGE = 'sun_position_node [--ros-args -p name:=value ...]'
#: Once the graph is ready, the publishers in other processes still have to match the
#: subscriptions it shows: the held clock starts this much later [s of wall time].
START_SETTLE_S = 1.0

#: name -> Spec.
PARAMETERS = {
    'latitude_deg': double(48.7784, 'Geodetic latitude of the site, north positive [deg]',
                           -90.0, 90.0),
    'longitude_deg': double(9.18, 'Longitude of the site, east positive [deg]', -180.0, 180.0),
    'elevation_m': double(245.0, 'Height of the site above mean sea level [m]', -500.0, 9000.0),
    'mode': choice('wall', 'wall: follow the ROS clock; simulated: publish /clock and run a '
                   'simulated day', MODES),
    'start_time': string('2026-06-21T04:00:00+02:00',
                         'Start of the simulated day (mode simulated)', constraints=_ISO),
    'end_time': string('2026-06-21T22:00:00+02:00',
                       'End of the simulated day, after start_time (mode simulated)',
                       constraints=_ISO),
    'speedup': double(360.0, 'Simulated seconds per wall second (mode simulated) [-]',
                      1.0, 10000.0),
    'clock_rate_hz': double(50.0, 'Rate of /clock, steady clock (mode simulated) [Hz]',
                            1.0, 1000.0),
    'publish_period_s': double(
        60.0, 'Time between sun messages [s]: simulated seconds in mode simulated, ROS-clock '
        'seconds in mode wall', 0.01, 3600.0, read_only=False),
    'frame_id': string(contract.SITE_FRAME, 'header.frame_id of the sun vector: the site ENU '
                       'frame (x east, y north, z up)', read_only=False),
    'start.wait_for_panels': integer(
        0, 'Mode simulated: hold the clock at start_time until this many distinct panels have '
        'published a state on /facade/panel_states (0: start at once)', 0, 9999),
    'start.wait_for_sun_listeners': integer(
        0, 'Mode simulated: hold the clock at start_time until /facade/sun has this many '
        'subscribers (0: start at once)', 0, 1000),
    'start.timeout_s': double(
        120.0, 'Mode simulated: start the day anyway after holding this long for the start.* '
        'conditions [s, wall clock]', 1.0, 3600.0),
}


class SunPositionNode(Node):
    """Node ``sun_position``: publishes ``facade/sun``, and ``/clock`` in mode simulated.

    Keyword arguments go to :class:`rclpy.node.Node` (``context``, ``parameter_overrides``,
    ``namespace``, ...). A bad parameter raises :class:`rclpy.exceptions.ParameterException`
    (out of range, wrong type) or :class:`ValueError` (the rest), naming the parameter.
    """

    def __init__(self, **kwargs):
        super().__init__(contract.SUN_POSITION_NODE, **kwargs)
        configure_or_destroy(self, self._configure)

    def _configure(self):
        declare_all(self, PARAMETERS)
        self.site = Site(self._value('latitude_deg'), self._value('longitude_deg'),
                         self._value('elevation_m'))
        self.mode = self._value('mode')
        self.simulated_clock = SimulatedClock(*self._day(), self._value('speedup'))
        self._frame_id = self._value('frame_id')
        self._period_ns = _to_ns(self._value('publish_period_s'))
        self._ephemeris = self._sun_ephemeris()
        self._sun_publisher = publisher(self, contract.SUN)
        self._finished = False
        self._sim_epoch_s = None
        self._held = False
        self._gate = None
        if self.mode == 'simulated':
            self._start_simulated()
        else:
            self._timer = self.create_timer(self._period_ns / NS_PER_S, self._on_wall_timer)
        self.add_on_set_parameters_callback(self._check_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)
        self.get_logger().info(self._summary())

    def _value(self, name):
        return self.get_parameter(name).value

    def _day(self):
        epochs = []
        low, high = (epoch_from_iso(text) for text in TIME_RANGE_ISO)
        for name in ('start_time', 'end_time'):
            text = self._value(name)
            try:
                epoch = epoch_from_iso(text)
            except ValueError as error:
                raise ValueError(f'parameter {name}: {error}') from None
            if not low <= epoch <= high:
                raise ValueError(f'parameter {name} {text!r} must lie between '
                                 f'{TIME_RANGE_ISO[0]} and {TIME_RANGE_ISO[1]}, the range of '
                                 f'a ROS time stamp')
            epochs.append(epoch)
        if epochs[1] <= epochs[0]:
            raise ValueError(f'parameter end_time {self._value("end_time")!r} must be after '
                             f'start_time {self._value("start_time")!r}')
        return epochs

    def _summary(self):
        site = (f'site {self.site.latitude_deg:.4f} deg N, {self.site.longitude_deg:.4f} deg E, '
                f'{self.site.elevation_m:g} m')
        period = f'sun every {self._period_ns / NS_PER_S:g} s'
        if self.mode == 'wall':
            clock = contract.CLOCK.name if self._value('use_sim_time') else 'the system clock'
            return f'{site}; mode wall: {period} of ROS time, following {clock}'
        return (f'{site}; mode simulated: {self._value("start_time")} to '
                f'{self._value("end_time")} at {self.simulated_clock.speedup:g}x '
                f'({self.simulated_clock.wall_duration_s:g} s of wall time), {period} of '
                f'simulated time, /clock at {self._value("clock_rate_hz"):g} Hz')

    # -- runtime parameters -----------------------------------------------------------------

    def _check_parameters(self, parameters):
        for parameter in parameters:
            if parameter.name == 'use_sim_time' and parameter.value and self.mode == 'simulated':
                return SetParametersResult(successful=False, reason=_SIM_TIME_REFUSED)
        return SetParametersResult(successful=True)

    def _apply_parameters(self, parameters):
        for parameter in parameters:
            if parameter.name == 'frame_id':
                self._frame_id = parameter.value
            elif parameter.name == 'publish_period_s':
                self._period_ns = _to_ns(parameter.value)
                self._ephemeris = self._sun_ephemeris()
                if self.mode == 'wall':
                    self._timer.timer_period_ns = self._period_ns

    def _sun_ephemeris(self):
        """Return an ephemeris for a simulated day's sun stamps, on a grid (mode wall: None)."""
        if self.mode != 'simulated':
            return None
        return SunEphemeris(self.site, self._period_ns / NS_PER_S)

    # -- mode wall --------------------------------------------------------------------------

    def _on_wall_timer(self):
        now_ns = self.get_clock().now().nanoseconds
        if now_ns == 0:
            return  # use_sim_time before the first /clock
        self._publish_sun(now_ns)

    # -- mode simulated ---------------------------------------------------------------------

    def _start_simulated(self):
        if self._value('use_sim_time'):
            raise ValueError(_SIM_TIME_REFUSED)
        self._clock_publisher = publisher(self, contract.CLOCK)
        self._sent_clock = OrderedDict()
        self._steady = Clock(clock_type=ClockType.STEADY_TIME)
        self._last_tick = None  # the first tick: the simulated day starts when spun
        self._elapsed_s = 0.0
        self._longest_tick_s = LONGEST_TICKS / self._value('clock_rate_hz')
        self._last_sun_ns = None
        self._sim_epoch_s = self.simulated_clock.start_epoch_s
        self._timer = self.create_timer(1.0 / self._value('clock_rate_hz'), self._on_clock_tick,
                                        clock=self._steady)
        self._start_gate()

    # -- holding the start until the graph is ready (mode simulated) -------------------------

    def _start_gate(self):
        """Hold the clock at start_time while the ``start.*`` conditions are not met."""
        panels, listeners = (self._value(f'start.{name}')
                             for name in ('wait_for_panels', 'wait_for_sun_listeners'))
        if not (panels or listeners):
            return
        self._gate = {'panels': panels, 'listeners': listeners, 'heard': set(),
                      'since': self._steady.now(), 'ready': None,
                      'timeout_s': self._value('start.timeout_s')}
        self._gate['subscription'] = subscription(self, contract.PANEL_STATES,
                                                  self._on_panel_states, contract.OBSERVER) \
            if panels else None
        self.get_logger().info(
            f'holding the clock at {self._value("start_time")} until {panels} panels report '
            f'and {listeners} nodes listen to {contract.SUN.name} (at most '
            f'{self._gate["timeout_s"]:g} s)')

    def _on_panel_states(self, message):
        try:
            table = panel_states.unpack(message)
        except ValueError:
            return  # not the contract's layout: counts for nothing
        if self._gate is not None:
            self._gate['heard'].update(panel_states.panel_ids(table))

    def _check_gate(self, now):
        gate = self._gate
        waited_s = (now - gate['since']).nanoseconds / NS_PER_S
        if gate['ready'] is None and self._graph_ready():
            gate['ready'] = waited_s
        if gate['ready'] is not None and waited_s - gate['ready'] >= START_SETTLE_S:
            self._open_gate(f'the graph was ready after {gate["ready"]:.1f} s')
        elif gate['ready'] is None and waited_s > gate['timeout_s']:
            self.get_logger().warning(
                f'starting the day without a ready graph after {waited_s:.0f} s: '
                f'{len(gate["heard"])}/{gate["panels"]} panels reported, '
                f'{self.count_subscribers(contract.SUN.name)}/{gate["listeners"]} nodes listen '
                f'to {contract.SUN.name}')
            self._open_gate('timed out')

    def _graph_ready(self):
        gate = self._gate
        return (len(gate['heard']) >= gate['panels'] and
                self.count_subscribers(contract.SUN.name) >= gate['listeners'])

    def _open_gate(self, why):
        if self._gate['subscription'] is not None:
            self.destroy_subscription(self._gate['subscription'])
        self._gate = None
        self.get_logger().info(f'the simulated day starts: {why}')

    @property
    def waiting_for_graph(self):
        """Whether the clock is held at the start for the ``start.*`` conditions."""
        return self._gate is not None

    def _on_clock_tick(self):
        now = self._steady.now()
        if self._last_tick is not None:
            # A starved process (a long callback beside this timer) slows simulated time
            # down rather than leaping it ahead of the nodes it drives.
            tick_s = (now - self._last_tick).nanoseconds / NS_PER_S
            if not (self._held or self._gate is not None):
                self._elapsed_s += min(tick_s, self._longest_tick_s)
        self._last_tick = now
        if self._gate is not None:
            self._check_gate(now)
        elapsed_s = self._elapsed_s
        self._sim_epoch_s = self.simulated_clock.sim_epoch_s(elapsed_s)
        sim_ns = _to_ns(self._sim_epoch_s)
        self._clock_publisher.publish(ClockMessage(clock=_stamp(sim_ns)))
        self._sent_clock[sim_ns] = None
        self._sent_clock.move_to_end(sim_ns)
        if len(self._sent_clock) > SENT_CLOCK_KEPT:
            self._sent_clock.popitem(last=False)
        if self._finished:
            return
        self._publish_due_sun(sim_ns)
        if self.simulated_clock.finished(elapsed_s):
            self._finish(sim_ns)

    def _publish_due_sun(self, sim_ns):
        # Sun stamps lie on the grid last + k * period, the latest one the clock has passed:
        # the samples stay regular whatever the jitter of the ticks.
        if self._last_sun_ns is None:
            self._publish_sun(sim_ns)
        elif sim_ns - self._last_sun_ns >= self._period_ns:
            periods = (sim_ns - self._last_sun_ns) // self._period_ns
            self._publish_sun(self._last_sun_ns + periods * self._period_ns)

    def _finish(self, end_ns):
        if self._last_sun_ns != end_ns:
            self._publish_sun(end_ns)
        self._finished = True
        self._timer.timer_period_ns = round(NS_PER_S / FINISHED_CLOCK_RATE_HZ)
        self.get_logger().info(
            f'simulated day finished at {self._value("end_time")}; /clock stays there '
            f'(repeated at {FINISHED_CLOCK_RATE_HZ:g} Hz)')

    # -- publishing -------------------------------------------------------------------------

    def _publish_sun(self, epoch_ns):
        epoch_s = epoch_ns / NS_PER_S
        vectors = sun_vector_enu(epoch_s, self.site) if self._ephemeris is None else \
            self._ephemeris.enu(epoch_s)
        east, north, up = vectors[0]
        message = Vector3Stamped(vector=Vector3(x=float(east), y=float(north), z=float(up)))
        message.header.stamp = _stamp(epoch_ns)
        message.header.frame_id = self._frame_id
        self._sun_publisher.publish(message)
        self._last_sun_ns = epoch_ns

    def hold(self):
        """Stop simulated time where it is (mode simulated): /clock repeats it until released.

        An in-process bringup holds the clock until the graph is up, and while panel loops
        catch up.
        """
        self._held = True

    def release(self):
        """Let simulated time run again from where it was held."""
        self._held = False

    def sent_clock(self, clock_ns):
        """Whether ``/clock`` at ``clock_ns`` [ns] is one this node sent (of its latest ones)."""
        return clock_ns in self._sent_clock

    @property
    def held(self):
        """Whether simulated time is held."""
        return self._held

    @property
    def finished(self):
        """``True`` once a simulated day has reached ``end_time``; always ``False`` in wall."""
        return self._finished

    @property
    def sim_epoch_s(self):
        """Simulated time of the latest ``/clock``, POSIX seconds [s]; ``None`` in wall."""
        return self._sim_epoch_s


def _to_ns(seconds):
    return int(round(seconds * NS_PER_S))


def _stamp(epoch_ns):
    return Time(sec=epoch_ns // NS_PER_S, nanosec=epoch_ns % NS_PER_S)


def main(args=None):
    """``ros2 run flectofold_ros sun_position_node [--ros-args -p mode:=simulated ...]``."""
    return run_nodes('sun_position_node', args, lambda: Program([SunPositionNode()]), USAGE,
                     PARAMETERS)


if __name__ == '__main__':
    sys.exit(main())
