"""Meshes per second into an .rrd: the bridge's scene against one call per panel and message.

Both log the demonstrator's 36 panels for 100 states each (every panel moving, the worst
case), with fold-angle, pressure and closure series, to an .rrd file in a temporary folder.
The scene meshes every changed panel in one vectorised ``fold_mesh`` call per flush and sends
the series in columns; the peer builds one panel's mesh per message and logs each sample.
"""

from pathlib import Path
import tempfile
import time

import numpy as np
import rerun as rr

from flectofold_model.actuation import ATMOSPHERIC_PRESSURE_PA
from flectofold_model.facade.description import DEFAULT_FACADE, load_facade
from flectofold_model.kinematics.mesh import fold_mesh
from flectofold_ros.rerun.scene import FacadeScene
from flectofold_ros.rerun.sinks import open_recording

STEPS = 100
T0_NS = 1782036000 * 10**9


def states(facade, model):
    closure = 0.5 + 0.45 * np.sin(np.arange(STEPS)[:, None] / 4.0 + np.arange(len(facade)) / 5.0)
    return closure, np.stack([model.fold_angle_from_closure(c) for c in closure])


def run_scene(facade, path):
    recording = open_recording('bench', None, path)
    scene = FacadeScene(facade, recording)
    scene.log_static()
    closure, angles = states(facade, scene.model)
    started = time.perf_counter()
    for step in range(STEPS):
        stamp = T0_NS + step * 72 * 10**9
        for i, panel_id in enumerate(facade.panel_ids):
            scene.fold_angle(panel_id, stamp, float(angles[step, i]))
            scene.closure_value(panel_id, stamp, float(closure[step, i]))
            scene.pressure(panel_id, stamp, ATMOSPHERIC_PRESSURE_PA + 8e3 * closure[step, i])
        scene.flush()
    recording.flush()
    recording.disconnect()
    return time.perf_counter() - started, scene.counts.meshes_logged


def run_per_message(facade, path):
    recording = open_recording('bench', None, path)
    scene = FacadeScene(facade, rr.RecordingStream('unused'))  # for its model only
    model, batch = scene.model, scene.model.batch
    closure, angles = states(facade, model)
    started = time.perf_counter()
    for step in range(STEPS):
        recording.set_time('ros_time', timestamp=np.datetime64(T0_NS + step * 72 * 10**9, 'ns'))
        for i, panel_id in enumerate(facade.panel_ids):
            k = model.state_from_closure(closure[step]).elastica_k[i:i + 1]
            mesh = fold_mesh(batch.take([i]), k, dtype=np.float32)
            recording.log(f'/facade/panels/{panel_id}/mesh', rr.Mesh3D(
                vertex_positions=mesh.vertices[0], vertex_normals=mesh.normals[0],
                triangle_indices=mesh.faces))
            for name, value in (('fold_angle_rad', angles[step, i]),
                                ('closure', closure[step, i]),
                                ('pressure_gauge_pa', 8e3 * closure[step, i])):
                recording.log(f'/metrics/{name}/{panel_id}', rr.Scalars(value))
    recording.flush()
    recording.disconnect()
    return time.perf_counter() - started, STEPS * len(facade)


def main():
    facade = load_facade(DEFAULT_FACADE)
    print(f'{len(facade)} panels x {STEPS} states, every panel moving; .rrd file sink')
    with tempfile.TemporaryDirectory() as folder:
        results = {}
        for name, run in (('scene (bridge)', run_scene), ('per message', run_per_message)):
            path = Path(folder) / f'{name.split()[0]}.rrd'
            seconds, meshes = run(facade, path)
            results[name] = meshes / seconds
            print(f'  {name:15s} {meshes} meshes in {seconds:5.2f} s: {meshes / seconds:7.0f} '
                  f'meshes/s, .rrd {path.stat().st_size / 1e6:5.1f} MB')
        ratio = results['scene (bridge)'] / results['per message']
        print(f'  scene / per message: {ratio:.1f}x')


if __name__ == '__main__':
    main()
