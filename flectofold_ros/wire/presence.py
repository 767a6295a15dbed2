"""One facade per domain, and inputs with one source: the rules, without ROS.

A facade's ROS domain holds one clock, one coordinator and one panel node per panel id. Two
facades on one domain mix: their clocks, coordinators and same-id panels answer each other.
Every flectofold process that runs a part of a facade therefore announces itself, latched, on
:data:`INSTANCES` (an :class:`Instance`: its nodes, host, process id, role, facade, panels).
A latched message comes only from a live writer, so an announcement heard proves the other
process runs now; a node the ROS graph still lists may be one that died less than its DDS
lease ago.

The rule at start: a process refuses to run (exit 2) when it hears a live instance that holds
what it would hold (:func:`conflicts`): the clock, the coordinator, a panel id. While running,
the same announcement is an ERROR (the bringup stops its day). Inputs that have one publisher
by design (:data:`ONE_SOURCE`) are watched on the graph; each has its policy for the time a
second publisher is on it, because a subscriber cannot tell which of two publishers sent a
message (rclpy's message info carries no publisher id):

- ``stop``: the bringup stops its day (a second clock: simulated time is no longer its own);
- ``hold``: the input's messages are refused while two publish; the consumer does what it
  does when the input falls silent (panels: the setpoint watchdog vents them open; the
  coordinator: a stale sun holds its last commands, a stale DNI is dropped);
- ``storm_only``: a wind sample is taken only when it would trip the storm latch, so that a
  stranger can neither keep a storm from tripping nor release one;
- ``name_sender``: each accepted message is logged with the publishers it can have come from
  (fault requests; ``reset_faults`` requests, logged with the service's clients).

``msg_docs/reliability.md`` ("One facade per domain") lists each with its test.
"""

from dataclasses import dataclass
import os
import socket
from typing import Iterable, Optional

from flectofold_ros.wire import contract

#: Where every facade process announces itself: latched, one message per process.
INSTANCES = contract.Topic('/flectofold/instances', 'diagnostic_msgs/msg/DiagnosticStatus',
                           contract.LATCHED)

#: Roles of a process, as announced.
BRINGUP, COORDINATOR, PANELS = 'facade bringup', 'coordinator', 'panel process'

STOP, HOLD, STORM_ONLY, NAME_SENDER = 'stop', 'hold', 'storm_only', 'name_sender'

#: Input topic -> policy while more than one publisher is on it.
ONE_SOURCE = {
    contract.CLOCK.name: STOP,
    contract.FACADE_SETPOINTS.name: HOLD,
    contract.SUN.name: HOLD,
    contract.DNI.name: HOLD,
    contract.WIND_SPEED.name: STORM_ONLY,
    contract.INJECT_FAULT.name: NAME_SENDER,
}

#: Longest list of names a line quotes.
_NAMES_QUOTED = 4


@dataclass(frozen=True)
class Instance:
    """One announced facade process.

    ``nodes`` are its facade-wide nodes' full names (``/facade/coordinator``); ``panels`` the
    panel ids it runs; ``clock``: whether it publishes ``/clock``.
    """

    host: str
    pid: int
    role: str
    facade: str
    nodes: tuple = ()
    panels: tuple = ()
    clock: bool = False

    @property
    def process(self) -> tuple[str, int]:
        """``(host, pid)``: one process."""
        return self.host, self.pid

    @property
    def key(self) -> tuple[str, int, str]:
        """``(host, pid, role)``: one announcement (a bringup may run its panels itself)."""
        return self.host, self.pid, self.role

    def fields(self) -> tuple[str, str, str, list[tuple[str, str]]]:
        """Return the announcement's ``(name, hardware_id, message, values)``, values as pairs."""
        return (self.role, self.host, self.facade,
                [('pid', str(self.pid)), ('nodes', ','.join(self.nodes)),
                 ('panels', ','.join(self.panels)), ('clock', 'true' if self.clock else 'false')])

    def describe(self) -> str:
        """``facade bringup of 'demonstrator' (host h, pid 123)``."""
        return f'{self.role} of {self.facade!r} (host {self.host}, pid {self.pid})'


def this_process(role: str, facade: str, nodes: Iterable[str] = (), panels: Iterable[str] = (),
                 clock: bool = False) -> Instance:
    """Return the :class:`Instance` of the calling process."""
    return Instance(socket.gethostname(), os.getpid(), role, facade, tuple(nodes),
                    tuple(panels), clock)


def instance_from_fields(name: str, hardware_id: str, message: str,
                         values: Iterable[tuple[str, str]]) -> Instance:
    """Return the :class:`Instance` an announcement describes; ValueError if it is none."""
    values = dict(values)
    try:
        pid = int(values['pid'])
    except (KeyError, ValueError):
        raise ValueError(f'an announcement without a process id: {values.get("pid")!r}') \
            from None

    def listed(key: str) -> tuple[str, ...]:
        return tuple(word for word in values.get(key, '').split(',') if word)
    return Instance(hardware_id, pid, name, message, listed('nodes'), listed('panels'),
                    values.get('clock') == 'true')


def conflicts(own: Instance, others: Iterable[Instance]) -> list[str]:
    """Return one line per live instance in ``others`` that holds what ``own`` holds.

    Two instances conflict when both publish ``/clock``, both run a coordinator, or both run
    a panel of the same id. ``own``'s process (same host and pid) is never a conflict.
    """
    lines = []
    own_coordinator = _runs_coordinator(own)
    own_panels = set(own.panels)
    for other in others:
        if other.process == own.process:
            continue
        held = []
        if own.clock and other.clock:
            held.append(contract.CLOCK.name)
        if own_coordinator and _runs_coordinator(other):
            held.append(f'{contract.FACADE_NAMESPACE}/{contract.COORDINATOR_NODE}')
        shared = sorted(own_panels.intersection(other.panels))
        if shared:
            held.append(f'panel(s) {quoted(shared)}')
        if held:
            lines.append(f'{other.describe()} already holds {", ".join(held)}')
    return lines


def _runs_coordinator(instance: Instance) -> bool:
    coordinator = f'{contract.FACADE_NAMESPACE}/{contract.COORDINATOR_NODE}'
    return instance.role == COORDINATOR or coordinator in instance.nodes


def panel_id_of(node_name: str) -> Optional[str]:
    """Return the panel id of a panel node's full name (``/facade/r00c00/panel``), or None."""
    parts = node_name.strip('/').split('/')
    if len(parts) == 3 and parts[0] == contract.FACADE_NAMESPACE.strip('/') \
            and parts[2] == contract.PANEL_NODE and contract.PANEL_ID.fullmatch(parts[1]):
        return parts[1]
    return None


def who(node_name: str, instances: Iterable[Instance]) -> str:
    """Name a node for a log line: with its host and process when an instance announced it."""
    panel_id = panel_id_of(node_name)
    for instance in instances:
        if node_name in instance.nodes or (panel_id is not None and panel_id in instance.panels):
            return f'{node_name} ({instance.describe()})'
    return f'{node_name} (announced no flectofold process: host unknown)'


def doubled_panels(node_names: Iterable[str], panels: Iterable[str]) -> list[str]:
    """Return the ids of ``panels`` whose panel node the graph lists more than once."""
    wanted = set(panels)
    seen: set[str] = set()
    doubled: set[str] = set()
    for name in node_names:
        panel_id = panel_id_of(name)
        if panel_id in wanted:
            (doubled if panel_id in seen else seen).add(panel_id)
    return sorted(doubled)


def quoted(names: Iterable[str]) -> str:
    """Quote a list short enough for one line: ``a, b, c, d and 3 more``."""
    names = list(names)
    head = ', '.join(names[:_NAMES_QUOTED])
    return head + (f' and {len(names) - _NAMES_QUOTED} more' if len(names) > _NAMES_QUOTED
                   else '')
