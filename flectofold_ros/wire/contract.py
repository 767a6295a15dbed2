"""The public contract of flectofold_ros: every topic, its type and QoS, the words on it.

Pure Python (no rclpy), so that the nodes, the recorder, the Rerun scene, the bringup's plan,
the launch file and the tests all take names from here;
:mod:`flectofold_ros.runtime.interfaces` turns them into rclpy objects. The contract is
documented, table by table, in ``msg_docs/``.

**One rule for names: every topic and service name is absolute.** Panel topics live under
``/facade/<panel id>/``, the facade's own under ``/facade/``; ``/clock`` and ``/diagnostics``
are the ROS-wide ones. A node's namespace says which node it is (``/facade/r02c03/panel``), not
where its topics are, so remapping works on the absolute names
(``-r /facade/r02c03/setpoint:=/my/cmd``).
"""

from dataclasses import dataclass
import re

from flectofold_model.control import Fault, SetpointState

#: Root of everything a facade publishes.
FACADE_NAMESPACE = '/facade'
#: Panel ids as facade descriptions build them: ``r<row>c<column>``, two digits each.
PANEL_ID = re.compile(r'r\d{2}c\d{2}')


@dataclass(frozen=True)
class Qos:
    """A QoS profile in plain words: history depth, reliability, durability."""

    depth: int
    reliable: bool = True
    latched: bool = False
    """Transient local: a late subscriber gets the last ``depth`` messages."""


#: Streams of state and commands: reliable, volatile, keep last 10.
STREAM = Qos(depth=10)
#: Latched state (fault, status): reliable, transient local, keep last 1.
LATCHED = Qos(depth=1, latched=True)
#: What an observer that must not miss a burst subscribes with (the Rerun bridge).
OBSERVER = Qos(depth=100)
#: What rclpy's ``qos_profile_sensor_data`` asks (best effort, keep last 5): a subscriber
#: with it is compatible with every stream.
SENSOR_DATA = Qos(depth=5, reliable=False)
#: What the replay publishes a recorded stream with.
REPLAY = Qos(depth=100)
#: History depth of the recorder's subscriptions, which mirror the publishers' QoS.
RECORDING_DEPTH = 1000


def recording_qos(latched: bool, reliable: bool) -> Qos:
    """Return the recorder's subscription QoS for a latched / reliable topic."""
    return Qos(depth=RECORDING_DEPTH, reliable=reliable, latched=latched)


@dataclass(frozen=True)
class Topic:
    """A topic: absolute name, message type (``package/msg/Name``) and its publishers' QoS."""

    name: str
    msgtype: str
    qos: Qos = STREAM


@dataclass(frozen=True)
class PanelTopic:
    """A topic every panel has, under ``/facade/<panel id>/<suffix>``."""

    suffix: str
    msgtype: str
    qos: Qos = STREAM

    def of(self, panel_id: str) -> Topic:
        """Return the :class:`Topic` of panel ``panel_id``."""
        return Topic(panel_topic_name(panel_id, self.suffix), self.msgtype, self.qos)


def panel_namespace(panel_id: str) -> str:
    """``/facade/<panel id>``: the namespace of a panel's node and topics."""
    return f'{FACADE_NAMESPACE}/{panel_id}'


def panel_topic_name(panel_id: str, suffix: str) -> str:
    """``/facade/<panel id>/<suffix>``."""
    return f'{panel_namespace(panel_id)}/{suffix}'


# -- the ROS-wide topics ----------------------------------------------------------------------

CLOCK = Topic('/clock', 'rosgraph_msgs/msg/Clock')
DIAGNOSTICS = Topic('/diagnostics', 'diagnostic_msgs/msg/DiagnosticArray')

# -- the facade's topics ----------------------------------------------------------------------

SUN = Topic(f'{FACADE_NAMESPACE}/sun', 'geometry_msgs/msg/Vector3Stamped')
WIND_SPEED = Topic(f'{FACADE_NAMESPACE}/wind_speed', 'std_msgs/msg/Float64')
DNI = Topic(f'{FACADE_NAMESPACE}/dni', 'std_msgs/msg/Float64')
#: The weather node's other readings (``weather.md``): diffuse horizontal irradiance
#: [W/m2], wind direction [rad, from north, clockwise] and air temperature [degC].
DHI = Topic(f'{FACADE_NAMESPACE}/dhi', 'std_msgs/msg/Float64')
WIND_DIRECTION = Topic(f'{FACADE_NAMESPACE}/wind_direction', 'std_msgs/msg/Float64')
AIR_TEMPERATURE = Topic(f'{FACADE_NAMESPACE}/air_temperature', 'std_msgs/msg/Float64')
OVERRIDE = Topic(f'{FACADE_NAMESPACE}/override', 'sensor_msgs/msg/JointState')
OVERRIDE_CLEAR = Topic(f'{FACADE_NAMESPACE}/override_clear', 'std_msgs/msg/String')
#: ``override``, ``override_clear`` and ``inject_fault`` name this instead of a panel id for
#: every panel.
ALL_PANELS = '*'
#: Simulated panels only: a fault to inject into panels' circuits, or to take away
#: (``fault_injection.md``): ``name`` the kind, ``hardware_id`` the panels, ``values`` the
#: figures. Depth 100: a fault script may send many at one instant.
INJECT_FAULT = Topic(f'{FACADE_NAMESPACE}/inject_fault', 'diagnostic_msgs/msg/DiagnosticStatus',
                     Qos(depth=100))
#: ``inject_fault`` kinds (``name``): the faults, then the two that take them away.
INJECT_SENSOR_STUCK = 'sensor_stuck'
INJECT_SENSOR_DROPOUT = 'sensor_dropout'
INJECT_SENSOR_NOISE = 'sensor_noise'
INJECT_LEAK = 'leak'
INJECT_SUPPLY_LOSS = 'supply_loss'
INJECT_FILL_VALVE_STUCK_OPEN = 'fill_valve_stuck_open'
INJECT_SUPPLY_RESTORE = 'supply_restore'
INJECT_RESTORE = 'restore'
#: The facade-level state: reliable, volatile, keep last 100, so that a busy observer (a
#: recorder writing, a bridge meshing) may trail by 10 s at 10 Hz before a state is lost.
FACADE_STREAM = Qos(depth=100)
#: Every flap of one panel process's panels, one message per state (``facade_state.md``).
FACADE_JOINT_STATES = Topic(f'{FACADE_NAMESPACE}/joint_states', 'sensor_msgs/msg/JointState',
                            FACADE_STREAM)
#: Every panel of one panel process, one point each (:mod:`flectofold_ros.wire.panel_states`).
PANEL_STATES = Topic(f'{FACADE_NAMESPACE}/panel_states', 'sensor_msgs/msg/PointCloud2',
                     FACADE_STREAM)
#: Every panel's commanded closure in one message (``panel_node.md``): ``name`` panel ids,
#: ``position`` closures. The coordinator commands through it; each panel process takes its
#: own panels' entries. Depth 10, as a panel's ``setpoint``.
FACADE_SETPOINTS = Topic(f'{FACADE_NAMESPACE}/setpoints', 'sensor_msgs/msg/JointState')
#: The facade-level state topics: what observers subscribe to.
FACADE_STATE = (FACADE_JOINT_STATES, PANEL_STATES)
#: The folded facade for RViz and Foxglove (``markers.md``), in :data:`SITE_FRAME`. Latched,
#: so that a display started later gets the last message at once.
MARKERS = Topic(f'{FACADE_NAMESPACE}/markers', 'visualization_msgs/msg/MarkerArray',
                Qos(depth=1, latched=True))

# -- each panel's topics and service ----------------------------------------------------------

SETPOINT = PanelTopic('setpoint', 'std_msgs/msg/Float64')
PRESSURE = PanelTopic('pressure', 'sensor_msgs/msg/FluidPressure')
JOINT_STATES = PanelTopic('joint_states', 'sensor_msgs/msg/JointState')
CLOSURE = PanelTopic('closure', 'std_msgs/msg/Float64')
FAULT = PanelTopic('fault', 'std_msgs/msg/String', LATCHED)
STATUS = PanelTopic('status', 'std_msgs/msg/String', LATCHED)
#: What a panel publishes, in the order the docs list it.
PANEL_OUTPUTS = (PRESSURE, JOINT_STATES, CLOSURE, FAULT, STATUS)
#: The panel outputs a panel streams at its publish rate (the rest are latched).
PANEL_STATE = (JOINT_STATES, PRESSURE, CLOSURE)
RESET_FAULTS_SERVICE = 'reset_faults'
RESET_FAULTS_TYPE = 'std_srvs/srv/Trigger'


def reset_faults_service(panel_id: str) -> str:
    """``/facade/<panel id>/reset_faults``."""
    return panel_topic_name(panel_id, RESET_FAULTS_SERVICE)


#: Flaps of each panel kind, in the order of their ``joint_states`` names.
FLAPS = {'quad': ('left', 'right'), 'hexagon': ('0', '1', '2')}


def flap_joint_names(panel_id: str, kind: str = 'quad') -> list[str]:
    """``joint_states`` names of a panel's flaps: two for a quad, three for a hexagon."""
    return [f'{panel_id}_flap_{flap}' for flap in FLAPS[kind]]


# -- words on the topics ----------------------------------------------------------------------

#: ``fault`` values: the latched circuit fault (``none`` when healthy).
FAULTS = tuple(fault.value for fault in Fault)
NO_FAULT = Fault.NONE.value
#: ``status`` value of a panel with a latched fault.
STATUS_FAULT = 'fault'
#: ``status`` values: where the tracked setpoint comes from, or ``fault``.
STATUSES = tuple(state.value for state in SetpointState) + (STATUS_FAULT,)
STATUS_TIMED_OUT = SetpointState.TIMED_OUT.value
#: ``header.frame_id`` of the sun vector and of every position in the site's frame.
SITE_FRAME = 'site_enu'

# -- nodes ------------------------------------------------------------------------------------

PANEL_NODE = 'panel'
"""Name of a panel's node; its namespace is :func:`panel_namespace`."""
COORDINATOR_NODE = 'coordinator'
SUN_POSITION_NODE = 'sun_position'
WEATHER_NODE = 'weather'
MONITOR_NODE = 'facade_monitor'
RERUN_BRIDGE_NODE = 'rerun_bridge'
MARKERS_NODE = 'facade_markers'
RECORDER_NODE = 'bag_recorder'
REPLAY_NODE = 'replay'
FAULT_SCRIPT_NODE = 'fault_script'
#: Namespace of the facade-wide nodes (coordinator, monitor, bridge).
FACADE_NODE_NAMESPACE = FACADE_NAMESPACE

#: What the recorder records unless told otherwise: the facade-level state and setpoints, the
#: facade's inputs, ``/diagnostics`` and ``/clock``; not the per-panel topics (``/facade/**``
#: adds them).
RECORDED_BY_DEFAULT = (FACADE_JOINT_STATES.name, PANEL_STATES.name, FACADE_SETPOINTS.name,
                       SUN.name, WIND_SPEED.name, DNI.name, DHI.name, WIND_DIRECTION.name,
                       AIR_TEMPERATURE.name, OVERRIDE.name, OVERRIDE_CLEAR.name,
                       INJECT_FAULT.name, DIAGNOSTICS.name, CLOCK.name)

# -- diagnostics ------------------------------------------------------------------------------

#: ``/diagnostics`` keys of a panel's status whose values are cumulative counts, for summaries.
DIAGNOSTIC_FREE_AIR_NL = 'free_air_used_nl'
DIAGNOSTIC_SETPOINTS_REJECTED = 'setpoints_rejected'
#: ``/diagnostics`` key of a panel's status: the faults injected into it now (``none``).
DIAGNOSTIC_INJECTED_FAULTS = 'injected_faults'
#: ``/diagnostics`` keys of a panel process's status: fault requests it applied and refused,
#: since start, and the reason of the last refusal.
DIAGNOSTIC_FAULT_REQUESTS_APPLIED = 'fault_requests_applied'
DIAGNOSTIC_FAULT_REQUESTS_REFUSED = 'fault_requests_refused'
DIAGNOSTIC_LAST_FAULT_REFUSAL = 'last_fault_refusal'
#: ``/diagnostics`` keys of a panel process's status: ``/facade/setpoints`` messages it refused
#: whole since start (lists that do not pair up, a panel twice, a panel not of the facade), and
#: the reason of the last refusal. A refused closure of one panel counts as that panel's
#: ``setpoints_rejected``.
DIAGNOSTIC_SETPOINT_MESSAGES_REFUSED = 'setpoint_messages_refused'
DIAGNOSTIC_LAST_SETPOINTS_REFUSAL = 'last_setpoints_refusal'
#: ``/diagnostics`` key of a panel's status: how far its simulation is behind the clock [s].
DIAGNOSTIC_BEHIND_S = 'behind_by_s'
#: ``/diagnostics`` key of a panel's status: states its loop kept but it did not publish,
#: because more came in one tick than it publishes (a loop catching up).
DIAGNOSTIC_STATES_SKIPPED = 'states_skipped'
#: ``/diagnostics`` keys of a panel process's status: the median and 99th percentile of how far
#: its tick's interval strayed from the control period, over the last report [s].
DIAGNOSTIC_TICK_JITTER_P50_S = 'tick_jitter_p50_s'
DIAGNOSTIC_TICK_JITTER_P99_S = 'tick_jitter_p99_s'
