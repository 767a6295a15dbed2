"""Which of a loop's states to keep or publish, so that they come at a given rate.

A pressure loop produces a state every control period (or one per longer quiet span); a node
publishes them at ``publish_rate_hz``, a loop keeps them for its nodes at the fastest rate any
of them asks for. Both pick states with a :class:`PublishDecimator`.
"""

from flectofold_model._validate import real_scalar


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

    def __init__(self, period_s, slack_s):
        self.period_s = real_scalar('period_s', period_s)
        if self.period_s <= 0.0:
            raise ValueError(f'period_s must be positive, got {self.period_s:g} s')
        self.slack_s = real_scalar('slack_s', slack_s)
        if not 0.0 <= self.slack_s < self.period_s:
            raise ValueError(f'slack_s must lie in [0, period_s = {self.period_s:g}) s, got '
                             f'{self.slack_s:g} s')
        self._next_s = None
        self._last_s = None

    def due(self, time_s):
        """Whether the state at ``time_s`` [s] is kept; states must come in time order."""
        if self._next_s is None or time_s < self._last_s - self.slack_s:
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
    def next_due_s(self):
        """Time the next kept state is due at (less ``slack_s`` it counts) [s]; None at first."""
        return self._next_s

    def restart(self):
        """Forget the grid: the next state is kept and starts a new one."""
        self._next_s = self._last_s = None
