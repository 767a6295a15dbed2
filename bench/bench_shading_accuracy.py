"""Accuracy and CPU cost of the direct-sun blocked fraction, against a converged reference.

Run with ``.venv/bin/python bench/bench_shading_accuracy.py`` (a few minutes). One process,
BLAS pinned to one thread. Prints the figures of msg_docs/scheduling.md (section "Accuracy of
the blocked fraction"):

1. the reference and its convergence: the exact area of the union of the sheets' shadows
   (the mesh's triangles and their neighbours' copies projected along the sun onto the
   footprint plane), integrated exactly along ``ROWS`` rows of the footprint (midpoint rule
   across them), compared with twice as many rows;
2. the error of ``blocked_fraction`` at the default ``samples`` (24) and at the shading
   table's (16), and at 96 and 192, against the reference, for the quad
   DEMONSTRATOR_MODULE and the HEXAGON_MODULE: max and mean over closures 0 ... 1 and suns
   0 ... 80 deg off the facade normal at every 15 deg of azimuth;
3. CPU seconds (``time.process_time``, the least of ``REPEATS`` runs at samples 16 and 24)
   of those calls and of building a ShadingTable;
4. the errors at samples 16 and 24 over a finer sweep: every degree of azimuth at 50 and
   75 deg off the normal, closures 0.5 and 1.

With ``git`` and the repository at hand, the same figures are printed for the point
sampling that this module replaced (commit ``BASELINE_COMMIT``, cell-centre rays), loaded
from git history into this process, and the ratio of the CPU times, old over new.
"""

import importlib.util
import math
import os
import subprocess
import sys
import time
import types

os.environ.setdefault('OMP_NUM_THREADS', '1')
os.environ.setdefault('OPENBLAS_NUM_THREADS', '1')

import numpy as np  # noqa: E402

from flectofold_model.kinematics.closure import FoldModel  # noqa: E402
from flectofold_model.kinematics.hexagon_closure import HexagonFoldModel  # noqa: E402
from flectofold_model.kinematics.hexagon_panel import HEXAGON_MODULE, HexagonBatch  # noqa: E402
from flectofold_model.kinematics.panel import DEMONSTRATOR_MODULE, PanelBatch  # noqa: E402
from flectofold_model.shading import ray_casting, scan_lines, table  # noqa: E402

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', 'test',
                                'helpers'))
import shadow_area  # noqa: E402, I100

#: The last commit with cell-centre point sampling.
BASELINE_COMMIT = 'fe846d7'
ROWS = 2048
CLOSURES = np.array([0.0, 0.25, 0.5, 0.75, 1.0])
OFF_NORMAL_DEG = (20.0, 40.0, 60.0, 70.0, 80.0)
AZIMUTH_STEP_DEG = 15.0
SAMPLES = (16, 24, 96, 192)
#: CPU times at samples 16 and 24, and of the table, are the least of this many runs.
REPEATS = 3
STANDOFF_M = ray_casting.DEFAULT_STANDOFF_M


def toward(off_normal_deg, azimuth_deg):
    off, azimuth = np.radians(off_normal_deg), np.radians(azimuth_deg)
    return np.stack([np.sin(off) * np.cos(azimuth), np.sin(off) * np.sin(azimuth),
                     np.cos(off)], axis=-1)


def sun_grid():
    """(M, 3) the facade normal and every (off-normal, azimuth) pair of the grid."""
    off, azimuth = np.meshgrid(OFF_NORMAL_DEG, np.arange(0.0, 360.0, AZIMUTH_STEP_DEG))
    return np.vstack([[0.0, 0.0, 1.0], toward(off.ravel(), azimuth.ravel())])


def cases(kind):
    """Fold model of one panel repeated over all (closure, sun) cases, shapes and suns."""
    suns = sun_grid()
    if kind == 'quad':
        model = FoldModel(PanelBatch.repeat(DEMONSTRATOR_MODULE, CLOSURES.size * len(suns)))
    else:
        model = HexagonFoldModel(HexagonBatch.repeat(HEXAGON_MODULE, CLOSURES.size * len(suns)))
    shape = model.state_from_closure(np.repeat(CLOSURES, len(suns))).shape_parameter
    return model, shape, np.tile(suns, (CLOSURES.size, 1))


# -- reference: exact shadow area along rows (the tests' reference, test/helpers) ------------

def reference_fraction(kind, vertices, faces, sun, rows=ROWS):
    """Blocked share of the footprint: area of the union of the shadows over its area.

    :func:`shadow_area.blocked_share`: the triangles (of the panel and its copies) projected
    along the sun onto the footprint plane ``z = -standoff``, each row of the footprint
    meeting each shadow triangle in an interval, the union of a row's intervals measured
    exactly, the rows (midpoints of equal strips) summed.
    """
    footprint = (shadow_area.quad_footprint(DEMONSTRATOR_MODULE.length_m,
                                            DEMONSTRATOR_MODULE.width_m) if kind == 'quad'
                 else shadow_area.hexagon_footprint(HEXAGON_MODULE.circumradius_m))
    return shadow_area.blocked_share(vertices, faces, footprint, sun, STANDOFF_M, rows=rows)


def references(kind, model, shape, sun, rows=ROWS):
    topology = (ray_casting.SHADING_TOPOLOGY if kind == 'quad'
                else ray_casting.HEXAGON_SHADING_TOPOLOGY)
    mesh = (model.mesh(shape, topology) if kind == 'hexagon'
            else _quad_mesh(model, shape, topology))
    assert mesh.vertices[..., 2].min() >= -STANDOFF_M  # every shadow is a ray's hit
    return np.array([reference_fraction(kind, mesh.vertices[n], mesh.faces, sun[n], rows)
                     for n in range(len(shape))])


def _quad_mesh(model, shape, topology):
    from flectofold_model.kinematics.mesh import fold_mesh
    return fold_mesh(model.batch, shape, topology)


# -- the baseline, from git history ---------------------------------------------------------

def baseline_module():
    """Load the ray casting of BASELINE_COMMIT (cell-centre rays) as a module, or None."""
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

    def source(path):
        return subprocess.run(['git', 'show', f'{BASELINE_COMMIT}:{path}'], cwd=root,
                              check=True, capture_output=True, text=True).stdout
    try:
        tiling = source('flectofold_model/shading/hexagon_tiling.py')
        casting = source('flectofold_model/shading/ray_casting.py')
    except (OSError, subprocess.CalledProcessError):
        return None
    old_tiling = types.ModuleType('baseline_hexagon_tiling')
    exec(compile(tiling, 'baseline_hexagon_tiling', 'exec'), old_tiling.__dict__)
    line = 'from flectofold_model.shading import hexagon_tiling\n'
    assert line in casting
    old = types.ModuleType('baseline_ray_casting')
    old.__dict__['hexagon_tiling'] = old_tiling
    exec(compile(casting.replace(line, ''), 'baseline_ray_casting', 'exec'), old.__dict__)
    return old


def baseline_table(old):
    """Return a ShadingTable class whose casting is the baseline's."""
    spec = importlib.util.find_spec('flectofold_model.shading.table')
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    module.blocked_fraction = old.blocked_fraction
    module.view_fraction = old.view_fraction
    return module.ShadingTable


# -- figures ---------------------------------------------------------------------------------

def timed(function, repeats=1):
    """Value of ``function()`` and its least CPU time [s] over ``repeats`` calls."""
    best = np.inf
    for _ in range(repeats):
        start = time.process_time()
        value = function()
        best = min(best, time.process_time() - start)
    return value, best


def resolution(name, kind, samples):
    if name == 'new':
        return f'{scan_lines.line_count(samples):>4} lines'
    rays = samples**2 if kind == 'quad' else 6 * round(samples / math.sqrt(6.0))**2
    return f'{rays:>5} rays'


def errors(value, reference):
    error = np.abs(value - reference)
    return error.max(), error.mean()


def convergence(kind, model, shape, sun, reference):
    fine = references(kind, model, shape, sun, 2 * ROWS)
    worst, mean = errors(reference, fine)
    print(f'{kind:<8} reference, {ROWS} rows against {2 * ROWS}: max {worst:.2e}  '
          f'mean {mean:.2e}')


def accuracy(kind, model, shape, sun, reference, implementations):
    print(f'| {kind} | samples | resolution | max error | mean error | CPU s, {len(shape)} '
          f'cases | CPU old / new |')
    cpu_of = {}
    for samples in SAMPLES:
        for name, module in implementations:
            if module is None:
                continue
            value, cpu = timed(lambda: module.blocked_fraction(model.batch, shape, sun,
                                                               samples=samples).blocked_fraction,
                               REPEATS if samples <= 24 else 1)
            worst, mean = errors(value, reference)
            cpu_of[name, samples] = cpu
            ratio = (f'{cpu_of["old", samples] / cpu:.2f}'
                     if name == 'new' and ('old', samples) in cpu_of else '')
            print(f'| {name} | {samples} | {resolution(name, kind, samples)} | {worst:.4f} | '
                  f'{mean:.5f} | {cpu:.2f} | {ratio} |')


def worst_cases(kind, shape, sun, value, reference, count=3):
    error = np.abs(value - reference)
    for n in np.argsort(-error)[:count]:
        off = math.degrees(math.acos(sun[n, 2]))
        azimuth = math.degrees(math.atan2(sun[n, 1], sun[n, 0])) % 360.0
        closure = CLOSURES[n // len(sun_grid())]
        print(f'    closure {closure:.2f}, {off:4.1f} deg off normal, azimuth {azimuth:5.1f}: '
              f'{value[n]:.4f} against {reference[n]:.4f}')


def azimuth_sweep(implementations):
    """Max and mean error over every degree of azimuth, 50 and 75 deg off the normal."""
    print('== sweep: azimuth every 1 deg, 50 and 75 deg off the normal, closures 0.5 and 1 ==')
    off, azimuth, closure = np.meshgrid([50.0, 75.0], np.arange(0.0, 360.0, 1.0), [0.5, 1.0],
                                        indexing='ij')
    sun = toward(off.ravel(), azimuth.ravel())
    for kind in ('quad', 'hexagon'):
        count = sun.shape[0]
        model = (FoldModel(PanelBatch.repeat(DEMONSTRATOR_MODULE, count)) if kind == 'quad'
                 else HexagonFoldModel(HexagonBatch.repeat(HEXAGON_MODULE, count)))
        shape = model.state_from_closure(closure.ravel()).shape_parameter
        reference = references(kind, model, shape, sun)
        for samples in (16, 24):
            figures = []
            for name, module in implementations:
                if module is not None:
                    value = module.blocked_fraction(model.batch, shape, sun,
                                                    samples=samples).blocked_fraction
                    worst, mean = errors(value, reference)
                    figures.append(f'{name} max {worst:.4f} mean {mean:.5f}')
            print(f'{kind:<8} samples {samples}: ' + '   '.join(figures))


def table_cost(implementations):
    print('== building a ShadingTable (defaults: 11 closures, 5 deg steps, samples 16) ==')
    for panel in (DEMONSTRATOR_MODULE, HEXAGON_MODULE):
        cpu_of = {}
        for name, module in implementations:
            if module is None:
                continue
            cls = table.ShadingTable if name == 'new' else baseline_table(module)
            _, cpu = timed(lambda: cls(panel), REPEATS)
            cpu_of[name] = cpu
        label = 'DEMONSTRATOR_MODULE' if panel is DEMONSTRATOR_MODULE else 'HEXAGON_MODULE'
        figures = '  '.join(f'{name} {cpu:.2f} CPU s' for name, cpu in cpu_of.items())
        ratio = (f'  old / new {cpu_of["old"] / cpu_of["new"]:.2f}' if 'old' in cpu_of else '')
        print(f'{label:<20}: {figures} (least of {REPEATS}){ratio}')


def main():
    old = baseline_module()
    if old is None:
        print(f'(git history unavailable: no figures for the baseline {BASELINE_COMMIT})')
    implementations = [('old', old), ('new', ray_casting)]
    print(f'{len(CLOSURES)} closures x {len(sun_grid())} suns per panel kind; '
          f'reference: {ROWS} rows')
    for kind in ('quad', 'hexagon'):
        model, shape, sun = cases(kind)
        reference, cpu = timed(lambda: references(kind, model, shape, sun))
        print(f'== {kind}: reference in {cpu:.1f} CPU s ==')
        convergence(kind, model, shape, sun, reference)
        accuracy(kind, model, shape, sun, reference, implementations)
        for name, module in implementations:
            if module is not None:
                print(f'  worst cases, {name}, default samples:')
                value = module.blocked_fraction(model.batch, shape, sun).blocked_fraction
                worst_cases(kind, shape, sun, value, reference)
    azimuth_sweep(implementations)
    table_cost(implementations)
    sys.stdout.flush()


if __name__ == '__main__':
    main()
