"""The clairvoyant limit against brute force: every schedule of a tiny facade enumerated."""

import itertools
import math

import numpy as np
import pytest

from flectofold_model.scheduling.frontier import (best_schedule, ClosureProblem, frontier,
                                                  limit_at, Limits, view_on_frontier)
from flectofold_model.scheduling.paths import limited_paths
from flectofold_model.scheduling.scheduler import SchedulerParameters

HOUR_S = 3600.0
#: 22:00 UTC: the steps of the tiny problems cross a UTC midnight after two steps.
START_S = 20000 * 86400.0 - 2 * HOUR_S


def tiny_problem(seed, steps=5, count=2, closures=(0.0, 0.5, 1.0)):
    rng = np.random.default_rng(seed)
    closures = np.asarray(closures)
    size = closures.size
    view = np.sort(rng.uniform(0.0, 0.9, size))
    return ClosureProblem(
        closures=closures, direct_w_m2=rng.uniform(0, 800, (steps, count)),
        blocked=rng.uniform(0, 1, (steps, count, size)), view=view,
        daylight=rng.uniform(0, 1, steps) < 0.8, step_s=HOUR_S,
        start_s=START_S + HOUR_S * np.arange(steps),
        weights=np.full(count, 1.0 / count), air_nl=np.full(count, 16.0))


def keeps_limits(path, problem, parameters, latched, start):
    """Check the scheduler's limits on a path of candidate indices, read independently."""
    closures = problem.closures
    storm = int(np.argmin(np.abs(closures - parameters.storm_position)))
    held, moves, last_move_s = start, 0, -math.inf
    day = math.floor(problem.start_s[0] / 86400.0)
    for t, level in enumerate(path):
        now = problem.start_s[t]
        if math.floor(now / 86400.0) != day:
            day, moves = math.floor(now / 86400.0), 0
        if latched[t]:
            if level != storm:
                return False
            if level != held:
                moves, last_move_s = min(moves + 1, parameters.daily_move_cap), now
        elif level != held:
            change = abs(closures[level] - closures[held])
            if change < parameters.deadband or change > parameters.rate_per_s * HOUR_S + 1e-12:
                return False
            if moves >= parameters.daily_move_cap or now - last_move_s < parameters.min_dwell_s:
                return False
            moves, last_move_s = moves + 1, now
        held = level
    return True


def panel_points(problem, parameters, latched, panel):
    """(B [Wh/m2], V [h]) of every path of one panel that keeps the limits, by enumeration."""
    start = 0 if parameters is None else int(
        np.argmin(np.abs(problem.closures - parameters.default_closure)))
    steps = problem.daylight.size
    points = []
    for path in itertools.product(range(problem.closures.size), repeat=steps):
        if parameters is not None and not keeps_limits(path, problem, parameters, latched,
                                                       start):
            continue
        levels = np.zeros((steps, problem.weights.size), np.int8)
        levels[:, panel] = path
        blocked, view = problem.per_panel(levels)
        points.append((blocked[panel], view[panel], path))
    return points


BINDING = SchedulerParameters(deadband=0.4, rate_per_s=0.7 / HOUR_S, min_dwell_s=2 * HOUR_S,
                              daily_move_cap=2, default_closure=1.0, storm_position=0.0)


@pytest.mark.parametrize('seed', range(6))
def test_each_panels_dynamic_programme_finds_the_best_path_that_keeps_every_limit(seed):
    problem = tiny_problem(seed, steps=6, count=2, closures=(0.0, 1 / 3, 2 / 3, 1.0))
    latched = np.zeros(6, bool)
    latched[4] = seed % 2 == 0  # a storm hour in half the cases
    limits = Limits.of(problem, BINDING, latched)
    assert limits.dwell_steps == 2 and limits.daily_move_cap == 2
    for value in (0.0, 30.0, 150.0, 900.0):
        schedule = best_schedule(problem, value, limits)
        blocked, view = problem.per_panel(schedule.levels)
        for panel in range(2):
            assert keeps_limits(schedule.levels[:, panel], problem, BINDING, latched, 3)
            best = max(b + value * v for b, v, _ in panel_points(problem, BINDING, latched,
                                                                 panel))
            assert blocked[panel] + value * view[panel] == pytest.approx(best, rel=1e-12)


def test_the_kernel_agrees_with_enumeration_when_every_move_is_allowed():
    problem = tiny_problem(11, steps=6, count=3, closures=(0.0, 0.5, 1.0))
    parameters = SchedulerParameters(deadband=0.03, daily_move_cap=1, min_dwell_s=0.0,
                                     default_closure=0.0)
    latched = np.zeros(6, bool)
    limits = Limits.of(problem, parameters, latched)
    rewards = np.ascontiguousarray(problem.direct_w_m2[..., None] * problem.blocked)
    day = np.floor(problem.start_s / 86400.0)
    new_day = np.concatenate([[False], day[1:] != day[:-1]])
    for all_moves in (True, False):  # the fast path and the general one
        paths, totals = limited_paths(rewards, limits.allowed, all_moves, new_day,
                                      np.full(6, -1, np.int64), np.zeros(3, np.int64), 1, 0)
        for panel in range(3):
            best = max(sum(rewards[t, panel, k] for t, k in enumerate(path))
                       for path in itertools.product(range(3), repeat=6)
                       if keeps_limits(path, problem, parameters, latched, 0))
            assert totals[panel] == pytest.approx(best, rel=1e-12)
            assert sum(rewards[t, panel, k] for t, k in enumerate(paths[:, panel])) \
                == pytest.approx(best, rel=1e-12)


@pytest.mark.parametrize('limited', [False, True])
def test_the_limit_brackets_the_brute_force_optimum_of_the_whole_facade(limited):
    problem = tiny_problem(5, steps=5, count=2)
    latched = np.zeros(5, bool)
    parameters = BINDING if limited else None
    limits = Limits.of(problem, BINDING, latched) if limited else None
    first, second = (panel_points(problem, parameters, latched, p) for p in (0, 1))
    # every schedule of the facade: one path per panel
    blocked = np.add.outer([p[0] for p in first], [p[0] for p in second]).ravel() / 1000
    view = np.add.outer([p[1] for p in first], [p[1] for p in second]).ravel()
    for share in (0.2, 0.5, 0.8, 0.95):
        target = blocked.min() + share * (blocked.max() - blocked.min())
        truth = view[blocked >= target - 1e-12].max()
        limit = limit_at(problem, target, limits, tolerance_h=0.0)
        assert limit.view_weighted_lower_h <= truth + 1e-9 <= limit.view_weighted_upper_h + 2e-9
        assert limit.schedule.blocked_direct_kwh_m2 >= target - 1e-12
        # the bound is the upper concave envelope of the brute-force points
        envelope = _upper_envelope(blocked, view, target)
        assert limit.view_weighted_upper_h == pytest.approx(envelope, abs=1e-6)
        if limited:
            for panel in range(2):
                assert keeps_limits(limit.schedule.levels[:, panel], problem, BINDING,
                                    latched, problem.closures.size - 1)


@pytest.mark.parametrize('limited', [False, True])
def test_the_frontier_lies_on_or_above_every_schedule(limited):
    problem = tiny_problem(8, steps=5, count=2)
    latched = np.zeros(5, bool)
    parameters = BINDING if limited else None
    limits = Limits.of(problem, BINDING, latched) if limited else None
    points = frontier(problem, limits, tolerance_h=0.0, tolerance_kwh_m2=0.0)
    first, second = (panel_points(problem, parameters, latched, p) for p in (0, 1))
    blocked = np.add.outer([p[0] for p in first], [p[0] for p in second]).ravel() / 1000
    view = np.add.outer([p[1] for p in first], [p[1] for p in second]).ravel()
    on_frontier = view_on_frontier(points, blocked)
    assert np.all(view <= on_frontier + 1e-9)
    # and it touches the extremes: most blocking and most view
    assert points[0].blocked_direct_kwh_m2 == pytest.approx(blocked.max())
    assert points[-1].view_weighted_h == pytest.approx(view.max())


def test_a_blocking_beyond_reach_is_refused_with_the_most_there_is():
    problem = tiny_problem(2)
    most = best_schedule(problem, 0.0).blocked_direct_kwh_m2
    assert limit_at(problem, most).view_weighted_lower_h >= 0.0  # at the bound: fine
    with pytest.raises(ValueError, match='most is'):
        limit_at(problem, most * 1.001)


def _upper_envelope(x, y, at):
    """Evaluate the upper concave envelope of points (x, y) at x = ``at`` (monotone part)."""
    order = np.lexsort((-y, x))
    hull = []
    for point in zip(x[order], y[order]):
        while len(hull) >= 2 and _cross(hull[-2], hull[-1], point) >= 0:
            hull.pop()
        hull.append(point)
    hx, hy = np.array(hull).T
    # only the part where more blocking costs view counts: to the right of the most view
    best = int(np.argmax(hy))
    if at <= hx[best]:
        return hy[best]
    return float(np.interp(at, hx[best:], hy[best:]))


def _cross(o, a, b):
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
