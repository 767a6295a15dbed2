"""The clairvoyant limit: the best blocking-view trade-off any schedule of a facade can reach.

With the whole weather of a date range known in advance, which schedules of closures give
the most view for a given amount of blocked direct sun? No controller, however clever, can
do better on the same weather and facade model: the answer is the limit every strategy is
measured against (the value of perfect information, Birge and Louveaux [1]_; Oldewurtel et
al. [2]_ use the perfect-forecast optimum the same way).

The problem. ``T`` steps, ``N`` panels, ``K`` candidate closures (:class:`ClosureProblem`).
A schedule holds one candidate per panel and step; it blocks
``B = sum_t sum_p w_p dt E_tp b_tp(c)`` [Wh/m2] and gives ``V = sum_t sum_p w_p dt v(c) [day]``
view-weighted hours (``w_p`` the panel's share of the footprint: the annual report's
figures). Maximise ``V`` subject to ``B >= B*``.

How it is solved (Everett [3]_). Pricing the view at ``lambda`` [W/m2] turns it into
maximising ``B + lambda V`` (:class:`~.objective.SunAndView`), which separates by panel:

(a) **without move limits** the best candidate of each panel and step is chosen alone;
(b) **with the scheduler's limits** each panel's path is a dynamic programme
    (:func:`~.paths.limited_paths`): deadband and rate limit on each move, the dwell between
    move starts, the daily cap on moves (UTC day, as the scheduler counts), the storm latch's
    steps forced to ``storm_position`` (taken from the strategy run, the wind being the
    same for every strategy). The two limits shared by all panels, the air bucket and the
    parallel fills, are relaxed: a relaxation can only raise the optimum, so the limit stays
    an upper bound (:attr:`Limit.air_bound_exceeded_steps` counts the steps where its
    schedule would have asked for more air than a full bucket plus the step's refill).

For every ``lambda`` the maximiser is an exact point of the frontier, and
``(L(lambda) - B*) / lambda`` (``L`` the maximum) bounds the view at blocking ``B*`` from
above for any schedule (weak duality). :func:`limit_at` bisects ``lambda`` on ``B*`` and
returns the bracket: the bound from above, and from below the view of a schedule that is
feasible, made of the two bracketing maximisers panel by panel (the greedy mix, best view per
blocking first). The true limit lies in between; the report prints the upper end and the
width. Between supported points the frontier is traced by straight lines (:func:`frontier`);
they are the same upper bound.

The candidates are the shading table's closures (0, 0.1, ..., 1); between them the report
interpolates blocking and view linearly, so a closure between two candidates is a mix of the
two and never better than the better one: the candidate grid is exact for case (a), and
for case (b) as long as one step's rate limit covers a full stroke (``rate_per_s dt >= 1``;
the default 0.02/s does within 50 s).

References
----------
.. [1] Birge, J. R. and Louveaux, F., "Introduction to Stochastic Programming", 2nd ed.,
   Springer, 2011, sec. 4.2 (the expected value of perfect information).
.. [2] Oldewurtel, F. et al., "Use of model predictive control and weather forecasts for
   energy efficient building climate control", Energy and Buildings 45 (2012) 15-27.
.. [3] Everett, H., "Generalized Lagrange multiplier method for solving problems of optimum
   allocation of resources", Operations Research 11(3) (1963) 399-417.
"""

from dataclasses import dataclass
import math
from typing import Optional, overload, Self, Sequence

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import FloatArray, IntArray
from flectofold_model.scheduling.objective import Stage, SunAndView
from flectofold_model.scheduling.paths import greedy_paths, limited_paths, within_limits
from flectofold_model.scheduling.scheduler import SchedulerParameters, SECONDS_PER_DAY

#: Bracket of the value of view searched [W/m2]: from blocking first to view first.
VIEW_VALUE_RANGE_W_M2 = (1e-3, 1e5)


@dataclass(frozen=True)
class ClosureProblem:
    """A facade over a date range, as the strategies and the limit see it."""

    closures: np.ndarray
    """(K,) candidate closures, increasing, evenly spaced from 0 to 1."""
    direct_w_m2: np.ndarray
    """(T, N) direct irradiance on each panel's plane, 0 where not sunlit [W/m2]."""
    blocked: np.ndarray
    """(T, N, K) blocked fraction at each candidate."""
    view: np.ndarray
    """(K,) view fraction of each candidate."""
    daylight: np.ndarray
    """(T,) bool: the sun above the horizon."""
    step_s: float
    start_s: np.ndarray
    """(T,) start of each step [s, UTC Unix time]: the daily move counter follows the UTC
    day, as the scheduler's."""
    weights: np.ndarray
    """(N,) each panel's share of the footprint, summing to 1."""
    air_nl: np.ndarray
    """(N,) free air of a full close of each panel [NL]."""

    def stage(self) -> Stage:
        """Return the whole range as a :class:`~.objective.Stage`."""
        return Stage(direct_w_m2=self.direct_w_m2, blocked=self.blocked, view=self.view,
                     daylight=self.daylight,
                     step_h=np.full(self.daylight.shape, self.step_s / 3600.0))

    def per_panel(self, levels: IntArray) -> tuple[FloatArray, FloatArray]:
        """Return (N,) blocked direct [Wh/m2] and (N,) view-weighted hours of paths (T, N).

        Each is weighted by the panel's footprint share: they sum to the facade's figures.
        """
        step_h = self.step_s / 3600.0
        blocked = np.take_along_axis(self.blocked, levels[..., None].astype(np.intp),
                                     axis=-1)[..., 0]
        energy = np.sum(self.direct_w_m2 * blocked, axis=0) * step_h
        view = np.sum(self.view[levels] * self.daylight[:, None], axis=0) * step_h
        return energy * self.weights, view * self.weights


@dataclass(frozen=True)
class Limits:
    """The scheduler's per-panel limits on a problem's step grid; ``None``: case (a)."""

    allowed: np.ndarray
    """(K, K) bool: moves the deadband and the rate limit allow within one step."""
    dwell_steps: int
    daily_move_cap: int
    storm_level: int
    """Candidate index nearest ``storm_position``."""
    latched: np.ndarray
    """(T,) bool: the storm latch set over the step."""
    start_level: int
    """Candidate index nearest ``default_closure``, where the scheduler starts."""
    air_room_nl: float
    """A full air bucket plus one step's refill [NL]: what one step can draw at most."""

    @classmethod
    def of(cls, problem: ClosureProblem, parameters: SchedulerParameters,
           latched: npt.ArrayLike) -> Self:
        """Make the limits of ``parameters`` on ``problem``'s grid, storm steps ``latched``."""
        if not isinstance(parameters, SchedulerParameters):
            raise TypeError(f'parameters must be SchedulerParameters, got '
                            f'{type(parameters).__name__}')
        latched = np.asarray(latched, dtype=bool)
        if latched.shape != problem.daylight.shape:
            raise ValueError(f'latched must have shape {problem.daylight.shape}, got '
                             f'{latched.shape}')
        change = np.abs(problem.closures[:, None] - problem.closures[None, :])
        allowed = (change >= parameters.deadband) & (
            change <= parameters.rate_per_s * problem.step_s + 1e-12)
        np.fill_diagonal(allowed, False)
        return cls(allowed=allowed,
                   dwell_steps=int(math.ceil(parameters.min_dwell_s / problem.step_s - 1e-9)),
                   daily_move_cap=parameters.daily_move_cap,
                   storm_level=_nearest(problem.closures, parameters.storm_position),
                   latched=latched,
                   start_level=_nearest(problem.closures, parameters.default_closure),
                   air_room_nl=parameters.capacity_nl
                   + parameters.refill_nl_per_s * problem.step_s)


@dataclass(frozen=True)
class Point:
    """One schedule's figures on the frontier's axes."""

    view_value_w_m2: float
    """The value of view that made it (NaN for a mix)."""
    blocked_direct_kwh_m2: float
    view_weighted_h: float
    levels: np.ndarray
    """(T, N) candidate index held by each panel at each step."""


@dataclass(frozen=True)
class Limit:
    """The limit at one blocking: the view no schedule can beat, bracketed."""

    blocked_direct_kwh_m2: float
    """The blocking asked for [kWh/m2]."""
    view_weighted_upper_h: float
    """No schedule (within the limits) that blocks at least that much gives more view [h]."""
    view_weighted_lower_h: float
    """A schedule within the limits that does, :attr:`schedule`, gives this view [h]."""
    schedule: Point
    """The feasible schedule behind :attr:`view_weighted_lower_h`."""
    evaluations: int
    """Values of view tried (one dynamic programme per panel each)."""
    air_bound_exceeded_steps: int
    """Steps where :attr:`schedule` asks more air than a full bucket plus the step's refill
    (the relaxed shared limit; 0 when the limits are not applied)."""

    @property
    def width_h(self) -> float:
        """Width of the bracket [h]: how exactly the limit is known."""
        return self.view_weighted_upper_h - self.view_weighted_lower_h


def best_schedule(problem: ClosureProblem, view_value_w_m2: float,
                  limits: Optional[Limits] = None) -> Point:
    """Return the schedule that maximises blocked sun plus ``view_value_w_m2`` times view.

    ``limits`` None: case (a), every panel and step alone; a :class:`Limits`: case (b).
    """
    rewards = SunAndView(view_value_w_m2).rewards(problem.stage())
    if limits is None:
        # ties (night, no sun) keep the most view, then the least closure
        levels = np.argmax(rewards[..., ::-1], axis=-1)
        levels = (rewards.shape[-1] - 1 - levels).astype(np.int8)
    else:
        steps, count, size = rewards.shape
        if limits.latched.shape != (steps,):
            raise ValueError('limits were made for another problem')
        day = np.floor(problem.start_s / SECONDS_PER_DAY)
        new_day = np.concatenate([[False], day[1:] != day[:-1]])
        forced = np.where(limits.latched, limits.storm_level, -1).astype(np.int64)
        rewards = np.ascontiguousarray(rewards)
        start = np.full(count, limits.start_level, np.int64)
        dwell = 0 if limits.dwell_steps <= 1 else int(limits.dwell_steps)
        # A panel whose best path without move limits keeps them has its optimum already.
        levels = greedy_paths(rewards, forced, start)
        bound = ~within_limits(levels, limits.allowed, new_day, forced, start,
                               int(limits.daily_move_cap), dwell)
        if bound.any():
            off_diagonal = ~np.eye(size, dtype=bool)
            levels[:, bound], _ = limited_paths(
                np.ascontiguousarray(rewards[:, bound]), limits.allowed,
                bool(np.all(limits.allowed[off_diagonal])), new_day, forced, start[bound],
                int(limits.daily_move_cap), dwell)
    blocked, view = problem.per_panel(levels)
    return Point(view_value_w_m2=float(view_value_w_m2),
                 blocked_direct_kwh_m2=float(blocked.sum()) / 1000.0,
                 view_weighted_h=float(view.sum()), levels=levels)


def frontier(problem: ClosureProblem, limits: Optional[Limits] = None, tolerance_h: float = 0.05,
             tolerance_kwh_m2: float = 0.01, max_evaluations: int = 120) -> list[Point]:
    """Supported points of the frontier, by blocking (decreasing) (list of :class:`Point`).

    The dichotomic method: from the most blocking and the most view schedules, each segment
    between neighbouring points is tested at the value of view that prices both ends alike,
    ``lambda = (B1 - B2) / (V2 - V1)``; a maximiser above the segment by more than
    ``tolerance_h`` of view is a new supported point and both halves are tested again,
    breadth first. Segments that span less than ``tolerance_kwh_m2`` of blocking are not
    split. Straight lines between the points then bound every schedule from above, within
    those tolerances (or less tightly where ``max_evaluations`` ran out first).
    """
    ends = [best_schedule(problem, value, limits) for value in VIEW_VALUE_RANGE_W_M2[::-1]]
    ends[-1] = best_schedule(problem, 0.0, limits)
    points = sorted(ends, key=lambda p: p.blocked_direct_kwh_m2)
    segments = [(points[0], points[1])]
    evaluations = 3
    while segments and evaluations < max_evaluations:
        view_end, blocking_end = segments.pop(0)
        rise = view_end.view_weighted_h - blocking_end.view_weighted_h
        drop = (blocking_end.blocked_direct_kwh_m2 - view_end.blocked_direct_kwh_m2) * 1000.0
        if rise <= 1e-12 or drop <= max(1e-9, tolerance_kwh_m2 * 1000.0):
            continue
        value = drop / rise
        point = best_schedule(problem, value, limits)
        evaluations += 1
        level = blocking_end.blocked_direct_kwh_m2 * 1000.0 \
            + value * blocking_end.view_weighted_h
        found = point.blocked_direct_kwh_m2 * 1000.0 + value * point.view_weighted_h
        if found - level > value * tolerance_h + 1e-12 * abs(level):
            points.append(point)
            segments += [(view_end, point), (point, blocking_end)]
    points.sort(key=lambda p: (-p.blocked_direct_kwh_m2, p.view_weighted_h))
    kept: list[Point] = []
    for point in points:
        if kept and point.view_weighted_h <= kept[-1].view_weighted_h + 1e-12:
            continue
        kept.append(point)
    return kept


def view_on_frontier(points: Sequence[Point], blocked_direct_kwh_m2: npt.ArrayLike) -> FloatArray:
    """Return the view [h] of the frontier through ``points`` at a blocking [kWh/m2].

    Straight lines between the points; NaN beyond the most blocking point.
    """
    blocked = np.array([p.blocked_direct_kwh_m2 for p in points])[::-1]
    view = np.array([p.view_weighted_h for p in points])[::-1]
    target = np.asarray(blocked_direct_kwh_m2, dtype=float)
    return np.where(target > blocked[-1] + 1e-9, np.nan,
                    np.interp(target, blocked, view, left=view[0]))


def limit_at(problem: ClosureProblem, blocked_direct_kwh_m2: float,
             limits: Optional[Limits] = None, tolerance_h: Optional[float] = None,
             max_evaluations: int = 40) -> Limit:
    """Return the limit of view at a blocking [kWh/m2], bracketed (:class:`Limit`).

    Bisects the value of view on a log scale until the bracket is narrower than
    ``tolerance_h`` (default: 1e-4 of the most view the problem has, about 0.4 h over a
    year) or ``max_evaluations`` are spent; see the module doc.
    """
    target_wh = float(blocked_direct_kwh_m2) * 1000.0
    if not math.isfinite(target_wh):
        raise ValueError(f'blocked_direct_kwh_m2 must be finite, got {blocked_direct_kwh_m2}')
    most_view_h = float(np.max(problem.view) * np.sum(problem.daylight) * problem.step_s / 3600)
    tolerance = 1e-4 * most_view_h if tolerance_h is None else float(tolerance_h)
    low, high = (math.log(v) for v in VIEW_VALUE_RANGE_W_M2)
    upper = math.inf
    feasible = infeasible = None
    evaluations = 0
    for value in (VIEW_VALUE_RANGE_W_M2[0], VIEW_VALUE_RANGE_W_M2[1]):
        point = best_schedule(problem, value, limits)
        evaluations += 1
        feasible, infeasible, upper = _bracket(point, target_wh, feasible, infeasible, upper)
    if feasible is None:
        raise ValueError(f'no schedule within the limits blocks {blocked_direct_kwh_m2:.4g} '
                         f'kWh/m2; the most is {point_blocked(problem, limits):.4g} kWh/m2')
    if infeasible is None:  # the most view already blocks enough
        return _limit(problem, target_wh, feasible, feasible, feasible.view_weighted_h,
                      evaluations, limits)
    while evaluations < max_evaluations:
        lower = _mix(problem, feasible, infeasible, target_wh)
        if upper - lower.view_weighted_h <= tolerance:
            break
        middle = 0.5 * (low + high)
        point = best_schedule(problem, math.exp(middle), limits)
        evaluations += 1
        if point.blocked_direct_kwh_m2 * 1000.0 >= target_wh:
            low = middle
        else:
            high = middle
        feasible, infeasible, upper = _bracket(point, target_wh, feasible, infeasible, upper)
    return _limit(problem, target_wh, feasible, infeasible, upper, evaluations, limits)


def point_blocked(problem: ClosureProblem, limits: Optional[Limits]) -> float:
    """Most direct sun any schedule within ``limits`` blocks [kWh/m2]."""
    return best_schedule(problem, 0.0, limits).blocked_direct_kwh_m2


@overload
def _bracket(point: Point, target_wh: float, feasible: Point, infeasible: Point,
             upper: float) -> tuple[Point, Point, float]: ...


@overload
def _bracket(point: Point, target_wh: float, feasible: Optional[Point],
             infeasible: Optional[Point],
             upper: float) -> tuple[Optional[Point], Optional[Point], float]: ...


def _bracket(point: Point, target_wh: float, feasible: Optional[Point],
             infeasible: Optional[Point],
             upper: float) -> tuple[Optional[Point], Optional[Point], float]:
    value = point.view_value_w_m2
    blocked_wh = point.blocked_direct_kwh_m2 * 1000.0
    lagrangian = blocked_wh + value * point.view_weighted_h
    upper = min(upper, (lagrangian - target_wh) / value)
    if blocked_wh >= target_wh:
        if feasible is None or point.view_weighted_h > feasible.view_weighted_h:
            feasible = point
    elif infeasible is None or point.blocked_direct_kwh_m2 > infeasible.blocked_direct_kwh_m2:
        infeasible = point
    return feasible, infeasible, upper


def _mix(problem: ClosureProblem, feasible: Point, infeasible: Point, target_wh: float) -> Point:
    """Make a feasible schedule: ``feasible``'s, panels taken from ``infeasible`` greedily."""
    blocked_f, view_f = problem.per_panel(feasible.levels)
    blocked_i, view_i = problem.per_panel(infeasible.levels)
    gain_view, lose_blocked = view_i - view_f, blocked_f - blocked_i
    ratio = np.where(lose_blocked > 0, gain_view / np.maximum(lose_blocked, 1e-300), np.inf)
    order = np.argsort(-ratio, kind='stable')
    spare = blocked_f.sum() - target_wh
    take = np.zeros(len(order), bool)
    for panel in order:
        if gain_view[panel] <= 0:
            continue
        if lose_blocked[panel] <= spare + 1e-9:
            take[panel] = True
            spare -= lose_blocked[panel]
    levels = np.where(take[None, :], infeasible.levels, feasible.levels)
    blocked, view = problem.per_panel(levels)
    return Point(view_value_w_m2=math.nan, blocked_direct_kwh_m2=float(blocked.sum()) / 1000.0,
                 view_weighted_h=float(view.sum()), levels=levels)


def _limit(problem: ClosureProblem, target_wh: float, feasible: Point, infeasible: Point,
           upper: float, evaluations: int, limits: Optional[Limits]) -> Limit:
    schedule = _mix(problem, feasible, infeasible, target_wh)
    return Limit(blocked_direct_kwh_m2=target_wh / 1000.0,
                 view_weighted_upper_h=max(float(upper), schedule.view_weighted_h),
                 view_weighted_lower_h=schedule.view_weighted_h, schedule=schedule,
                 evaluations=evaluations,
                 air_bound_exceeded_steps=0 if limits is None else _air_exceeded(
                     problem, schedule, limits))


def _air_exceeded(problem: ClosureProblem, schedule: Point, limits: Limits) -> int:
    closure = problem.closures[schedule.levels]
    start = np.full((1, closure.shape[1]), problem.closures[limits.start_level])
    gained = np.maximum(np.diff(np.vstack([start, closure]), axis=0), 0.0) @ problem.air_nl
    return int(np.sum(gained > limits.air_room_nl + 1e-9))


def _nearest(closures: npt.ArrayLike, value: float) -> int:
    return int(np.argmin(np.abs(np.asarray(closures) - value)))
