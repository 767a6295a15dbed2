"""Benchmark: folded-mesh vertex updates per second, batched against one panel at a time.

Run with ``.venv/bin/python bench/bench_fold_model.py`` (``--quick`` for a short run). One
process, one thread: BLAS threads are pinned to 1 before numpy loads. A "vertex update" is one
vertex position and its normal, recomputed from a new closure per panel. Both paths below run
the same model code on the same closures; the peer calls it once per panel.
"""

import argparse
import os

os.environ.setdefault('OMP_NUM_THREADS', '1')
os.environ.setdefault('OPENBLAS_NUM_THREADS', '1')

from _timing import best_and_median  # noqa: E402
import numpy as np  # noqa: E402

from flectofold_model import (DEFAULT_TOPOLOGY, DEMONSTRATOR_MODULE, fold_mesh,  # noqa: E402
                              FoldModel, PanelBatch)


def batched(model, closures, dtype, out=None):
    state = model.state_from_closure(closures)
    return fold_mesh(model.batch, state.elastica_k, DEFAULT_TOPOLOGY, dtype=dtype, out=out)


def one_at_a_time(singles, closures, dtype):
    for model, closure in zip(singles, closures):
        state = model.state_from_closure(closure)
        fold_mesh(model.batch, state.elastica_k, DEFAULT_TOPOLOGY, dtype=dtype)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--quick', action='store_true', help='fewer repeats, for a smoke run')
    options = parser.parse_args()
    repeats = 3 if options.quick else 15
    vertices = DEFAULT_TOPOLOGY.vertex_count
    rng = np.random.default_rng(7)
    print(f'panel: demonstrator module, {vertices} vertices (21 stations x 41 columns); '
          f'times are best / median of {repeats} runs')
    print(f'{"panels":>7} {"dtype":>8} {"batch ms":>17} {"Mvert/s":>8} {"refill ms":>17} '
          f'{"Mvert/s":>8} {"1-by-1 ms":>19} {"Mvert/s":>8} {"speed-up":>8}')
    for count in (36, 1000, 10000):
        model = FoldModel(PanelBatch.repeat(DEMONSTRATOR_MODULE, count))
        singles = [FoldModel(model.batch.take([i])) for i in range(count)]
        closures = rng.uniform(0.0, 1.0, count)
        for dtype in (np.float64, np.float32):
            fresh = best_and_median(lambda: batched(model, closures, dtype), repeats)
            previous = batched(model, closures, dtype)
            refill = best_and_median(lambda: batched(model, closures, dtype, previous), repeats)
            single_repeats = max(1, repeats // 5) if count >= 1000 else repeats
            single = best_and_median(lambda: one_at_a_time(singles, closures, dtype),
                                     single_repeats)
            updates = count * vertices
            cells = [f'{count:>7} {np.dtype(dtype).name:>8}']
            for best, median in (fresh, refill, single):
                cells.append(f'{best * 1e3:8.2f} / {median * 1e3:6.2f} '
                             f'{updates / best / 1e6:8.2f}')
            cells.append(f'{single[0] / refill[0]:7.0f}x')
            print(' '.join(cells))
    print('Mvert/s uses the best time. Every path includes the closure -> elastica root finding '
          'and the mesh (vertices + normals); "refill" reuses the previous frame\'s arrays '
          '(fold_mesh(out=...)); speed-up = 1-by-1 / refill.')


if __name__ == '__main__':
    main()
