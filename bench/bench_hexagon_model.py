"""Benchmark: the hexagonal fold model's CPU cost against the quad model's, same run.

Run with ``.venv/bin/python bench/bench_hexagon_model.py`` (``--quick`` for a short run). One
process, one thread. For 36 and 1,000 panels it measures, in CPU seconds
(``time.process_time``, best of the repeats): building the model for identical panels and for
panels that all differ (a curved facade moulds each pre-fold differently), one state per panel
at random closures, and one display mesh per panel; then each figure over the quad
demonstrator module's (the peer), which every row also times.
"""

import argparse
import os

os.environ.setdefault('OMP_NUM_THREADS', '1')
os.environ.setdefault('OPENBLAS_NUM_THREADS', '1')

import time  # noqa: E402

import numpy as np  # noqa: E402

from flectofold_model import (DEMONSTRATOR_MODULE, fold_model_of, HEXAGON_MODULE,  # noqa: E402
                              HexagonPanel, PanelGeometry)


def cpu_best(function, repeats):
    """Least CPU time [s] of ``repeats`` calls, and the last call's result."""
    best, result = float('inf'), None
    for _ in range(repeats):
        start = time.process_time()
        result = function()
        best = min(best, time.process_time() - start)
    return best, result


def distinct_panels(kind, count):
    prefolds = np.linspace(0.06, 0.12, count)
    if kind == 'hexagon':
        return [HexagonPanel(circumradius_m=0.62, fold_line_sag_m=0.06, hinge_width_m=0.03,
                             prefold_rad=float(p)) for p in prefolds]
    return [PanelGeometry.with_lens_midrib(length_m=1.0, width_m=1.0, fold_radius_m=1.0,
                                           end_width_m=0.04, hinge_width_m=0.03,
                                           prefold_rad=float(p)) for p in prefolds]


def figures(kind, count, repeats, rng):
    module = HEXAGON_MODULE if kind == 'hexagon' else DEMONSTRATOR_MODULE
    build, model = cpu_best(lambda: fold_model_of([module] * count), repeats)
    build_distinct, _ = cpu_best(lambda: fold_model_of(distinct_panels(kind, count)),
                                 max(1, repeats // 3))
    closures = rng.uniform(0.0, 1.0, count)
    state_s, state = cpu_best(lambda: model.state_from_closure(closures), repeats)
    mesh_s, mesh = cpu_best(lambda: model.mesh(state.shape_parameter), repeats)
    return {'build': build, 'build distinct': build_distinct, 'states': state_s,
            'meshes': mesh_s, 'vertices': mesh.vertices.shape[1]}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--quick', action='store_true', help='fewer repeats, for a smoke run')
    options = parser.parse_args()
    repeats = 2 if options.quick else 6
    rng = np.random.default_rng(3)
    columns = ('build', 'build distinct', 'states', 'meshes')
    print(f'CPU seconds, best of {repeats} (build distinct: of {max(1, repeats // 3)}); '
          f'ratio = hexagon / quad')
    print(f'{"panels":>7} {"kind":>8} ' + ' '.join(f'{c:>15}' for c in columns)
          + f' {"vertices":>9}')
    for count in (36, 1000):
        quad = figures('quad', count, repeats, rng)
        hexagon = figures('hexagon', count, repeats, rng)
        for kind, row in (('quad', quad), ('hexagon', hexagon)):
            print(f'{count:>7} {kind:>8} ' + ' '.join(f'{row[c]:15.4f}' for c in columns)
                  + f' {row["vertices"]:>9}')
        ratios = ' '.join(f'{hexagon[c] / quad[c]:15.2f}' for c in columns)
        print(f'{count:>7} {"ratio":>8} {ratios}')


if __name__ == '__main__':
    main()
