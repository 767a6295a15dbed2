"""Best closure paths of panels by dynamic programming: the limit's and the predictive plan's.

Both kernels choose, for each panel separately, one candidate closure level per time step
so that the sum of the step rewards is largest (Bertsekas [1]_, ch. 1). The rewards
``(T, N, K)`` come from an objective (:mod:`.objective`); the panels are independent once
the trade-off between blocking and view is priced by a multiplier (:mod:`.frontier`).

:func:`limited_paths` is the clairvoyant limit under the scheduler's per-panel limits. The
state of a panel after step ``t`` is ``(level, moves today, steps since its last move)``:

- a move is a change of level; it is allowed when ``allowed[k, k']`` (deadband and rate
  limit), fewer than ``cap`` moves were made since the last UTC day change (``new_day``)
  and at least ``dwell`` steps have passed since the last move started;
- a step with ``forced[t] >= 0`` (the storm latch) puts every panel on that level whatever
  the limits; such a move counts toward the day's moves, as the scheduler counts storm
  moves, but is never stopped by the cap;
- ties prefer staying, then the lower state index: the limit moves no more than it must.

Cost ``O(T K M D)`` per panel with ``M = cap + 1`` and ``D = dwell + 1`` states of the move
counter and the dwell clock when every move is allowed (the best move into a level comes
from the best or the second-best level), ``O(T K^2 M D)`` otherwise.

:func:`first_levels` is the predictive controller's receding-horizon plan: state = level
only, a move costs ``move_cost`` plus ``air_price`` per unit of closure gained, and only the
first step of the best plan is returned (the plan is made again at the next decision).

References
----------
.. [1] Bertsekas, D. P., "Dynamic Programming and Optimal Control", vol. 1, 4th ed., Athena
   Scientific, 2017.
"""

import numpy as np
import numpy.typing as npt

from flectofold_model._compiled import kernel
from flectofold_model._validate import BoolArray, FloatArray, IntArray


@kernel
def limited_paths(rewards: FloatArray, allowed: BoolArray, all_moves: bool, new_day: BoolArray,
                  forced: IntArray, start: IntArray, cap: int,
                  dwell: int) -> tuple[npt.NDArray[np.int8], FloatArray]:
    """Best level path (T, N) and its total reward (N,) of every panel; see the module doc.

    ``rewards`` (T, N, K) float; ``allowed`` (K, K) bool, moves other than storm ones;
    ``all_moves``: every off-diagonal entry of ``allowed`` is true; ``new_day`` (T,) bool, the
    move counter restarts before step t; ``forced`` (T,) int, the level of step t or -1;
    ``start`` (N,) int, each panel's level before step 0; ``cap`` >= 1 and ``dwell`` >= 0
    int: moves a day, steps between move starts (0 and 1 both mean no wait).
    """
    steps, count, levels = rewards.shape
    caps = cap + 1
    clocks = dwell + 1
    states = levels * caps * clocks
    negative = -np.inf
    paths = np.empty((steps, count), np.int8)
    totals = np.empty(count)
    back = np.empty((steps, states), np.int32)
    value = np.empty(states)
    carried = np.empty(states)
    source = np.empty(states, np.int32)
    new = np.empty(states)
    for p in range(count):
        value[:] = negative
        value[(start[p] * caps) * clocks + dwell] = 0.0
        for t in range(steps):
            # the move counter restarts: every count collapses onto 0
            if new_day[t]:
                carried[:] = negative
                for k in range(levels):
                    for d in range(clocks):
                        to = (k * caps) * clocks + d
                        for m in range(caps):
                            s = (k * caps + m) * clocks + d
                            if value[s] > carried[to]:
                                carried[to] = value[s]
                                source[to] = s
            else:
                for s in range(states):
                    carried[s] = value[s]
                    source[s] = s
            new[:] = negative
            f = forced[t]
            # staying (first, so that a move must be strictly better)
            for k in range(levels):
                if f >= 0 and k != f:
                    continue
                for m in range(caps):
                    for d in range(clocks):
                        s = (k * caps + m) * clocks + d
                        if carried[s] == negative:
                            continue
                        to = (k * caps + m) * clocks + min(d + 1, dwell)
                        if carried[s] > new[to]:
                            new[to] = carried[s]
                            back[t, to] = source[s]
            if f >= 0:
                # the storm: every other level moves to f, whatever the limits
                for k in range(levels):
                    if k == f:
                        continue
                    for m in range(caps):
                        for d in range(clocks):
                            s = (k * caps + m) * clocks + d
                            if carried[s] == negative:
                                continue
                            to = (f * caps + min(m + 1, cap)) * clocks
                            if carried[s] > new[to]:
                                new[to] = carried[s]
                                back[t, to] = source[s]
            else:
                for m in range(cap):
                    for d in range(clocks):
                        if min(d + 1, dwell) < dwell:
                            continue
                        if all_moves:
                            best, second = -1, -1
                            for k in range(levels):
                                s = (k * caps + m) * clocks + d
                                if carried[s] == negative:
                                    continue
                                if best < 0 or \
                                        carried[s] > carried[(best * caps + m) * clocks + d]:
                                    second = best
                                    best = k
                                elif second < 0 or \
                                        carried[s] > carried[(second * caps + m) * clocks + d]:
                                    second = k
                            for to_level in range(levels):
                                k = best if best != to_level else second
                                if k < 0:
                                    continue
                                s = (k * caps + m) * clocks + d
                                to = (to_level * caps + m + 1) * clocks
                                if carried[s] > new[to]:
                                    new[to] = carried[s]
                                    back[t, to] = source[s]
                        else:
                            for k in range(levels):
                                s = (k * caps + m) * clocks + d
                                if carried[s] == negative:
                                    continue
                                for to_level in range(levels):
                                    if to_level == k or not allowed[k, to_level]:
                                        continue
                                    to = (to_level * caps + m + 1) * clocks
                                    if carried[s] > new[to]:
                                        new[to] = carried[s]
                                        back[t, to] = source[s]
            for s in range(states):
                if new[s] != negative:
                    new[s] += rewards[t, p, s // (caps * clocks)]
                value[s] = new[s]
        best = 0
        for s in range(states):
            if value[s] > value[best]:
                best = s
        totals[p] = value[best]
        s = best
        for t in range(steps - 1, -1, -1):
            paths[t, p] = s // (caps * clocks)
            s = back[t, s]
    return paths, totals


@kernel
def first_levels(rewards: FloatArray, closures: FloatArray, start: FloatArray,
                 move_cost: FloatArray, air_price: FloatArray,
                 deadband: float) -> npt.NDArray[np.int64]:
    """First level (N,) of each panel's best plan over the horizon; see the module doc.

    ``rewards`` (H, N, K); ``closures`` (K,) the levels' closures; ``start`` (N,) each
    panel's closure now (not necessarily a level); ``move_cost`` (N,) the cost of a move and
    ``air_price`` (N,) the cost per unit of closure gained, in the rewards' unit. A level
    within ``deadband`` of the start is reached without a move (the scheduler would hold).
    Ties keep the level nearest the start.
    """
    horizon, count, levels = rewards.shape
    first = np.empty(count, np.int64)
    future = np.empty(levels)
    step = np.empty(levels)
    for p in range(count):
        future[:] = 0.0
        for h in range(horizon - 1, 0, -1):
            for k in range(levels):
                best = rewards[h, p, k] + future[k]
                for to in range(levels):
                    if to == k:
                        continue
                    gain = closures[to] - closures[k]
                    cost = move_cost[p] + (air_price[p] * gain if gain > 0.0 else 0.0)
                    value = rewards[h, p, to] - cost + future[to]
                    if value > best:
                        best = value
                # the best value from level k before step h
                step[k] = best
            for k in range(levels):
                future[k] = step[k]
        chosen = -1
        chosen_value = -np.inf
        chosen_distance = np.inf
        for to in range(levels):
            gain = closures[to] - start[p]
            distance = abs(gain)
            cost = 0.0
            if distance >= deadband and distance > 1e-12:
                cost = move_cost[p] + (air_price[p] * gain if gain > 0.0 else 0.0)
            value = rewards[0, p, to] - cost + future[to]
            if value > chosen_value + 1e-12 or (
                    abs(value - chosen_value) <= 1e-12 and distance < chosen_distance):
                chosen, chosen_value, chosen_distance = to, value, distance
        first[p] = chosen
    return first


@kernel
def greedy_paths(rewards: FloatArray, forced: IntArray,
                 start: IntArray) -> npt.NDArray[np.int8]:
    """Return the best level of each step alone (T, N); the storm's where ``forced``.

    Ties keep the level held before: the path of :func:`limited_paths` without move limits.
    """
    steps, count, levels = rewards.shape
    paths = np.empty((steps, count), np.int8)
    for p in range(count):
        held = start[p]
        for t in range(steps):
            if forced[t] >= 0:
                held = forced[t]
            else:
                best = held
                for k in range(levels):
                    if rewards[t, p, k] > rewards[t, p, best]:
                        best = k
                held = best
            paths[t, p] = held
    return paths


@kernel
def within_limits(paths: IntArray, allowed: BoolArray, new_day: BoolArray, forced: IntArray,
                  start: IntArray, cap: int, dwell: int) -> BoolArray:
    """(N,) bool: each panel's path keeps the limits of :func:`limited_paths`."""
    steps, count = paths.shape
    keeps = np.ones(count, np.bool_)
    for p in range(count):
        held = start[p]
        moves = 0
        since = dwell
        for t in range(steps):
            if new_day[t]:
                moves = 0
            level = paths[t, p]
            if forced[t] >= 0 and level != forced[t]:
                keeps[p] = False
                break
            if level != held:
                if forced[t] < 0 and (not allowed[held, level] or moves >= cap
                                      or min(since + 1, dwell) < dwell):
                    keeps[p] = False
                    break
                moves = min(moves + 1, cap)
                since = 0
            else:
                since = min(since + 1, dwell)
            held = level
    return keeps
