"""Draw what RViz or Foxglove would show of ``/facade/markers``, to a PNG, without a display.

Listens to the markers topic (``visualization_msgs/MarkerArray``, latched) on the current
``ROS_DOMAIN_ID`` for ``--seconds``, applies the messages as RViz does (``ADD`` replaces the
marker of the same namespace and id, ``DELETE`` removes it, ``DELETEALL`` clears), and draws
the ``TRIANGLE_LIST`` markers in their colours and the ``ARROW`` markers with matplotlib, in
the markers' frame (``site_enu``: x east, y north, z up), seen from the south. A check of the
markers by eye where no RViz can run.

Usage (from the repository root, while a facade with ``--markers`` runs)::

    .venv/bin/python tools/render_markers.py --seconds 5 --out markers.png
"""

import argparse
import sys
import time

import matplotlib
matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: E402
import numpy as np  # noqa: E402
import rclpy  # noqa: E402
from rclpy.node import Node  # noqa: E402
from visualization_msgs.msg import Marker  # noqa: E402

from flectofold_ros.runtime.interfaces import subscription  # noqa: E402
from flectofold_ros.wire import colours, contract  # noqa: E402


def apply(shown, array):
    """Apply a MarkerArray to ``shown`` ({(ns, id): Marker}) as RViz does."""
    for marker in array.markers:
        key = (marker.ns, marker.id)
        if marker.action == Marker.DELETEALL:
            shown.clear()
        elif marker.action == Marker.DELETE:
            shown.pop(key, None)
        else:
            shown[key] = marker


def draw(shown, path, title):
    """Draw the markers of ``shown`` to the PNG ``path``."""
    figure = plt.figure(figsize=(9, 7))
    axes = figure.add_subplot(projection='3d')
    corners = []
    for marker in shown.values():
        points = np.array([[p.x, p.y, p.z] for p in marker.points])
        rgba = (marker.color.r, marker.color.g, marker.color.b, marker.color.a)
        if marker.type == Marker.TRIANGLE_LIST and len(points):
            triangles = points.reshape(-1, 3, 3)
            axes.add_collection3d(Poly3DCollection(triangles, facecolor=rgba,
                                                   edgecolor=(0, 0, 0, 0.08), linewidth=0.2))
            corners.append(points)
        elif marker.type == Marker.ARROW and len(points) == 2:
            tail, head = points
            axes.quiver(*tail, *(head - tail), color=rgba, linewidth=2)
            corners.append(points)
    if corners:
        every = np.concatenate(corners)
        centre, half = every.mean(axis=0), (every.max(axis=0) - every.min(axis=0)).max() / 2
        for setter, c in zip((axes.set_xlim, axes.set_ylim, axes.set_zlim), centre):
            setter(c - half, c + half)
    axes.set_xlabel('east [m]')
    axes.set_ylabel('north [m]')
    axes.set_zlabel('up [m]')
    axes.view_init(elev=15, azim=-100)  # from the south, a little west
    ramp = matplotlib.colors.ListedColormap(colours.ramp_colours(np.linspace(0, 1, 256)) / 255)
    bar = figure.colorbar(matplotlib.cm.ScalarMappable(cmap=ramp), ax=axes, shrink=0.6)
    bar.set_label('closure (0 open, 1 closed); red: fault, grey: no state yet')
    axes.set_title(title)
    figure.savefig(path, dpi=110)
    plt.close(figure)


def _utc(seconds):
    return time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime(seconds))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--seconds', type=float, default=5.0, help='how long to listen [s]')
    parser.add_argument('--out', default='markers.png', help='PNG to write')
    options = parser.parse_args(argv)
    rclpy.init()
    node = Node('render_markers')
    shown, arrays = {}, []
    subscription(node, contract.MARKERS, lambda array: (arrays.append(1), apply(shown, array)))
    deadline = time.monotonic() + options.seconds
    while time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.1)
    stamps = [m.header.stamp.sec for m in shown.values() if m.ns == 'panels']
    title = (f'{contract.MARKERS.name} in {contract.SITE_FRAME}: {len(arrays)} messages, '
             f'{sum(1 for k in shown if k[0] == "panels")} panels'
             + (f', newest stamp {_utc(max(stamps))}' if stamps else ''))
    draw(shown, options.out, title)
    print(f'{options.out}: {title}')
    node.destroy_node()
    rclpy.try_shutdown()
    return 0 if shown else 1


if __name__ == '__main__':
    sys.exit(main())
