"""The node that plays a day's fault script on ``/facade/inject_fault`` (``fault_script.py``)."""

from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.parameter import Parameter

from flectofold_ros.runtime.interfaces import publisher
from flectofold_ros.wire import contract
from flectofold_ros.wire.fault_injection import request_fields

#: Wall period at which the node looks at the clock [s].
POLL_PERIOD_S = 0.05


class FaultScriptNode(Node):
    """Node ``/facade/fault_script``: publishes each entry of a script when its time comes.

    ``script``: :class:`~flectofold_ros.bringup.fault_script.TimedFault` entries in time order
    (``load_fault_script``); ``start_epoch_s``: the ROS time of the day's start [s]. The node
    runs on ROS time (``use_sim_time`` unless ``parameter_overrides`` say otherwise) and looks
    at the clock every :data:`POLL_PERIOD_S` of wall time: under a sped-up clock every entry
    that came due since goes out at once, in order. Nothing goes out before ``subscribers``
    subscriptions (one per panel process) are matched, so that an entry due at the day's
    start is not lost to discovery.
    """

    def __init__(self, script, start_epoch_s, subscribers=1, **node_kwargs):
        node_kwargs.setdefault('parameter_overrides', [Parameter('use_sim_time', value=True)])
        super().__init__(contract.FAULT_SCRIPT_NODE, namespace=contract.FACADE_NODE_NAMESPACE,
                         **node_kwargs)
        self.script = sorted(script, key=lambda fault: fault.offset_s)
        self.start_epoch_s = float(start_epoch_s)
        self.subscribers = int(subscribers)
        self.sent = 0
        """Entries published so far, in time order."""
        self._publisher = publisher(self, contract.INJECT_FAULT)
        self.create_timer(POLL_PERIOD_S, self._poll,
                          clock=Clock(clock_type=ClockType.STEADY_TIME))
        self.get_logger().info(f'fault script: {len(self.script)} entries')

    @property
    def done(self):
        """Whether every entry has been published."""
        return self.sent == len(self.script)

    def _poll(self):
        now_s = self.get_clock().now().nanoseconds * 1e-9
        if self.done or now_s <= 0.0:
            return  # use_sim_time before the first /clock
        if self._publisher.get_subscription_count() < self.subscribers:
            return
        while not self.done and self.start_epoch_s + self.script[self.sent].offset_s <= now_s:
            self._publish(self.script[self.sent])
            self.sent += 1

    def _publish(self, fault):
        kind, panels, values = request_fields(fault.request)
        self._publisher.publish(DiagnosticStatus(
            name=kind, hardware_id=panels, message=f'fault script entry {fault.entry}',
            values=[KeyValue(key=key, value=value) for key, value in values]))
        self.get_logger().info(f'fault script entry {fault.entry} at +{fault.offset_s:g} s: '
                               f'{fault.request.describe()}')
