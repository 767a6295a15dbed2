"""``/facade/setpoints``: every panel's commanded closure in one message.

The message is a ``sensor_msgs/msg/JointState``: ``name`` holds panel ids and ``position``
their closures [-] (0 open ... 1 closed); ``velocity`` and ``effort`` are empty, as on
``/facade/override``. The coordinator sends one per decision and per heartbeat; each panel
process takes the entries of its own panels and leaves those of other processes' panels.

Pure Python (no rclpy). Field table, and why one message rather than one ``Float64`` per
panel: msg_docs/panel_node.md, section "Topics", item ``/facade/setpoints``.
"""

from typing import Iterable, Sequence


class SetpointsMessageError(ValueError):
    """A facade setpoints message that cannot be read as pairs of panel id and closure."""


def entries(names: Sequence[str], positions: Sequence[float]) -> list[tuple[str, float]]:
    """Return the ``(panel id, closure)`` pairs of a message's ``name`` and ``position``.

    A message whose lists differ in length, or that names a panel twice, is refused whole:
    which value was meant is unknown. Each closure is returned as given; whether it is a
    valid setpoint is the panel's guard's to say.

    Parameters
    ----------
    names : sequence of str
        The message's ``name``: panel ids.
    positions : sequence of float
        The message's ``position``: closures [-] (0 open ... 1 closed), one per name.

    Returns
    -------
    list of (str, float)
        ``[(panel id, closure), ...]`` in the message's order.

    Raises
    ------
    SetpointsMessageError
        If ``names`` and ``positions`` differ in length, or a panel id occurs more than once.
    """
    if len(names) != len(positions):
        raise SetpointsMessageError(
            f'{len(names)} name(s) and {len(positions)} position(s): they must pair up')
    if len(set(names)) != len(names):
        seen: set[str] = set()
        twice: set[str] = set()
        for name in names:
            (twice if name in seen else seen).add(name)
        raise SetpointsMessageError(f'{", ".join(sorted(twice)[:5])} named more than once')
    return [(name, float(value)) for name, value in zip(names, positions)]


def fields(panel_ids: Sequence[str], closures: Iterable[float]) -> tuple[list[str], list[float]]:
    """Return ``(name, position)`` for a message commanding ``closures`` to ``panel_ids``.

    Parameters
    ----------
    panel_ids : sequence of str
        The panels commanded.
    closures : iterable of float
        Their closures [-] (0 open ... 1 closed), one per panel id, in the same order.

    Returns
    -------
    tuple of (list of str, list of float)
        The message's ``name`` and ``position`` fields.

    Raises
    ------
    ValueError
        If the number of closures differs from the number of panel ids.
    """
    closures = [float(value) for value in closures]
    if len(closures) != len(panel_ids):
        raise ValueError(f'{len(closures)} closure(s) for {len(panel_ids)} panel id(s)')
    return list(panel_ids), closures
