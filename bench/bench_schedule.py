"""Timings of the coordinator's per-period work: the scheduler and the shading ray casting.

Run with ``.venv/bin/python bench/bench_schedule.py``. One process, BLAS pinned to one thread.
"""

import os
import time

os.environ.setdefault('OMP_NUM_THREADS', '1')
os.environ.setdefault('OPENBLAS_NUM_THREADS', '1')

import numpy as np  # noqa: E402

from flectofold_model.closure import FoldModel  # noqa: E402
from flectofold_model.day_report import simulate_day  # noqa: E402
from flectofold_model.facade import load_facade  # noqa: E402
from flectofold_model.panel import DEMONSTRATOR_MODULE, PanelBatch  # noqa: E402
from flectofold_model.scheduler import Scheduler, SchedulerParameters  # noqa: E402
from flectofold_model.shading import blocked_fraction  # noqa: E402


def median_ms(function, repeats):
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return 1e3 * float(np.median(times))


def scheduler_timings():
    print('== scheduler: one step, random desired closures, 60 s period ==')
    rng = np.random.default_rng(3)
    for count in (36, 1000, 10000):
        scheduler = Scheduler(count, np.full(count, 16.0), SchedulerParameters(),
                              zones=np.arange(count) % 6)
        clock = [0.0]

        def step():
            clock[0] += 60.0
            scheduler.step(clock[0], rng.uniform(0, 1, count), wind_m_s=3.0, dni_w_m2=600.0,
                           faulted=rng.uniform(0, 1, count) < 0.01)
        print(f'{count:>6} panels: {median_ms(step, 60):7.2f} ms median per step')


def shading_timings():
    print('== shading: blocked fraction by ray casting (24 x 24 rays, 280 triangles) ==')
    for count in (36, 1000):
        model = FoldModel(PanelBatch.repeat(DEMONSTRATOR_MODULE, count))
        k = model.state_from_closure(np.linspace(0, 1, count)).elastica_k
        for angle in (0.0, 45.0, 80.0):
            theta = np.radians(angle)
            sun = np.array([0.0, np.sin(theta), np.cos(theta)])
            elapsed = median_ms(lambda: blocked_fraction(model.batch, k, sun), 3)
            print(f'{count:>6} panels, sun {angle:4.0f} deg off normal: {elapsed:8.1f} ms')


def day_timing():
    facade = load_facade()
    start = time.perf_counter()
    simulate_day(facade, '2026-06-21', step_s=600.0)
    print(f'== day report: {len(facade)} panels, 144 steps: '
          f'{time.perf_counter() - start:.1f} s ==')


if __name__ == '__main__':
    scheduler_timings()
    shading_timings()
    day_timing()
