"""Timings of the coordinator's per-period work: the scheduler and the shading ray casting.

Run with ``.venv/bin/python bench/bench_schedule.py [section ...]`` (sections: scheduler,
shading, table, day, controller, limit; all by default). One process, BLAS pinned to one
thread.
"""

import datetime
import os
from pathlib import Path
import sys
import time

os.environ.setdefault('OMP_NUM_THREADS', '1')
os.environ.setdefault('OPENBLAS_NUM_THREADS', '1')

from _facades import large_facade_text  # noqa: E402
from _timing import best_and_median  # noqa: E402
import numpy as np  # noqa: E402

from flectofold_model.environment.clear_sky import clear_sky_dni  # noqa: E402
from flectofold_model.environment.sun import sun_vector_enu  # noqa: E402
from flectofold_model.facade.description import (build_facade, DEFAULT_FACADE,  # noqa: E402
                                                 load_facade)
from flectofold_model.kinematics.closure import FoldModel  # noqa: E402
from flectofold_model.kinematics.panel import DEMONSTRATOR_MODULE, PanelBatch  # noqa: E402
from flectofold_model.scheduling import annual_report as annual  # noqa: E402
from flectofold_model.scheduling.day_report import simulate_day  # noqa: E402
from flectofold_model.scheduling.facade_schedule import (FacadeSchedule,  # noqa: E402
                                                         representative_panel)
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


#: The sunny instant of the controller timings: 2026-06-21 11:00 UTC, one decision a minute.
DECISION_START_S = datetime.datetime(2026, 6, 21, 11, 0,
                                     tzinfo=datetime.timezone.utc).timestamp()
DECISIONS = 20


def large_facade(rows=25, columns=40):
    """YAML of the demonstrator's modules on a ``rows`` x ``columns`` grid (bench_rerun's)."""
    return large_facade_text(rows, columns)


def with_controller(text, controller):
    """Build the facade of YAML ``text`` with ``control.controller`` set."""
    assert 'control:\n' in text and 'controller:' not in text
    return build_facade(text.replace('control:\n', f'control:\n  controller: {controller}\n'))


def decision_times(schedule, start_s, window):
    """Return the CPU and wall times [s] of a warm-up decision and DECISIONS more.

    The warm-up at ``start_s - 60`` fills the ephemeris and clear-sky caches and loads or
    compiles the numba kernels; the others follow every 60 s. The coordinator's inputs: the
    sun now (and the look-ahead window for the target rule), the clear-sky DNI as the
    measured DNI, a light wind.
    """
    facade = schedule.facade
    period = float(facade.control.get('period_s', 60.0))
    look = float(facade.control.get('look_ahead_s', 0.0)) if window else 0.0
    times = start_s + period * np.arange(-1, DECISIONS)
    ahead = period * np.arange(1, int(look / period + 1e-9) + 1)
    suns = [sun_vector_enu(np.concatenate([[t], t + ahead]), facade.site) for t in times]
    dni = clear_sky_dni(times, facade.site)
    cpu, wall = [], []
    for k, (t, sun) in enumerate(zip(times, suns)):
        start_cpu, start_wall = time.process_time(), time.perf_counter()
        schedule.step(float(t), sun if window else sun[0], dni_w_m2=float(dni[k]),
                      wind_m_s=3.0)
        cpu.append(time.process_time() - start_cpu)
        wall.append(time.perf_counter() - start_wall)
    return np.array(cpu), np.array(wall)  # the first is the warm-up


def controller_timings():
    print(f'== coordinator decision (FacadeSchedule.step): predictive vs target rule, '
          f'{DECISIONS} decisions 60 s apart from 2026-06-21 11:00 UTC after a warm-up; '
          f'ms CPU (process_time) / wall ==')
    for count, text in ((36, Path(DEFAULT_FACADE).read_text()), (1000, large_facade())):
        facades = {name: with_controller(text, name) for name in ('predictive', 'target')}
        assert len(facades['target']) == count
        table = ShadingTable(representative_panel(facades['target']))
        figures = {}
        for name, facade in facades.items():
            schedule = FacadeSchedule(facade, start_s=DECISION_START_S - 3600.0, table=table)
            assert schedule.controller == name
            cpu, wall = decision_times(schedule, DECISION_START_S, window=name == 'target')
            print(f'{count:>6} panels, {name:>10}: CPU median {1e3 * np.median(cpu[1:]):7.2f} '
                  f'ms, max {1e3 * cpu[1:].max():7.2f} ms; wall median '
                  f'{1e3 * np.median(wall[1:]):7.2f} ms, max {1e3 * wall[1:].max():7.2f} ms '
                  f'(warm-up call: {1e3 * cpu[0]:.0f} ms CPU, {1e3 * wall[0]:.0f} ms wall)')
            figures[name] = cpu[1:], wall[1:]
        ratio = np.median(figures['predictive'][0]) / np.median(figures['target'][0])
        print(f'{count:>6} panels: predictive / target, median CPU: {ratio:5.1f} x')


def limit_timing():
    import pvlib
    from flectofold_model.environment import read_weather
    from flectofold_model.scheduling import frontier
    path = os.path.join(os.path.dirname(pvlib.__file__), 'data', '723170TYA.CSV')
    facade = load_facade()
    weather = read_weather(path)
    spent = {'limit_at': [], 'frontier': []}

    def timed(name, function):
        def wrapper(*args, **kwargs):
            start_cpu, start_wall = time.process_time(), time.perf_counter()
            try:
                return function(*args, **kwargs)
            finally:
                spent[name].append((time.process_time() - start_cpu,
                                    time.perf_counter() - start_wall))
        return wrapper

    originals = annual.limit_at, annual.frontier
    annual.limit_at = timed('limit_at', frontier.limit_at)
    annual.frontier = timed('frontier', frontier.frontier)
    try:
        # a first run compiles the kernels, which are not the limit's cost
        annual.annual_report(facade, weather, first_date='06-21', last_date='06-22',
                             families=False)
        for value in spent.values():
            value.clear()
        start_cpu, start_wall = time.process_time(), time.perf_counter()
        report = annual.annual_report(facade, weather, families=False)
        total_cpu = time.process_time() - start_cpu
        total_wall = time.perf_counter() - start_wall
    finally:
        annual.limit_at, annual.frontier = originals
    print(f'== the limit over a year: annual_report(families=False), {len(facade)} panels, '
          f'Greensboro TMY3, {report.range_days:.0f} days at {report.step_s / 60:g} min, '
          f'controller {report.controller} ==')
    print(f'annual_report total: {total_cpu:.1f} s CPU, {total_wall:.1f} s wall')
    first, rest = np.array(spent['limit_at'][:1]), np.array(spent['limit_at'][1:])
    print(f'limit_at, the limit at the scheduled blocking (with the limits): '
          f'{report.limit.evaluations} values of view, {first[0, 0]:.2f} s CPU, '
          f'{first[0, 1]:.2f} s wall')
    print(f'limit_at, the gaps (each strategy, with and without the limits): {len(rest)} '
          f'calls, {rest[:, 0].sum():.2f} s CPU, {rest[:, 1].sum():.2f} s wall')
    every = np.array(spent['limit_at'])
    print(f'limit_at, all {len(every)} calls: {every[:, 0].sum():.2f} s CPU, '
          f'{every[:, 1].sum():.2f} s wall')
    every = np.array(spent['frontier'])
    print(f'frontier (free and limited): {len(every)} calls, {every[:, 0].sum():.2f} s CPU, '
          f'{every[:, 1].sum():.2f} s wall')


SECTIONS = {'scheduler': scheduler_timings, 'shading': shading_timings,
            'table': table_timings, 'day': day_timing, 'controller': controller_timings,
            'limit': limit_timing}


if __name__ == '__main__':
    unknown = set(sys.argv[1:]) - set(SECTIONS)
    if unknown:
        raise SystemExit(f'unknown section(s) {", ".join(sorted(unknown))}; '
                         f'known: {", ".join(SECTIONS)}')
    for name in sys.argv[1:] or SECTIONS:
        SECTIONS[name]()
