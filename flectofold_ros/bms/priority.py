"""BACnet's 16-slot priority array mapped onto the coordinator's precedence; a write's bounds.

The coordinator's precedence is fault > storm > manual override > automatic
(:mod:`flectofold_model.scheduling.scheduler`). A commandable closure object keeps BACnet's
priority array (ASHRAE 135 clause 19.2: the present value is the highest-priority non-NULL
slot, the relinquish default when every slot is NULL; a write without a priority writes at 16)
and the gateway hands the outcome on:

* priorities 1-8 (:data:`OVERRIDE_PRIORITIES`) are the coordinator's manual override; within
  them the array arbitrates (a value at 2 outranks one at 8), and what wins is sent as the
  override. None of them outranks the storm latch: while it is set a value at any of them is
  refused (:data:`STORM_REFUSAL`), as the coordinator refuses an override, and not kept;
* priorities 9-16 (automatic in BACnet and in VDI 3813 / Desigo orders) are refused: the
  facade's automatic layer is its own schedule, which a value from the BMS could only replace
  (a manual override in disguise, and the destination of every write that names no priority)
  or sit below (never in force);
* NULL (relinquish) is accepted at every priority, also in a storm; no value left at 1-8
  sends the panel back to automatic (``override_clear``).

Sources of the priority meanings and orders: ``msg_docs/bacnet_gateway.md``. Every refusal
is a :class:`Refused` carrying the BACnet error class and code and the reason in words.
"""

import math

#: BACnet priorities [1, 16]; 1 is the highest.
LOWEST_PRIORITY = 16
#: ASHRAE 135: Manual Operator.
MANUAL_OPERATOR_PRIORITY = 8
#: Priorities whose values become the coordinator's manual override.
OVERRIDE_PRIORITIES = range(1, MANUAL_OPERATOR_PRIORITY + 1)
#: The closure command's range [%]: 0 open, 100 closed.
CLOSURE_RANGE_PERCENT = (0.0, 100.0)
STORM_REFUSAL = ('storm latch set: the panels hold the storm position, a command is refused '
                 'and not kept for after the storm')


class Refused(Exception):
    """A request the gateway answers with a BACnet error: class, code (bacpypes3 words), reason."""

    def __init__(self, error_class, error_code, reason):
        super().__init__(f'{error_code}: {reason}')
        self.error_class = error_class
        self.error_code = error_code
        self.reason = reason


def check_priority(priority):
    """Return the priority a write of a closure command is at; :class:`Refused` if out of range.

    ``None`` (no priority in the request) is 16 (ASHRAE 135 clause 19.2). Outside 1..16:
    ``services`` / ``parameter-out-of-range``.
    """
    if priority is None:
        return LOWEST_PRIORITY
    if isinstance(priority, bool) or not isinstance(priority, int) \
            or not 1 <= priority <= LOWEST_PRIORITY:
        raise Refused('services', 'parameterOutOfRange',
                      f'priority {priority!r} is outside 1..{LOWEST_PRIORITY}')
    return priority


def check_closure_percent(value):
    """Return ``value`` [%] as a float if it is a finite number in [0, 100], else :class:`Refused`.

    A value that is not a real number (a string, a boolean): ``property`` /
    ``invalid-data-type``; NaN, infinite or outside the range: ``property`` /
    ``value-out-of-range``.
    """
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise Refused('property', 'invalidDataType',
                      f'a closure command is a REAL in %, not {type(value).__name__}')
    value = float(value)
    low, high = CLOSURE_RANGE_PERCENT
    if not math.isfinite(value) or not low <= value <= high:
        raise Refused('property', 'valueOutOfRange',
                      f'closure command {value!r} % is outside [{low:g}, {high:g}]')
    return value


def check_command(value, priority, storm_latched):
    """Return ``(priority, closure % or None)`` of an accepted write; :class:`Refused` if not.

    ``value`` None is a relinquish (NULL). The checks, in order: the priority's range, the
    value's type and range, the priority's layer (9-16 refused), the storm latch.
    """
    priority = check_priority(priority)
    if value is None:
        return priority, None
    value = check_closure_percent(value)
    if priority not in OVERRIDE_PRIORITIES:
        raise Refused('property', 'writeAccessDenied',
                      f'priority {priority} is automatic: the facade schedules itself there; '
                      f'command at 1..{MANUAL_OPERATOR_PRIORITY} (manual operator: '
                      f'{MANUAL_OPERATOR_PRIORITY})')
    if storm_latched:
        raise Refused('property', 'writeAccessDenied', STORM_REFUSAL)
    return priority, value


class CommandSlots:
    """The 16 slots of one commandable object: closure [%] or None (NULL) per priority."""

    def __init__(self):
        self.slots = [None] * LOWEST_PRIORITY

    def write(self, priority, value):
        """Set slot ``priority`` (1..16) to ``value`` [%] or None."""
        self.slots[priority - 1] = value

    def active(self):
        """Return ``(priority, value)`` of the highest non-NULL slot, or None."""
        for index, value in enumerate(self.slots):
            if value is not None:
                return index + 1, value
        return None

    def relinquish_overrides(self):
        """Set every override slot to NULL; return how many held a value."""
        held = sum(self.slots[p - 1] is not None for p in OVERRIDE_PRIORITIES)
        for priority in OVERRIDE_PRIORITIES:
            self.slots[priority - 1] = None
        return held


def effective_override(panel, facade):
    """Return the closure [0, 1] a panel's override should be, or None for automatic.

    ``panel`` and ``facade`` are :class:`CommandSlots`: the panel's own command, when any
    slot holds a value, wins over the facade-wide one (the more specific command, as a KNX
    channel's position over its group's).
    """
    for slots in (panel, facade):
        active = slots.active()
        if active is not None:
            return active[1] / 100.0
    return None
