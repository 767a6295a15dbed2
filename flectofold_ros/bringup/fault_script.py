"""A day's fault script: faults to inject into simulated panels, each at its time of the day.

A YAML list of entries (``msg_docs/fault_injection.md`` has the kinds and their figures)::

    - {at: '12:30', panels: [r00c01, r00c02], fault: leak, conductance_m3_s_pa: 2.0e-8}
    - {at: 5400, panels: '*', fault: supply_loss, duration_s: 120.0}
    - {at: '14:00:30', panels: [r00c01], fault: restore}

``at`` is a local time ``HH:MM`` or ``HH:MM:SS`` at the facade's UTC offset, or seconds after
the day's start; it must lie within the day. :func:`load_fault_script` reads and checks a file
and returns its :class:`TimedFault` entries in time order;
:class:`~flectofold_ros.bringup.fault_script_node.FaultScriptNode` publishes each on
``/facade/inject_fault`` when the ROS clock (``use_sim_time``) reaches it. Pure (no rclpy).

The YAML is read with :func:`flectofold_model.safe_yaml.load_yaml`, the loader of all user
YAML, with the rules a script asks for: no aliases or anchors, at most :data:`MAX_CHARACTERS`,
decimal numbers only, so that ``12:30`` is text (YAML 1.1 would read the number 750).
"""

from dataclasses import dataclass
import datetime
import math
from numbers import Real
import re

from flectofold_model.safe_yaml import load_yaml, YAMLInputError
from flectofold_ros.wire.fault_injection import FaultRequest, FaultRequestError, parse_request

#: Longest script accepted [characters] and most entries.
MAX_CHARACTERS = 2**20
MAX_ENTRIES = 10_000
_TIME = re.compile(r'(\d{1,2}):(\d{2})(?::(\d{2}))?')
_ENTRY_KEYS = ('at', 'panels', 'fault')


class FaultScriptError(ValueError):
    """A fault script that cannot be used; the message names the entry and the reason."""


@dataclass(frozen=True)
class TimedFault:
    """One entry: when (seconds after the day's start) and the checked request."""

    offset_s: float
    request: FaultRequest
    entry: int
    """Its place in the script, from 1."""


def load_fault_script(path, facade_ids, start_epoch_s, end_epoch_s, utc_offset_h):
    """Read and check the fault script at ``path``; return its entries in time order.

    The day runs from ``start_epoch_s`` to ``end_epoch_s`` [s, POSIX]; local times are at
    ``utc_offset_h`` [h]. Raises :class:`FaultScriptError` (a ``ValueError``).
    """
    try:
        with open(path, encoding='utf-8') as stream:
            text = stream.read(MAX_CHARACTERS + 1)
    except (OSError, UnicodeDecodeError) as error:
        raise FaultScriptError(f'{path}: cannot read the fault script: {error}') from None
    return parse_fault_script(load_document(text, str(path)), facade_ids, start_epoch_s,
                              end_epoch_s, utc_offset_h, str(path))


def load_document(text, source='fault script'):
    """Return the plain value of a YAML document, refusing aliases, anchors and size."""
    try:
        return load_yaml(text, source, max_characters=MAX_CHARACTERS, anchors=False,
                         decimal_numbers=True)
    except YAMLInputError as error:
        raise FaultScriptError(str(error)) from None


def parse_fault_script(document, facade_ids, start_epoch_s, end_epoch_s, utc_offset_h,
                       source='fault script'):
    """Check a loaded script (a list of entries); return its entries in time order."""
    if document is None:
        return []
    if not isinstance(document, list):
        raise FaultScriptError(f'{source}: a fault script is a list of entries '
                               f'{{at, panels, fault, ...}}')
    if len(document) > MAX_ENTRIES:
        raise FaultScriptError(f'{source}: {len(document)} entries; at most {MAX_ENTRIES}')
    day = _Day(start_epoch_s, end_epoch_s, utc_offset_h)
    faults = [_entry(number, entry, facade_ids, day, source)
              for number, entry in enumerate(document, start=1)]
    return sorted(faults, key=lambda fault: fault.offset_s)


def _entry(number, entry, facade_ids, day, source):
    where = f'{source}: entry {number}'
    if not isinstance(entry, dict):
        raise FaultScriptError(f'{where}: must be a mapping {{at, panels, fault, ...}}')
    missing = [key for key in _ENTRY_KEYS if key not in entry]
    if missing:
        raise FaultScriptError(f'{where}: needs {", ".join(missing)}')
    if not all(isinstance(key, str) for key in entry):
        raise FaultScriptError(f'{where}: every key must be a word')
    try:
        offset_s = day.offset_s(entry['at'])
        values = [(key, value) for key, value in entry.items() if key not in _ENTRY_KEYS]
        request = parse_request(entry['fault'], entry['panels'], values, facade_ids)
    except FaultRequestError as error:
        raise FaultScriptError(f'{where}: {error}') from None
    return TimedFault(offset_s, request, number)


class _Day:
    """The span of a day and its local date, for the ``at`` of the entries."""

    def __init__(self, start_epoch_s, end_epoch_s, utc_offset_h):
        self.zone = datetime.timezone(datetime.timedelta(hours=utc_offset_h))
        self.start = datetime.datetime.fromtimestamp(start_epoch_s, self.zone)
        self.end = datetime.datetime.fromtimestamp(end_epoch_s, self.zone)
        self.length_s = end_epoch_s - start_epoch_s

    def offset_s(self, at):
        """Seconds after the day's start of ``at`` (local time text or seconds)."""
        if isinstance(at, Real) and not isinstance(at, bool):
            if not (math.isfinite(at) and 0.0 <= at <= self.length_s):
                raise FaultRequestError(f'at {at!r} s lies outside the day: give 0 .. '
                                        f'{self.length_s:g} s after its start')
            return float(at)
        match = _TIME.fullmatch(at) if isinstance(at, str) else None
        if match is None:
            raise FaultRequestError(f'at {at!r} is neither a local time HH:MM[:SS] nor '
                                    "seconds after the day's start")
        hour, minute, second = (int(part or 0) for part in match.groups())
        if hour > 23 or minute > 59 or second > 59:
            raise FaultRequestError(f'at {at!r} is no time of day')
        for day in (self.start.date(), self.end.date()):  # a day may run past midnight
            moment = datetime.datetime(day.year, day.month, day.day, hour, minute, second,
                                       tzinfo=self.zone)
            if self.start <= moment <= self.end:
                return (moment - self.start).total_seconds()
        raise FaultRequestError(f'at {at} lies outside the day {self.start:%H:%M:%S} .. '
                                f'{self.end:%H:%M:%S}')
