"""The folded facade as ``visualization_msgs/MarkerArray`` for RViz and Foxglove.

The node listens to the facade-level state (``/facade/panel_states``) and the sun, and
publishes ``/facade/markers`` in the fixed frame ``site_enu`` (no TF is needed: every marker
is in the frame RViz or Foxglove is told to display). Each panel is one ``TRIANGLE_LIST``
marker (namespace ``panels``, id = the panel's index in the facade), coloured by closure on
the Rerun scene's ramp, red for a latched fault, grey before its first state; the facade's
surface is one translucent ``TRIANGLE_LIST`` (``surface``) and the sun one ``ARROW``
(``sun``, deleted while the sun is below the horizon). At most ``publish_rate_hz`` messages
a second (steady clock), each with the panels that moved or changed colour since the last
one; every ``full_period_s`` one with everything, so that a display started late has the
whole facade within that time. Topics, parameters and the configs: ``msg_docs/markers.md``.
"""

import sys

from geometry_msgs.msg import Point
import numpy as np
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from flectofold_model.facade import DEFAULT_FACADE, load_facade
from flectofold_ros.runtime.interfaces import publisher, subscription
from flectofold_ros.runtime.parameters import declare_all, double, string
from flectofold_ros.runtime.runner import configure_or_destroy, Program, run_nodes
from flectofold_ros.wire import contract, panel_states
from flectofold_ros.wire.markers import FacadeMarkers

USAGE = 'facade_markers [--ros-args -p facade_file:=PATH -p name:=value ...]'

#: name -> Spec.
PARAMETERS = {
    'facade_file': string('', 'Facade description YAML; empty: the embedded demonstrator'),
    'publish_rate_hz': double(2.0, 'Most marker messages a second [Hz, steady clock]',
                              0.1, 30.0),
    'full_period_s': double(5.0, 'Time between messages with every marker, for displays '
                            'started late [s, steady clock]', 0.5, 600.0),
    'min_change_rad': double(1e-3, 'A panel whose fold angle changed less than this keeps '
                             'its marker [rad]', 0.0, 0.1),
}


class FacadeMarkersNode(Node):
    """Node ``/facade/facade_markers``: publishes the facade's markers (see the module)."""

    def __init__(self, **kwargs):
        super().__init__(contract.MARKERS_NODE, namespace=contract.FACADE_NODE_NAMESPACE,
                         **kwargs)
        configure_or_destroy(self, self._configure)

    def _configure(self):
        declare_all(self, PARAMETERS)
        path = self.get_parameter('facade_file').value
        self.markers = FacadeMarkers(load_facade(path or DEFAULT_FACADE),
                                     self.get_parameter('min_change_rad').value)
        self._stamp = self.get_clock().now().to_msg()
        self._sun = None
        self._publisher = publisher(self, contract.MARKERS)
        subscription(self, contract.PANEL_STATES, self._on_panel_states, contract.OBSERVER)
        subscription(self, contract.SUN, self._on_sun)
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self._full_every = max(1, round(self.get_parameter('full_period_s').value *
                                        self.get_parameter('publish_rate_hz').value))
        self._ticks = 0
        self.published = 0
        self.create_timer(1.0 / self.get_parameter('publish_rate_hz').value, self._on_timer,
                          clock=steady)
        self.get_logger().info(
            f'{self.markers.facade.name}: {len(self.markers)} panels as markers on '
            f'{contract.MARKERS.name} in frame {contract.SITE_FRAME}')

    def _on_panel_states(self, message):
        try:
            table = panel_states.unpack(message)
        except ValueError as error:
            self.get_logger().warning(f'ignored panel_states: {error}',
                                      throttle_duration_sec=10.0)
            return
        if self.markers.take(table):
            self._stamp = message.header.stamp

    def _on_sun(self, message):
        vector = np.array([message.vector.x, message.vector.y, message.vector.z])
        if np.all(np.isfinite(vector)) and np.linalg.norm(vector) > 0.0:
            self._sun = vector / np.linalg.norm(vector)

    def _on_timer(self):
        full = self._ticks % self._full_every == 0
        self._ticks += 1
        panels = self.markers.changed(full)
        array = MarkerArray(markers=[self._panel_marker(i) for i in panels])
        if full:
            array.markers += [self._surface_marker(), self._sun_marker()]
        if array.markers:
            self._publisher.publish(array)
            self.published += 1

    # -- markers ----------------------------------------------------------------------------

    def _marker(self, namespace, index, kind):
        marker = Marker(ns=namespace, id=int(index), type=kind, action=Marker.ADD)
        marker.header.frame_id = contract.SITE_FRAME
        marker.header.stamp = self._stamp
        marker.pose.orientation.w = 1.0
        marker.scale.x = marker.scale.y = marker.scale.z = 1.0
        return marker

    def _panel_marker(self, index):
        marker = self._marker('panels', index, Marker.TRIANGLE_LIST)
        marker.points = _points(self.markers.triangles(index))
        marker.color = _colour(self.markers.colour(index))
        return marker

    def _surface_marker(self):
        marker = self._marker('surface', 0, Marker.TRIANGLE_LIST)
        marker.points = _points(self.markers.surface_triangles())
        marker.color = _colour(self.markers.SURFACE_RGBA)
        return marker

    def _sun_marker(self):
        marker = self._marker('sun', 0, Marker.ARROW)
        if self._sun is None or self._sun[2] <= 0.0:
            marker.action = Marker.DELETE  # no sun yet, or below the horizon
            return marker
        tail, head = self.markers.sun_arrow(self._sun)
        marker.points = _points(np.array([tail, head]))
        marker.scale.x, marker.scale.y, marker.scale.z = 0.08, 0.2, 0.3  # shaft, head [m]
        marker.color = _colour(self.markers.SUN_RGBA)
        return marker


def _points(vertices):
    return [Point(x=x, y=y, z=z) for x, y, z in np.asarray(vertices, dtype=float).tolist()]


def _colour(rgba):
    r, g, b, a = (float(c) / 255.0 for c in rgba)
    return ColorRGBA(r=r, g=g, b=b, a=a)


def main(args=None):
    """``ros2 run flectofold_ros facade_markers [--ros-args -p facade_file:=PATH ...]``."""
    return run_nodes('facade_markers', args, lambda: Program([FacadeMarkersNode()]), USAGE,
                     PARAMETERS)


if __name__ == '__main__':
    sys.exit(main())
