"""Timings of the coordinator's per-period work: the scheduler and the shading ray casting.

Run with ``.venv/bin/python bench/bench_schedule.py``. One process, BLAS pinned to one thread.
"""

import os
import time

os.environ.setdefault('OMP_NUM_THREADS', '1')
os.environ.setdefault('OPENBLAS_NUM_THREADS', '1')

from _timing import best_and_median  # noqa: E402
import numpy as np  # noqa: E402

from flectofold_model.facade.description import load_facade  # noqa: E402
from flectofold_model.kinematics.closure import FoldModel  # noqa: E402
from flectofold_model.kinematics.panel import DEMONSTRATOR_MODULE, PanelBatch  # noqa: E402
from flectofold_model.scheduling.day_report import simulate_day  # noqa: E402
from flectofold_model.scheduling.scheduler import Scheduler, SchedulerParameters  # noqa: E402
from flectofold_model.shading.ray_casting import blocked_fraction  # noqa: E402
from flectofold_model.shading.table import ShadingTable  # noqa: E402


def median_ms(function, repeats):
    return 1e3 * best_and_median(function, repeats)[1]


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


def table_timings():
    print('== sun -> closures for 10,000 panels through a shading table, then the scheduler ==')
    start = time.perf_counter()
    table = ShadingTable(DEMONSTRATOR_MODULE, step_deg=5.0)
    print(f'table build (one panel type, 11 closures x 35 x 35 sun directions): '
          f'{time.perf_counter() - start:.1f} s')
    rng = np.random.default_rng(4)
    count = 10000
    alpha, beta = np.radians(rng.uniform(-60, 60, (2, count)))
    sun = np.stack([np.tan(alpha), np.tan(beta), np.ones(count)], axis=-1)
    sun /= np.linalg.norm(sun, axis=-1, keepdims=True)
    model = FoldModel(PanelBatch.repeat(DEMONSTRATOR_MODULE, 400))
    for index in (0, 5, 10):
        closure = table.closures[index]
        exact = blocked_fraction(model.batch, model.state_from_closure(closure).elastica_k,
                                 sun[:400], samples=16).blocked_fraction
        error = np.abs(table.blocked_fractions(sun[:400])[:, index] - exact)
        print(f'closure {closure:.1f}: table vs ray casting on 400 random suns, mean |error| '
              f'{error.mean():.4f}, max {error.max():.3f}')
    scheduler = Scheduler(count, np.full(count, 16.0), SchedulerParameters())
    clock = [0.0]

    def period():
        clock[0] += 60.0
        scheduler.step(clock[0], table.choose(sun, 0.9), dni_w_m2=600.0)
    print(f'{count} panels, one period (choose + schedule): {median_ms(period, 20):.1f} ms')


def day_timing():
    facade = load_facade()
    start = time.perf_counter()
    simulate_day(facade, '2026-06-21', step_s=600.0)
    print(f'== day report: {len(facade)} panels, 144 steps: '
          f'{time.perf_counter() - start:.1f} s ==')


if __name__ == '__main__':
    scheduler_timings()
    shading_timings()
    table_timings()
    day_timing()
