"""Which of a loop's states to keep or publish, so that they come at a given rate.

A pressure loop produces a state every control period (or one per longer quiet span); a node
publishes them at ``publish_rate_hz``, a loop keeps them for its nodes at the fastest rate any
of them asks for. Both pick states with a :class:`PublishDecimator`; a panel's own topics
take theirs by :class:`Heartbeats`, and :func:`loop_start_s` sets where a simulated loop's
periods fall between a process's ticks.
"""

from typing import cast, Optional

import numpy as np

from flectofold_model._validate import BoolArray, real_scalar


class PublishDecimator:
    """Pick states, given by their times, so that one per ``period_s`` is kept on average.

    A state is due when its time has reached the next due time less ``slack_s``; half a loop
    period suits, so that a state which rounding puts a hair early still counts (times of a
    day are about 1.8e9 s, where float64 resolves only 2.4e-7 s). Due times lie on the grid
    ``first + k period_s``: the average rate is exact also where the period is not a whole
    number of loop periods. A state more than a whole period behind the grid (after a quiet
    span, say) starts a new grid at itself, and a time that goes backwards (a bag looping, a
    restarted clock) starts again as if it were the first.

    Parameters
    ----------
    period_s : float
        Time between kept states [s], ``> 0``.
    slack_s : float
        How early a state may be and still be due [s], in ``[0, period_s)``.
    """

    def __init__(self, period_s: float, slack_s: float) -> None:
        self.period_s = real_scalar('period_s', period_s)
        if self.period_s <= 0.0:
            raise ValueError(f'period_s must be positive, got {self.period_s:g} s')
        self.slack_s = real_scalar('slack_s', slack_s)
        if not 0.0 <= self.slack_s < self.period_s:
            raise ValueError(f'slack_s must lie in [0, period_s = {self.period_s:g}) s, got '
                             f'{self.slack_s:g} s')
        self._next_s: Optional[float] = None
        self._last_s: Optional[float] = None

    def due(self, time_s: float) -> bool:
        """Whether the state at ``time_s`` [s] is kept; states must come in time order."""
        last_s = cast(float, self._last_s)  # None only together with _next_s
        if self._next_s is None or time_s < last_s - self.slack_s:
            self._last_s, self._next_s = time_s, time_s + self.period_s
            return True
        self._last_s = time_s
        if time_s < self._next_s - self.slack_s:
            return False
        self._next_s += self.period_s
        if self._next_s <= time_s:
            self._next_s = time_s + self.period_s
        return True

    @property
    def next_due_s(self) -> Optional[float]:
        """Time the next kept state is due at (less ``slack_s`` it counts) [s]; None at first."""
        return self._next_s

    def restart(self) -> None:
        """Forget the grid: the next state is kept and starts a new one."""
        self._next_s = self._last_s = None


class Heartbeats:
    """Which panels publish their own state topics for a state, each by its own rule.

    While the loop moves a panel (``active``: in any state since the last call), and for the
    first state after, every state; at rest, one state per ``heartbeat_s``; and whenever its
    sensor starts or stops giving a reading. The panels' first heartbeats are spread over one
    heartbeat period, not all at once.

    Parameters
    ----------
    count : int
        Panels.
    heartbeat_s : float
        At rest, the time between two states of a panel [s], ``> 0``.
    slack_s : float
        How early a heartbeat may be and still be due [s] (as :class:`PublishDecimator`).
    """

    def __init__(self, count: int, heartbeat_s: float, slack_s: float) -> None:
        self.heartbeat_s = real_scalar('heartbeat_s', heartbeat_s)
        if self.heartbeat_s <= 0.0:
            raise ValueError(f'heartbeat_s must be positive, got {self.heartbeat_s:g} s')
        self.slack_s = real_scalar('slack_s', slack_s)
        self._published_s = np.full(count, -np.inf)
        self._published_reading = np.zeros(count, dtype=bool)
        self._was_active = np.zeros(count, dtype=bool)

    def due(self, time_s: float, active: BoolArray, reading: BoolArray) -> BoolArray:
        """Return which panels publish the state at ``time_s`` [s] (bool, one per panel).

        ``active``: which panels the loop moved since the last call; ``reading``: which have
        a sensor reading in this state.
        """
        due = active | self._was_active | (reading != self._published_reading) | \
            (time_s - self._published_s >= self.heartbeat_s - self.slack_s)
        first = ~np.isfinite(self._published_s)
        self._was_active = active
        self._published_s[due] = time_s
        self._published_reading[due] = reading[due]
        if np.any(first):
            count = len(first)
            phase = self.heartbeat_s * np.arange(count) / count
            self._published_s[first] = time_s - phase[first]
        return due


def loop_start_s(now_s: float, until_next_tick_s: Optional[float], period_s: float) -> float:
    """Return where a simulated loop's periods start, at a process's first tick ``now_s``.

    Half a period before the instant the tick was *due* (the next is due
    ``until_next_tick_s`` from now, None if unknown: then now), so that every later tick,
    due a whole number of periods after it, falls midway between two period ends: a tick a
    little early or late still finds exactly one new state. A real driver's loop runs one
    period per tick whatever its phase. Why not at the tick itself:
    ``msg_docs/panel_node.md``, "Where a simulated loop starts its periods".

    Parameters
    ----------
    now_s : float
        Time of the first tick [s].
    until_next_tick_s : float or None
        Time from now to the next tick [s]; outside ``[0, period_s]`` it counts as unknown.
    period_s : float
        Loop period [s].
    """
    due_s = now_s
    if until_next_tick_s is not None and 0.0 <= until_next_tick_s <= period_s:
        due_s = now_s + until_next_tick_s - period_s
    return due_s - 0.5 * period_s
