"""Validation and watchdog of one panel's closure setpoint.

A :class:`SetpointGuard` accepts only finite closures in [0, 1]; anything else is refused with
a reason and the last valid setpoint holds. When no valid setpoint arrived for ``timeout_s``
(the commander died, the network split) the guard switches to the configured
:class:`SafeBehaviour` until a fresh setpoint arrives.
"""

import enum
from numbers import Real

from flectofold_model._validate import real_scalar


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


class SetpointGuard:
    """Closure setpoints in, the closure to track out.

    Parameters
    ----------
    timeout_s : float
        Time without a valid setpoint after which the safe behaviour starts [s], ``> 0``.
    safe_behaviour : SafeBehaviour
    initial_closure : float
        Closure tracked until the first valid setpoint, in [0, 1] (0: open, as a panel
        starts vented).
    """

    def __init__(self, timeout_s, safe_behaviour=SafeBehaviour.VENT, initial_closure=0.0):
        self.timeout_s = timeout_s
        self.safe_behaviour = safe_behaviour
        self._initial = _closure_or_raise('initial_closure', initial_closure)
        self._last_valid = self._initial
        self._last_valid_s = None
        self._started_s = None
        self.received = False
        self.rejected = 0
        self.last_rejection = ''

    @property
    def timeout_s(self):
        """Watchdog time [s]."""
        return self._timeout_s

    @timeout_s.setter
    def timeout_s(self, value):
        value = real_scalar('timeout_s', value)
        if value <= 0.0:
            raise ValueError(f'timeout_s must be positive, got {value:g} s')
        self._timeout_s = value

    @property
    def safe_behaviour(self):
        """The :class:`SafeBehaviour` after a timeout."""
        return self._safe_behaviour

    @safe_behaviour.setter
    def safe_behaviour(self, value):
        self._safe_behaviour = SafeBehaviour(value)

    @property
    def last_valid(self):
        """The last accepted setpoint (or the initial closure) [closure]."""
        return self._last_valid

    def offer(self, value, now_s):
        """Take a setpoint received at ``now_s`` [s]; return ``None``, or why it was refused."""
        reason = _closure_problem(value)
        if reason is not None:
            self.rejected += 1
            self.last_rejection = reason
            return reason
        self._last_valid = float(value)
        self._last_valid_s = real_scalar('now_s', now_s)
        self.received = True
        return None

    def state(self, now_s):
        """Return the :class:`SetpointState` at ``now_s`` [s]."""
        now_s = real_scalar('now_s', now_s)
        if self._started_s is None or now_s < self._started_s:
            self._started_s = now_s  # the first reading, or a clock that went back (a bag loop)
        if self._last_valid_s is not None and now_s < self._last_valid_s:
            self._last_valid_s = now_s
        since = self._started_s if self._last_valid_s is None else self._last_valid_s
        if now_s - since > self._timeout_s:
            return SetpointState.TIMED_OUT
        return SetpointState.TRACKING if self.received else SetpointState.WAITING

    def command(self, now_s):
        """Return the closure to track at ``now_s`` [s] and the :class:`SetpointState`."""
        state = self.state(now_s)
        if state is SetpointState.TIMED_OUT and self._safe_behaviour is SafeBehaviour.VENT:
            return 0.0, state
        return self._last_valid, state


def _closure_problem(value):
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


def _closure_or_raise(name, value):
    problem = _closure_problem(value)
    if problem is not None:
        raise ValueError(f'{name}: {problem}')
    return float(value)
