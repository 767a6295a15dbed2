"""Convergence and CPU cost of the ray casting against hexagonal panels.

Run with ``.venv/bin/python bench/bench_hexagon_shading.py`` (about two minutes). One process,
BLAS pinned to one thread. Prints the figures of msg_docs/hexagon_shading.md:

1. the blocked fraction's error against a dense mesh (48 rulings per sector, 16 rings, 32 flap
   columns: 13,206 triangles) at the same scan lines, per mesh topology;
2. its error against dense scan lines (samples 72: 216 lines) on the same mesh, per
   ``samples``;
3. the default (topology and samples) against the dense mesh with dense lines;
4. CPU seconds (``time.process_time``) of ``blocked_fraction`` for 36 hexagonal and 36 quad
   panels over one set of suns.

The cases: HEXAGON_MODULE at closures 0, 0.25, 0.5, 0.75 and 1 under the facade normal and 23
suns drawn uniformly over 0-85 deg off the normal and every azimuth (seed 3).
"""

import os
import time

os.environ.setdefault('OMP_NUM_THREADS', '1')
os.environ.setdefault('OPENBLAS_NUM_THREADS', '1')

import numpy as np  # noqa: E402

from flectofold_model.kinematics.closure import FoldModel  # noqa: E402
from flectofold_model.kinematics.hexagon_closure import HexagonFoldModel  # noqa: E402
from flectofold_model.kinematics.hexagon_mesh import HexagonTopology  # noqa: E402
from flectofold_model.kinematics.hexagon_panel import HEXAGON_MODULE, HexagonBatch  # noqa: E402
from flectofold_model.kinematics.panel import DEMONSTRATOR_MODULE, PanelBatch  # noqa: E402
from flectofold_model.shading.ray_casting import (blocked_fraction, DEFAULT_SAMPLES,  # noqa: E402
                                                  HEXAGON_SHADING_TOPOLOGY)
from flectofold_model.shading.scan_lines import line_count  # noqa: E402

DENSE_TOPOLOGY = HexagonTopology(rulings_per_sector=48, rings=16, flap_columns=32)
DENSE_SAMPLES = 72
TOPOLOGIES = [HexagonTopology(2, 1, 2), HexagonTopology(4, 1, 3), HexagonTopology(4, 2, 3),
              HexagonTopology(6, 2, 4), HexagonTopology(8, 2, 5), HexagonTopology(12, 4, 8),
              HexagonTopology(16, 4, 10), HexagonTopology(24, 8, 16)]
SAMPLES = (12, 16, 24, 36, 48)
CLOSURES = np.array([0.0, 0.25, 0.5, 0.75, 1.0])


def toward(off_normal_deg, azimuth_deg):
    off, azimuth = np.radians(off_normal_deg), np.radians(azimuth_deg)
    return np.stack([np.sin(off) * np.cos(azimuth), np.sin(off) * np.sin(azimuth),
                     np.cos(off)], axis=-1)


def sun_set(count=23, seed=3):
    rng = np.random.default_rng(seed)
    drawn = toward(rng.uniform(0.0, 85.0, count), rng.uniform(0.0, 360.0, count))
    return np.vstack([[0.0, 0.0, 1.0], drawn])


def cases():
    """HEXAGON_MODULE batch, centre rises and suns of every (closure, sun) case."""
    suns = sun_set()
    model = HexagonFoldModel(HexagonBatch.repeat(HEXAGON_MODULE, CLOSURES.size))
    rise = np.repeat(model.state_from_closure(CLOSURES).shape_parameter, len(suns))
    return HexagonBatch.repeat(HEXAGON_MODULE, rise.size), rise, np.tile(suns, (CLOSURES.size, 1))


def timed(function):
    start = time.process_time()
    value = function()
    return value, time.process_time() - start


def errors(estimate, reference):
    error = np.abs(estimate - reference)
    return f'max {error.max():.4f}  mean {error.mean():.4f}'


def topology_convergence(batch, rise, sun):
    print(f'== mesh topology, {DEFAULT_SAMPLES} samples ({line_count(DEFAULT_SAMPLES)} '
          f'scan lines), against {len(DENSE_TOPOLOGY.faces)} triangles ==')
    reference, cpu = timed(lambda: blocked_fraction(batch, rise, sun, DENSE_TOPOLOGY)
                           .blocked_fraction)
    print(f'reference: {cpu:.1f} CPU s for {len(batch)} cases')
    for topology in TOPOLOGIES:
        value, cpu = timed(lambda: blocked_fraction(batch, rise, sun, topology).blocked_fraction)
        chosen = '  <- HEXAGON_SHADING_TOPOLOGY' if topology == HEXAGON_SHADING_TOPOLOGY else ''
        print(f'({topology.rulings_per_sector:>2}, {topology.rings:>2}, '
              f'{topology.flap_columns:>2}) {len(topology.faces):>5} triangles: '
              f'{errors(value, reference)}  {cpu:5.2f} CPU s{chosen}')
    return reference


def sample_convergence(batch, rise, sun):
    print(f'== samples, on HEXAGON_SHADING_TOPOLOGY, against samples {DENSE_SAMPLES} '
          f'({line_count(DENSE_SAMPLES)} scan lines) ==')
    reference = blocked_fraction(batch, rise, sun, samples=DENSE_SAMPLES).blocked_fraction
    for samples in SAMPLES:
        value, cpu = timed(lambda: blocked_fraction(batch, rise, sun, samples=samples)
                           .blocked_fraction)
        print(f'samples {samples:>2} ({line_count(samples):>4} lines): '
              f'{errors(value, reference)}  {cpu:5.2f} CPU s')


def combined(batch, rise, sun):
    print('== default (topology and samples) against the dense mesh with dense rays ==')
    reference = blocked_fraction(batch, rise, sun, DENSE_TOPOLOGY,
                                 samples=DENSE_SAMPLES).blocked_fraction
    for samples in (16, DEFAULT_SAMPLES):
        value = blocked_fraction(batch, rise, sun, samples=samples).blocked_fraction
        print(f'samples {samples}: {errors(value, reference)}')


def cost_36_panels():
    print('== CPU cost: blocked_fraction of 36 panels, closures 0..1, the same 24 suns ==')
    suns = sun_set()
    closures = np.linspace(0.0, 1.0, 36)
    hexagons = HexagonFoldModel(HexagonBatch.repeat(HEXAGON_MODULE, 36))
    quads = FoldModel(PanelBatch.repeat(DEMONSTRATOR_MODULE, 36))
    for name, model in (('hexagon (HEXAGON_MODULE)', hexagons),
                        ('quad (DEMONSTRATOR_MODULE)', quads)):
        shape = model.state_from_closure(closures).shape_parameter
        blocked_fraction(model.batch, shape, suns[0])  # warm-up
        _, cpu = timed(lambda: [blocked_fraction(model.batch, shape, sun) for sun in suns])
        print(f'{name:<27}: {cpu / len(suns) * 1e3:6.1f} CPU ms per call '
              f'({cpu / len(suns) / 36 * 1e3:.2f} ms per panel and sun)')


def main():
    batch, rise, sun = cases()
    topology_convergence(batch, rise, sun)
    sample_convergence(batch, rise, sun)
    combined(batch, rise, sun)
    cost_36_panels()


if __name__ == '__main__':
    main()
