"""``/facade/setpoints``: every panel's commanded closure in one message.

A ``sensor_msgs/msg/JointState`` whose ``name`` holds panel ids and ``position`` their
closures [0 open, 1 closed], as ``/facade/override`` does (velocity and effort empty). The
coordinator sends one per decision and per heartbeat instead of one ``Float64`` per panel:
1,000 messages in a burst from one writer overran the middleware's queues and some arrived
only at the next reliable repair, 1-3 s late (``msg_docs/panel_node.md``). Each panel process
takes the entries of its own panels; those of other processes' panels are theirs.

Pure Python (no rclpy). Field table: ``msg_docs/panel_node.md``.
"""


class SetpointsMessageError(ValueError):
    """A facade setpoints message that cannot be read as pairs of panel id and closure."""


def entries(names, positions):
    """Return ``[(panel id, closure), ...]`` of a message's ``name`` and ``position``.

    A message whose lists differ in length, or that names a panel twice, is refused whole
    (:class:`SetpointsMessageError`): which value was meant is unknown. Each closure is
    returned as given; whether it is a valid setpoint is the panel's guard's to say.
    """
    if len(names) != len(positions):
        raise SetpointsMessageError(
            f'{len(names)} name(s) and {len(positions)} position(s): they must pair up')
    if len(set(names)) != len(names):
        seen, twice = set(), set()
        for name in names:
            (twice if name in seen else seen).add(name)
        raise SetpointsMessageError(f'{", ".join(sorted(twice)[:5])} named more than once')
    return [(name, float(value)) for name, value in zip(names, positions)]


def fields(panel_ids, closures):
    """Return ``(name, position)`` for a message commanding ``closures`` to ``panel_ids``."""
    closures = [float(value) for value in closures]
    if len(closures) != len(panel_ids):
        raise ValueError(f'{len(closures)} closure(s) for {len(panel_ids)} panel id(s)')
    return list(panel_ids), closures
