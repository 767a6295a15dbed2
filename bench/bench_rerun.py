"""The Rerun scene's flush: CPU, flushes per second and .rrd growth, 36 and 1,000 panels.

Run with ``.venv/bin/python bench/bench_rerun.py [--flushes 100]``. Each facade (the
demonstrator's 36 panels, and 1,000 demonstrator modules on a 25 x 40 grid) is split into two
panel processes, as the bringup runs it. Every flush gets one ``/facade/panel_states``
message from each process (``sensor_msgs/PointCloud2`` built with
:func:`flectofold_ros.wire.panel_states.fill_message`, through :func:`feed` as the bridge gets it)
with every panel moving and ``min_change_rad=0``, so every flush re-meshes every panel and logs
the whole facade mesh, colours, the three per-panel series and the closure band: the worst
case. The recording goes to an ``.rrd`` file in a temporary folder.

Figures: CPU per flush is this process's CPU time (``time.process_time``, which counts the
Rerun SDK's own threads: batching, compression, file writing) over the run, finishing the
file included, divided by the flushes, so one core sustains ``1000 / CPU ms`` flushes per
second; wall time is shown too (a busy machine stretches it). The .rrd growth is per flush
and per second at 10 flushes/s.
"""

import argparse
from pathlib import Path
import tempfile
import time

from _facades import large_facade_text
from builtin_interfaces.msg import Time
import numpy as np
from sensor_msgs.msg import PointCloud2, PointField

from flectofold_model.actuation import ATMOSPHERIC_PRESSURE_PA
from flectofold_model.facade.description import build_facade, DEFAULT_FACADE, load_facade
from flectofold_ros.rerun.scene import FacadeScene, feed
from flectofold_ros.rerun.sinks import open_recording
from flectofold_ros.wire import contract, panel_states

T0_NS = 1782036000 * 10**9
STATE_NS = 10**8  # 10 Hz of ROS time
TARGET_FLUSHES_PER_S = 10.0


def large_facade(rows=25, columns=40):
    """Return the demonstrator's modules on a ``rows`` x ``columns`` grid, 1.1 m pitch."""
    return build_facade(large_facade_text(rows, columns))


def messages(scene, step, processes=2):
    """One panel_states message per process for state ``step``, every panel moving."""
    count = len(scene)
    closure = 0.5 + 0.45 * np.sin(step / 4.0 + np.arange(count) / 5.0)
    table = panel_states.new_table(count)
    table['x'], table['y'], table['z'] = scene.positions_enu.T
    table['closure'] = closure
    table['fold_angle_rad'] = scene.model.fold_angle_from_closure(closure)
    table['pressure_pa'] = ATMOSPHERIC_PRESSURE_PA + 8e3 * closure
    table['setpoint'] = closure
    table['row'], table['column'] = panel_states.id_numbers(scene.panel_ids)
    table['status'] = contract.STATUSES.index('tracking')
    stamp_ns = T0_NS + step * STATE_NS
    stamp = Time(sec=stamp_ns // 10**9, nanosec=stamp_ns % 10**9)
    return [panel_states.fill_message(PointCloud2(), part, stamp, PointField)
            for part in np.array_split(table, processes)]


def run(facade, path, flushes):
    recording = open_recording('bench', None, path)
    scene = FacadeScene(facade, recording, min_change_rad=0.0)
    scene.log_static()
    recording.flush()
    inputs = [messages(scene, step) for step in range(flushes)]  # built outside the timing
    static_bytes = path.stat().st_size
    wall, cpu, feed_s = time.perf_counter(), time.process_time(), 0.0
    for step_messages in inputs:
        started = time.process_time()
        for message in step_messages:
            feed(scene, contract.PANEL_STATES.name, message)
        feed_s += time.process_time() - started
        scene.flush()
    recording.flush()
    recording.disconnect()
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    assert scene.counts.rejected == 0 and scene.counts.meshes_logged == flushes
    grown = path.stat().st_size - static_bytes
    return {'cpu_ms': 1e3 * cpu / flushes, 'wall_ms': 1e3 * wall / flushes,
            'feed_ms': 1e3 * feed_s / flushes, 'mb_per_flush': grown / flushes / 1e6,
            'vertices': len(scene) * scene.topology.vertex_count,
            'stations': scene.topology.stations}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--flushes', type=int, default=100)
    flushes = parser.parse_args().flushes
    print(f'FacadeScene: {flushes} flushes, every panel moving (min_change_rad 0), two '
          f'panel_states messages per flush; .rrd file sink')
    print(f'{"panels":>7} {"stations":>8} {"vertices":>9} {"CPU ms/flush":>13} '
          f'{"(feed)":>7} {"flushes/s/core":>15} {"wall ms":>8} {"MB/flush":>9} '
          f'{"MB/s @10 Hz":>12}')
    with tempfile.TemporaryDirectory() as folder:
        for name, facade in (('36', load_facade(DEFAULT_FACADE)), ('1000', large_facade())):
            r = run(facade, Path(folder) / f'{name}.rrd', flushes)
            rate = 1e3 / r['cpu_ms']
            print(f'{len(facade):>7} {r["stations"]:>8} {r["vertices"]:>9} '
                  f'{r["cpu_ms"]:>13.1f} {r["feed_ms"]:>7.2f} {rate:>15.0f} '
                  f'{r["wall_ms"]:>8.1f} {r["mb_per_flush"]:>9.3f} '
                  f'{TARGET_FLUSHES_PER_S * r["mb_per_flush"]:>12.2f}'
                  f'{"" if rate >= TARGET_FLUSHES_PER_S else "  BELOW TARGET"}')


if __name__ == '__main__':
    main()
