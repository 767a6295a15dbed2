"""A simulated day: wall (steady) seconds elapsed mapped to simulated POSIX time.

The clock runs ``speedup`` times faster than the wall clock from ``start_epoch_s`` and stops
at ``end_epoch_s``. It is a pure function of the elapsed wall time, so a caller that measures
the elapsed time from one fixed steady-clock origin accumulates no drift, however irregular
its ticks are. Times are POSIX seconds (UTC) [s]; :func:`~.sun.epoch_from_iso`
turns ISO 8601 timestamps with a UTC offset into them.
"""

from dataclasses import dataclass

import numpy as np

from flectofold_model._validate import in_range, real_fields, real_scalar

#: The fastest a simulated clock may run: a day in under a second [-].
MAX_SPEEDUP = 1e5


@dataclass(frozen=True)
class SimulatedClock:
    """Simulated time that runs ``speedup`` times the wall clock from start to end.

    Every field is checked on construction; the error names the field.
    """

    start_epoch_s: float
    """Simulated time at wall time 0, POSIX seconds (UTC) [s]."""
    end_epoch_s: float
    """Simulated time at which the clock stops, POSIX seconds (UTC) [s], after the start."""
    speedup: float
    """Simulated seconds per wall second [-], in ``(0, 1e5]``."""

    def __post_init__(self) -> None:
        real_fields(self)
        if not self.end_epoch_s > self.start_epoch_s:
            raise ValueError(
                f'end_epoch_s must be after start_epoch_s, got end {self.end_epoch_s:.3f} s '
                f'<= start {self.start_epoch_s:.3f} s')
        in_range('speedup', np.asarray(self.speedup), 0.0, MAX_SPEEDUP, low_open=True)

    @property
    def wall_duration_s(self) -> float:
        """Wall time the simulated span takes, ``(end - start) / speedup`` [s]."""
        return (self.end_epoch_s - self.start_epoch_s) / self.speedup

    def sim_epoch_s(self, wall_elapsed_s: float) -> float:
        """Return the simulated time after ``wall_elapsed_s`` of wall time [s].

        Parameters
        ----------
        wall_elapsed_s : float
            Wall (steady) time since the clock started [s], ``>= 0``.

        Returns
        -------
        float
            ``min(start + speedup * wall_elapsed_s, end)``, POSIX seconds (UTC) [s]: exactly
            ``end_epoch_s`` once the span is over.

        Raises
        ------
        TypeError
            If ``wall_elapsed_s`` is not a real number.
        ValueError
            If ``wall_elapsed_s`` is negative, NaN or infinite.
        """
        elapsed = _elapsed(wall_elapsed_s)
        return min(self.start_epoch_s + self.speedup * elapsed, self.end_epoch_s)

    def finished(self, wall_elapsed_s: float) -> bool:
        """Return ``True`` once the simulated time has reached ``end_epoch_s``.

        Takes the same ``wall_elapsed_s`` [s] as :meth:`sim_epoch_s`.
        """
        return self.sim_epoch_s(wall_elapsed_s) >= self.end_epoch_s


def _elapsed(wall_elapsed_s: float) -> float:
    elapsed = real_scalar('wall_elapsed_s', wall_elapsed_s)
    if elapsed < 0.0:
        raise ValueError(f'wall_elapsed_s must be >= 0 s, got {elapsed:g} s')
    return elapsed
