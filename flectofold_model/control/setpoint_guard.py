"""Validation and watchdog of the panels' closure setpoints.

:class:`SetpointGuards` (a process's panels, as arrays) and :class:`SetpointGuard` (one panel)
accept only finite closures in [0, 1]; anything else is refused with a reason and the last
valid setpoint holds. When no valid setpoint arrived for ``timeout_s``
(the commander died, the network split) the guard switches to the configured
:class:`SafeBehaviour` until a fresh setpoint arrives.
"""

import enum
from numbers import Integral, Real
from typing import cast, Optional

import numpy as np

from flectofold_model._validate import BoolArray, FloatArray, IntArray, real_scalar


class SafeBehaviour(enum.Enum):
    """What a panel does when its setpoints stop."""

    VENT = 'vent'
    """Command closure 0: the loop vents the cushion and the stored elastic energy opens the
    panel flat; costs no air. The actuator's fail-safe."""
    HOLD = 'hold'
    """Keep the last valid setpoint (a storm position, say)."""


class SetpointState(enum.Enum):
    """Where the guard's command comes from."""

    WAITING = 'waiting_for_setpoint'
    TRACKING = 'tracking'
    TIMED_OUT = 'setpoint_timeout'


class SetpointGuards:
    """Closure setpoints in, the closures to track out, for ``count`` panels at once.

    Each panel's setpoint is validated, held and watched on its own; the watchdog's time and
    the safe behaviour are the process's, shared by all.

    Parameters
    ----------
    count : int
        Panels, ``>= 1``.
    timeout_s : float
        Time without a valid setpoint after which the safe behaviour starts [s], ``> 0``.
    safe_behaviour : SafeBehaviour
    initial_closure : float
        Closure tracked until the first valid setpoint, in [0, 1] (0: open, as a panel
        starts vented).
    """

    #: The states, in the order of the codes :meth:`states` returns.
    STATES = (SetpointState.WAITING, SetpointState.TRACKING, SetpointState.TIMED_OUT)

    def __init__(self, count: int, timeout_s: float,
                 safe_behaviour: SafeBehaviour = SafeBehaviour.VENT,
                 initial_closure: float = 0.0) -> None:
        if isinstance(count, bool) or not isinstance(count, Integral) or count < 1:
            raise ValueError(f'count must be a whole number >= 1, got {count!r}')
        self.timeout_s = timeout_s
        self.safe_behaviour = safe_behaviour
        self.last_valid: FloatArray = np.full(
            count, _closure_or_raise('initial_closure', initial_closure))
        """The last accepted setpoint of each panel (or the initial closure) [closure]."""
        self._last_valid_s: FloatArray = np.full(count, np.nan)
        self._started_s: Optional[float] = None
        self.received: BoolArray = np.zeros(count, dtype=bool)
        """Whether each panel has had a valid setpoint."""
        self.rejected: IntArray = np.zeros(count, dtype=np.int64)
        """Setpoints refused, per panel."""
        self.last_rejection: list[str] = [''] * count
        """Why each panel's last refused setpoint was refused."""

    @property
    def timeout_s(self) -> float:
        """Watchdog time [s]."""
        return self._timeout_s

    @timeout_s.setter
    def timeout_s(self, value: float) -> None:
        value = real_scalar('timeout_s', value)
        if value <= 0.0:
            raise ValueError(f'timeout_s must be positive, got {value:g} s')
        self._timeout_s = value

    @property
    def safe_behaviour(self) -> SafeBehaviour:
        """The :class:`SafeBehaviour` after a timeout."""
        return self._safe_behaviour

    @safe_behaviour.setter
    def safe_behaviour(self, value: SafeBehaviour) -> None:
        self._safe_behaviour = SafeBehaviour(value)

    def offer(self, index: int, value: object, now_s: float) -> Optional[str]:
        """Take panel ``index``'s setpoint received at ``now_s`` [s].

        Return ``None``, or why it was refused (then the last valid one holds).
        """
        reason = _closure_problem(value)
        if reason is not None:
            self.rejected[index] += 1
            self.last_rejection[index] = reason
            return reason
        now_s = real_scalar('now_s', now_s)
        self.last_valid[index] = float(cast(float, value))  # a real number: checked above
        self._last_valid_s[index] = now_s
        self.received[index] = True
        return None

    def states(self, now_s: float) -> IntArray:
        """Return each panel's state at ``now_s`` [s], as indices into :attr:`STATES`.

        The watchdog runs from the last valid setpoint, or from the first reading of the
        clock; a clock that goes back (a bag that loops) restarts it.
        """
        now_s = real_scalar('now_s', now_s)
        if self._started_s is None or now_s < self._started_s:
            self._started_s = now_s
        np.minimum(self._last_valid_s, now_s, out=self._last_valid_s)  # NaN (none yet) stays
        since_s = np.where(np.isnan(self._last_valid_s), self._started_s, self._last_valid_s)
        return np.where(now_s - since_s > self._timeout_s, _TIMED_OUT,
                        np.where(self.received, _TRACKING, _WAITING))

    def command(self, now_s: float) -> tuple[FloatArray, IntArray]:
        """Return the closures to track at ``now_s`` [s] and the states (:meth:`states`)."""
        states = self.states(now_s)
        if self._safe_behaviour is SafeBehaviour.VENT:
            return np.where(states == _TIMED_OUT, 0.0, self.last_valid), states
        return self.last_valid.copy(), states


_WAITING, _TRACKING, _TIMED_OUT = range(3)


class SetpointGuard:
    """One panel's :class:`SetpointGuards`, with scalars in and out.

    Parameters
    ----------
    timeout_s : float
        Time without a valid setpoint after which the safe behaviour starts [s], ``> 0``.
    safe_behaviour : SafeBehaviour
    initial_closure : float
        Closure tracked until the first valid setpoint, in [0, 1].
    """

    def __init__(self, timeout_s: float, safe_behaviour: SafeBehaviour = SafeBehaviour.VENT,
                 initial_closure: float = 0.0) -> None:
        self.guards = SetpointGuards(1, timeout_s, safe_behaviour, initial_closure)

    @property
    def timeout_s(self) -> float:
        """Watchdog time [s]."""
        return self.guards.timeout_s

    @timeout_s.setter
    def timeout_s(self, value: float) -> None:
        self.guards.timeout_s = value

    @property
    def safe_behaviour(self) -> SafeBehaviour:
        """The :class:`SafeBehaviour` after a timeout."""
        return self.guards.safe_behaviour

    @safe_behaviour.setter
    def safe_behaviour(self, value: SafeBehaviour) -> None:
        self.guards.safe_behaviour = value

    @property
    def last_valid(self) -> float:
        """The last accepted setpoint (or the initial closure) [closure]."""
        return float(self.guards.last_valid[0])

    @property
    def received(self) -> bool:
        """Whether a valid setpoint came."""
        return bool(self.guards.received[0])

    @property
    def rejected(self) -> int:
        """Setpoints refused."""
        return int(self.guards.rejected[0])

    @property
    def last_rejection(self) -> str:
        """Why the last refused setpoint was refused."""
        return self.guards.last_rejection[0]

    def offer(self, value: object, now_s: float) -> Optional[str]:
        """Take a setpoint received at ``now_s`` [s]; return ``None``, or why it was refused."""
        return self.guards.offer(0, value, now_s)

    def state(self, now_s: float) -> SetpointState:
        """Return the :class:`SetpointState` at ``now_s`` [s]."""
        return SetpointGuards.STATES[self.guards.states(now_s)[0]]

    def command(self, now_s: float) -> tuple[float, SetpointState]:
        """Return the closure to track at ``now_s`` [s] and the :class:`SetpointState`."""
        closures, states = self.guards.command(now_s)
        return float(closures[0]), SetpointGuards.STATES[states[0]]


def _closure_problem(value: object) -> Optional[str]:
    if isinstance(value, bool) or not isinstance(value, Real):
        return f'setpoint must be a number, got {type(value).__name__}'
    value = float(value)
    if value != value:
        return 'setpoint is NaN'
    if value in (float('inf'), float('-inf')):
        return f'setpoint is {value}'
    if not 0.0 <= value <= 1.0:
        return f'setpoint {value:g} is outside [0, 1] (0 open, 1 closed)'
    return None


def _closure_or_raise(name: str, value: float) -> float:
    problem = _closure_problem(value)
    if problem is not None:
        raise ValueError(f'{name}: {problem}')
    return float(value)
