"""Stream the facade's 3D state to Rerun: every panel folded in one mesh, the sun, plots, faults.

``ros2 run flectofold_ros rerun_bridge [--ros-args -p use_sim_time:=true -p rrd_path:=day.rrd]``.
The node subscribes to ``/facade/panel_states`` (one message per panel process and state) and
the sun, and hands them to :class:`flectofold_ros.rerun.scene.FacadeScene`, which rebuilds the
meshes of the panels that moved with ``flectofold_model`` and logs the facade as one batched
mesh on the ROS time. Sinks: a viewer (one it spawns, connected to a server the bridge hosts on
127.0.0.1, or one at a gRPC address) and/or an ``.rrd`` file; whatever becomes of a viewer,
the file goes on. Topics, parameters and the entity layout: ``msg_docs/rerun_bridge.md``.
"""

from datetime import datetime
import sys
import time

from rclpy.clock import Clock, ClockType
from rclpy.node import Node

from flectofold_model.facade import DEFAULT_FACADE, load_facade
from flectofold_ros.rerun.scene import COLOR_MODES, FacadeScene, feed, scene_topics
from flectofold_ros.rerun.sinks import (choose_sinks, close_recording, open_recording,
                                        server_url, spawn_viewer)
from flectofold_ros.runtime import diagnostics
from flectofold_ros.runtime.interfaces import publisher, subscription
from flectofold_ros.runtime.parameters import boolean, choice, declare_all, double, integer, string
from flectofold_ros.runtime.runner import Program, run_nodes
from flectofold_ros.wire import contract

USAGE = 'rerun_bridge [--ros-args -p name:=value ...]'

#: name -> Spec.
PARAMETERS = {
    'facade_file': string('', 'Facade description YAML; empty: the embedded demonstrator'),
    'color_by': choice('closure', 'Panel colour: closure or gauge pressure', COLOR_MODES),
    'viewer': string('auto', 'Live viewer: auto (spawn one when a display is set), spawn, '
                     'none, or a gRPC URL such as rerun+http://127.0.0.1:9876/proxy'),
    'viewer_port': integer(9876, 'Port of the server a spawned viewer connects to (bound to '
                           '127.0.0.1)', 1024, 65535),
    'rrd_path': string('', 'Also save the recording to this .rrd; empty: save '
                       'flectofold_<time>.rrd in the working directory unless a viewer at a '
                       'URL is used'),
    'flush_period_s': double(0.1, 'Wall time between logging what changed [s]', 0.01, 10.0),
    'min_change_rad': double(
        1e-3, 'A panel is re-meshed when its fold angle moved more than this [rad]', 0.0, 0.0999),
    'strict': boolean(False, 'Rerun strict mode: logging errors raise instead of warning'),
    'diagnostics_period_s': double(1.0, 'Period of /diagnostics, wall clock [s]', 0.1, 60.0),
}


def _misplaced(count):
    if not count:
        return ''
    return f" ({count} not where this facade puts their panel: another facade's states?)"


class RerunBridge(Node):
    """Node ``rerun_bridge`` in namespace ``/facade``."""

    def __init__(self, **kwargs):
        kwargs.setdefault('namespace', contract.FACADE_NODE_NAMESPACE)
        super().__init__(contract.RERUN_BRIDGE_NODE, **kwargs)
        declare_all(self, PARAMETERS)
        value, warn = self._value, self.get_logger().warning
        facade = load_facade(value('facade_file') or DEFAULT_FACADE)
        port = value('viewer_port')
        url, self.rrd_path, spawn = choose_sinks(value('viewer'), value('rrd_path'), port,
                                                 warn=warn)
        recording_id = f'{facade.name}-{datetime.now().isoformat(timespec="seconds")}'
        self.recording = open_recording(recording_id, url, self.rrd_path, value('strict'),
                                        server_port=port if spawn else None)
        self.viewer = spawn_viewer(server_url(port), warn) if spawn else None
        self.viewer_url = server_url(port) if spawn else url
        self.scene = FacadeScene(facade, self.recording, value('color_by'),
                                 value('min_change_rad'))
        self.scene.log_static()
        for topic in scene_topics(facade):
            # A panel loop catching up publishes its states in a burst: keep them all.
            subscription(self, topic, self._callback(topic.name), contract.OBSERVER)
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.create_timer(value('flush_period_s'), self.flush, clock=steady)
        self._diagnostics = publisher(self, contract.DIAGNOSTICS)
        self.create_timer(value('diagnostics_period_s'), self._report, clock=steady)
        self.started = time.monotonic()
        self.lag_s = []
        self.flush_wall_s = 0.0
        self.flush_max_s = 0.0
        self.flushes = 0
        self._warned_misplaced = False

    def _value(self, name):
        return self.get_parameter(name).value

    def _callback(self, topic):
        def on_message(message):
            feed(self.scene, topic, message, self.get_clock().now().nanoseconds)
        return on_message

    def flush(self):
        """Log what changed; note how far the logged state trails the ROS clock."""
        started = time.perf_counter()
        remeshed = self.scene.flush()
        took_s = time.perf_counter() - started
        self.flush_wall_s += took_s
        self.flush_max_s = max(self.flush_max_s, took_s)
        self.flushes += 1
        now_ns = self.get_clock().now().nanoseconds
        if remeshed and self.scene.newest_stamp_ns > 0:
            self.lag_s.append(max(0.0, (now_ns - self.scene.newest_stamp_ns) * 1e-9))

    def figures(self):
        """Return counts, panel re-meshes per second (wall), flush times and lag [s]."""
        wall_s = max(time.monotonic() - self.started, 1e-9)
        counts = self.scene.counts
        lag = sorted(self.lag_s)
        return {'states_taken': counts.states_taken,
                'meshes_logged': counts.meshes_logged,
                'panels_remeshed': counts.panels_remeshed,
                'panels_unchanged': counts.panels_unchanged,
                'panels_remeshed_per_s': counts.panels_remeshed / wall_s,
                'samples_logged': counts.samples_logged,
                'events_logged': counts.events_logged, 'rejected': counts.rejected,
                'misplaced': counts.misplaced,
                'flush_mean_s': self.flush_wall_s / max(self.flushes, 1),
                'flush_max_s': self.flush_max_s,
                'lag_median_s': lag[len(lag) // 2] if lag else 0.0,
                'lag_max_s': lag[-1] if lag else 0.0,
                'lag_last_s': self.lag_s[-1] if self.lag_s else 0.0,
                'flush_cpu_share': self.flush_wall_s / wall_s}

    def _watch_viewer(self):
        if self.viewer is not None and self.viewer.poll() is not None:
            self.get_logger().warning(
                f'the Rerun viewer exited (exit {self.viewer.returncode}); still saving '
                f'{self.rrd_path} (a viewer can connect again: rerun --connect {self.viewer_url})')
            self.viewer = None

    def _report(self):
        self._watch_viewer()
        figures = self.figures()
        if figures['misplaced'] and not self._warned_misplaced:
            self._warned_misplaced = True
            self.get_logger().warning(
                f'{figures["misplaced"]} panel states are not where facade '
                f'{self.scene.facade.name!r} puts their panels, and are not drawn: the panels '
                f'run another facade (start the bridge with their facade_file)')
        self._diagnostics.publish(diagnostics.diagnostic_array(self, [diagnostics.status(
            self, diagnostics.OK, 'rerun', contract.RERUN_BRIDGE_NODE,
            f'{figures["meshes_logged"]} facade meshes logged', figures)]))

    def summary(self):
        """One line for the end of a run."""
        f = self.figures()
        where = [str(self.rrd_path)] if self.rrd_path else []
        where += [self.viewer_url] if self.viewer_url else []
        return (f'rerun_bridge: {f["meshes_logged"]} facade meshes, {f["panels_remeshed"]} '
                f'panels re-meshed ({f["panels_remeshed_per_s"]:.1f}/s, '
                f'{f["panels_unchanged"]} unchanged skipped), {f["samples_logged"]} samples, '
                f'{f["rejected"]} rejected{_misplaced(f["misplaced"])}; lag behind the '
                f'clock median '
                f'{f["lag_median_s"]:.1f} s, max {f["lag_max_s"]:.1f} s; flush mean '
                f'{1e3 * f["flush_mean_s"]:.1f} ms, max {1e3 * f["flush_max_s"]:.1f} ms, '
                f'{100 * f["flush_cpu_share"]:.1f} % of wall; to {", ".join(where)}')

    def close(self):
        """Log the last changes and finish the file (its footer)."""
        self.flush()
        close_recording(self.recording, self.get_logger().warning)


class _Bridging(Program):
    """The bridge as a program: on close, the last changes are logged and the file finished."""

    def __init__(self):
        super().__init__([RerunBridge()])
        bridge = self.nodes[0]
        bridge.get_logger().info(
            f'logging {len(bridge.scene.facade)} panels to '
            f'{bridge.rrd_path or ""}{" and " if bridge.rrd_path and bridge.viewer_url else ""}'
            f'{bridge.viewer_url or ""}')

    def close(self, interrupted):
        bridge = self.nodes[0]
        bridge.close()
        print(bridge.summary(), flush=True)


def main(args=None):
    """``ros2 run flectofold_ros rerun_bridge --ros-args -p use_sim_time:=true``."""
    return run_nodes('rerun_bridge', args, _Bridging, USAGE, PARAMETERS)


if __name__ == '__main__':
    sys.exit(main())
