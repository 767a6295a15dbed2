"""The storm latch: timestamped gust samples in, latched or not out, with hysteresis.

A :class:`StormLatch` decides from sparse wind samples when a facade goes to its storm
position and when it may come back. The rule (speeds in m/s, times in s):

* **Sample and hold.** A sample stands for the wind from its arrival until the next sample,
  or until it is older than ``stale_s`` (the weather timeout), whichever comes first. A gust
  sampled once therefore counts for as long as nothing newer says otherwise, but never longer
  than ``stale_s``; wind that is no longer known is neither above nor below any threshold.
* **Trip.** The wind must count as above ``wind_on_m_s`` (strictly) without a break for
  ``storm_on_delay_s``. The trip timer starts at the *arrival* of the first sample above; a
  sample at or below ``wind_on_m_s``, or the held sample going stale, stops it. The latch
  trips at the timer's start plus ``storm_on_delay_s`` exactly, whether or not a sample
  arrives then: a caller evaluates :meth:`StormLatch.advance` at :attr:`StormLatch.due_s`
  (or on a short timer while one is due) and at each sample.
* **Release.** Likewise below ``wind_off_m_s`` (strictly) for ``storm_off_delay_s``. A
  sample between the two thresholds while latched keeps the latch and restarts the release
  timer (hysteresis: only a calm that lasts the whole hold releases); stale wind never
  releases.
* A sample that arrives at the very instant a timer ends is taken first: the held sample
  covers the time from its own arrival up to, not including, the next one's.

With the defaults (10 m/s for 5 s, 7 m/s for 900 s) and a 1 Hz anemometer the latch trips
5 s after the first sample above 10 m/s if every later one stays above, and releases 900 s
after the first sample of a calm below 7 m/s that no sample at or above 7 m/s interrupts.

:class:`StormEvents` is what a coordinator keeps of a scheduler's latch between its
decisions (:class:`~.facade_schedule.FacadeSchedule` owns one): which trip or release it has
reported, which state its last decision saw, and when the latch must be evaluated next.
"""

import math
from typing import cast, NamedTuple, Optional, Protocol

import numpy as np

from flectofold_model._validate import in_range, real_scalar


class StormSettings(Protocol):
    """The latch's settings (:class:`~.scheduler.SchedulerParameters` has them).

    Protocols, here and in :class:`StormSource`: the scheduler's module imports this one.
    """

    wind_on_m_s: float
    wind_off_m_s: float
    storm_on_delay_s: float
    storm_off_delay_s: float


class StormSource(Protocol):
    """The storm interface of a :class:`~.scheduler.Scheduler`, all :class:`StormEvents` uses."""

    @property
    def storm_latched(self) -> bool:
        """Whether the latch is set."""

    @property
    def storm_time_s(self) -> float:
        """Latest instant the latch was evaluated at [s]."""

    @property
    def storm_due_s(self) -> Optional[float]:
        """Instant of the pending trip or release [s]; or None."""

    @property
    def storm_changed_s(self) -> Optional[float]:
        """Instant of the last trip or release [s]; or None."""

    def wind_m_s(self, now_s: float) -> Optional[float]:
        """Return the sample that counts at ``now_s`` [m/s]; or None."""

    def observe_wind(self, wind_m_s: float, at_s: float) -> bool:
        """Take a sample [m/s] that arrived at ``at_s`` [s]; return the latch."""

    def advance_storm(self, now_s: float) -> bool:
        """Evaluate the latch at ``now_s`` [s]; return it."""


class StormLatch:
    """The storm latch of a facade, evaluated at sample arrivals and at chosen instants.

    Parameters
    ----------
    parameters : SchedulerParameters
        Its ``wind_on_m_s``, ``wind_off_m_s``, ``storm_on_delay_s`` and ``storm_off_delay_s``.
    stale_s : float
        A sample older than this no longer counts [s], ``> 0``.
    latched : bool
        State to start with.
    start_s : float
        Clock at construction [s]; no sample or evaluation may be earlier.
    """

    def __init__(self, parameters: StormSettings, stale_s: float = 60.0,
                 latched: bool = False, start_s: float = 0.0) -> None:
        self.parameters = parameters
        self.stale_s = real_scalar('stale_s', stale_s)
        if not self.stale_s > 0.0:
            raise ValueError(f'stale_s must be positive, got {self.stale_s:g} s')
        self._latched = bool(latched)
        self._now_s = real_scalar('start_s', start_s)
        self._wind_m_s: Optional[float] = None
        self._sample_s = -math.inf
        self._run_start_s: Optional[float] = None
        self.changed_s: Optional[float] = None
        """Instant of the last trip or release [s]; None before the first."""

    @property
    def latched(self) -> bool:
        """Whether the latch is set."""
        return self._latched

    @property
    def now_s(self) -> float:
        """Latest instant the latch was evaluated at [s]."""
        return self._now_s

    @property
    def run_start_s(self) -> Optional[float]:
        """Start of the pending trip (or release, while latched) timer [s]; None if none."""
        return self._run_start_s

    @property
    def due_s(self) -> Optional[float]:
        """Instant the latch trips (or releases) if the held sample stays the last [s].

        None while no timer runs, or when the held sample goes stale before the hold ends.
        """
        if self._run_start_s is None:
            return None
        due = self._run_start_s + self._delay_s()
        return due if due <= self._sample_s + self.stale_s else None

    def wind_m_s(self, now_s: float) -> Optional[float]:
        """Return the held sample at ``now_s`` [m/s]; None if there is none or it is stale."""
        if self._wind_m_s is None or now_s - self._sample_s > self.stale_s:
            return None
        return self._wind_m_s

    def advance(self, now_s: float) -> bool:
        """Evaluate the latch at ``now_s`` [s] on the held sample; return whether it changed."""
        return self._advance(self._check_time('now_s', now_s), up_to=False)

    def _advance(self, now: float, up_to: bool) -> bool:
        """Evaluate at ``now``; ``up_to``: a new sample arrives then, the held one ends there."""
        self._now_s = now
        if self._run_start_s is None:
            return False
        due = self._run_start_s + self._delay_s()
        held_until_s = self._sample_s + self.stale_s
        if due <= held_until_s and (due < now if up_to else due <= now):
            self._latched = not self._latched
            self._run_start_s = None
            self.changed_s = due
            return True
        if now > held_until_s:  # the sample went stale first: the wind is no longer known
            self._run_start_s = None
        return False

    def sample(self, wind_m_s: float, at_s: float) -> bool:
        """Take a gust sample [m/s] that arrived at ``at_s`` [s]; return whether it changed."""
        wind = real_scalar('wind_m_s', wind_m_s)
        in_range('wind_m_s', np.asarray(wind), 0.0, math.inf, ' m/s', high_open=True)
        at = self._check_time('at_s', at_s)
        before = self._latched
        self._advance(at, up_to=True)
        if self._counts(wind):
            if self._run_start_s is None:
                self._run_start_s = self._now_s
        else:
            self._run_start_s = None
        self._wind_m_s, self._sample_s = wind, self._now_s
        self._advance(at, up_to=False)
        return self._latched != before

    def _counts(self, wind: float) -> bool:
        """Whether ``wind`` runs the timer of the current state."""
        if self._latched:
            return wind < self.parameters.wind_off_m_s
        return wind > self.parameters.wind_on_m_s

    def _delay_s(self) -> float:
        parameters = self.parameters
        return parameters.storm_off_delay_s if self._latched else parameters.storm_on_delay_s

    def _check_time(self, name: str, value: float) -> float:
        time_s = real_scalar(name, value)
        if time_s < self._now_s:
            raise ValueError(f'{name} must not go backwards: got {time_s:.3f} s after '
                             f'{self._now_s:.3f} s')
        return time_s


class StormChange(NamedTuple):
    """A trip or a release of the storm latch."""

    latched: bool
    """True for a trip, False for a release."""
    at_s: float
    """Instant of the change [s]: the end of its hold, not the evaluation that found it."""

    def describe(self) -> str:
        """Return the change as one line of a log, its instant to the millisecond."""
        return (f'storm latch {"tripped" if self.latched else "released"} at {self.at_s:.3f} '
                f's: panels {"to the storm position" if self.latched else "back to automatic"}')


class StormStatus(NamedTuple):
    """The storm latch as a diagnostics report shows it at one instant."""

    latched: bool
    """Whether the latch is set."""
    wind_m_s: Optional[float]
    """The sample that counts [m/s]; None when there is none, it is stale, or the instant is
    before the latch's last evaluation."""
    due_in_s: Optional[float]
    """Time from the instant to the pending trip or release [s]; None while none is due."""


class StormUpdate(NamedTuple):
    """What one evaluation of the storm latch asks of a coordinator."""

    change: Optional[StormChange]
    """A trip or release not reported before, to report now; else None."""
    decide: bool
    """The latch differs from before the evaluation: decide at once."""


class StormEvents:
    """A coordinator's account of a scheduler's storm latch: reports, decisions, evaluations.

    The rule (times in s, wind in m/s):

    * **Report once.** A trip or release is reported by whichever comes to it first: an
      evaluation of the latch (a sample, a timer) or a decision's step. A state that is
      reported is not reported again; the first report compares with the latch the
      scheduler started with.
    * **Decide at once.** An evaluation that changes the latch asks for a decision then,
      not at the next decision period.
    * **Decide without the sun.** While the latch is set, or while it differs from what the
      last decision saw, a decision is due even without a sun vector (the automatic panels
      hold, the storm moves the rest).
    * **Never backwards.** A sample or an evaluation before the latch's latest evaluation
      (:attr:`~.scheduler.Scheduler.storm_time_s`) is not taken.
    * **Evaluate while due.** Between samples the latch needs evaluating only while a trip
      or release is due (:attr:`due_s` not None).

    Parameters
    ----------
    scheduler : Scheduler
        The :class:`~.scheduler.Scheduler` whose latch this follows; only its storm
        interface is used (``storm_latched``, ``storm_time_s``, ``storm_due_s``,
        ``storm_changed_s``, ``wind_m_s``, ``observe_wind``, ``advance_storm``).
    """

    def __init__(self, scheduler: StormSource) -> None:
        self.scheduler = scheduler
        self._reported = scheduler.storm_latched
        self._decided = scheduler.storm_latched

    @property
    def latched(self) -> bool:
        """Whether the latch is set."""
        return self.scheduler.storm_latched

    @property
    def due_s(self) -> Optional[float]:
        """Instant of the pending trip or release [s]; None while the latch needs no timer."""
        return self.scheduler.storm_due_s

    @property
    def decision_due(self) -> bool:
        """Whether the storm needs a decision even without a fresh sun."""
        latched = self.scheduler.storm_latched
        return latched or latched != self._decided

    def behind(self, at_s: float) -> bool:
        """Whether ``at_s`` [s] is before the latch's latest evaluation (so not taken)."""
        return at_s < self.scheduler.storm_time_s

    def observe_wind(self, wind_m_s: float, at_s: float) -> Optional[StormUpdate]:
        """Take a gust sample [m/s, >= 0] that arrived at ``at_s`` [s].

        Returns
        -------
        StormUpdate or None
            None, and the sample not taken, when ``at_s`` is :meth:`behind`.
        """
        if self.behind(at_s):
            return None
        was = self.scheduler.storm_latched
        self.scheduler.observe_wind(wind_m_s, at_s)
        return self._update(was)

    def advance(self, now_s: float) -> Optional[StormUpdate]:
        """Evaluate the latch at ``now_s`` [s] on the held sample.

        Returns
        -------
        StormUpdate or None
            None, and nothing evaluated, when ``now_s`` is :meth:`behind`.
        """
        if self.behind(now_s):
            return None
        was = self.scheduler.storm_latched
        self.scheduler.advance_storm(now_s)
        return self._update(was)

    def stepped(self) -> None:
        """Note that a decision's step has run on the latch as it is now."""
        self._decided = self.scheduler.storm_latched

    def report(self) -> Optional[StormChange]:
        """Return the latch's change not yet reported, a :class:`StormChange`; or None.

        A decision's step evaluates the latch too: when it reaches a trip or release instant
        before a sample or a timer does, the change is reported after the step.
        """
        latched = self.scheduler.storm_latched
        if latched == self._reported:
            return None
        self._reported = latched
        # set by the trip or release being reported
        return StormChange(latched, cast(float, self.scheduler.storm_changed_s))

    def status(self, now_s: float) -> StormStatus:
        """Return the :class:`StormStatus` at ``now_s`` [s]."""
        scheduler = self.scheduler
        wind = None if self.behind(now_s) else scheduler.wind_m_s(now_s)
        due = scheduler.storm_due_s
        return StormStatus(scheduler.storm_latched, wind, None if due is None else due - now_s)

    def _update(self, was: bool) -> StormUpdate:
        return StormUpdate(self.report(), self.scheduler.storm_latched != was)
