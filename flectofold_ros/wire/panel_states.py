"""``/facade/panel_states``: every panel of a panel process in one stamped message.

A ``sensor_msgs/msg/PointCloud2`` with one point per panel, at the panel's origin in the
site's ENU frame (so RViz and Foxglove draw it as it is), and the panel's state as further
fields. This module packs and unpacks it with numpy (no rclpy): the panel processes, the
bringup's monitor, the Rerun bridge and the bag converter all read it through
:func:`unpack`. Field table: ``msg_docs/facade_state.md``.

The message is the standard way to put a stamped table of typed, named columns on a topic;
a panel id ``rNNcNN`` travels as its two numbers, ``fault`` and ``status`` as their index in
:data:`flectofold_ros.wire.contract.FAULTS` and :data:`~flectofold_ros.wire.contract.STATUSES`.
"""

from typing import Any, Callable, Sequence

import numpy as np
import numpy.typing as npt

from flectofold_ros.wire import contract

#: ``sensor_msgs/PointField`` datatype numbers.
UINT8, UINT16, FLOAT32 = 2, 4, 7
_NUMPY = {UINT8: '<u1', UINT16: '<u2', FLOAT32: '<f4'}

#: name, PointField datatype, what it is.
FIELDS = (
    ('x', FLOAT32, 'panel origin, east [m]'),
    ('y', FLOAT32, 'panel origin, north [m]'),
    ('z', FLOAT32, 'panel origin, up [m]'),
    ('closure', FLOAT32, 'closure from the filtered measured pressure [0 open, 1 closed]'),
    ('fold_angle_rad', FLOAT32, 'flap fold angle at the crease apex [rad]'),
    ('pressure_pa', FLOAT32, 'absolute cushion pressure as measured [Pa]; NaN: no reading'),
    ('setpoint', FLOAT32, 'closure the loop tracks (after the watchdog) [0, 1]'),
    ('row', UINT16, 'panel id rNNcNN: NN of r'),
    ('column', UINT16, 'panel id rNNcNN: NN of c'),
    ('fault', UINT8, 'index in the fault words (0: none)'),
    ('status', UINT8, 'index in the status words'),
    ('active', UINT8, '1 while the loop moves the panel (a valve open, or the pressure '
                      'reference still ramping), else 0'),
)
DTYPE = np.dtype({
    'names': [name for name, _, _ in FIELDS],
    'formats': [_NUMPY[kind] for _, kind, _ in FIELDS],
    'offsets': [0, 4, 8, 12, 16, 20, 24, 28, 30, 32, 33, 34],
    'itemsize': 36,
})
POINT_STEP = DTYPE.itemsize
#: Byte offset of each field in a point (a structured dtype has fields).
_OFFSETS: dict[str, int] = {name: DTYPE.fields[name][1]  # type: ignore[index]
                            for name, _, _ in FIELDS}
#: A table of panels: a numpy structured array of :data:`DTYPE`, one row per panel.
Table = npt.NDArray[np.void]
#: Panel ids as their numbers: rows or columns (uint16), or indices (int64).
UInt16Array = npt.NDArray[np.uint16]
IndexArray = npt.NDArray[np.int64]


def new_table(count: int) -> Table:
    """Return a zeroed table of ``count`` panels (a numpy structured array of :data:`DTYPE`)."""
    return np.zeros(count, dtype=DTYPE)


def id_numbers(panel_ids: Sequence[str]) -> tuple[UInt16Array, UInt16Array]:
    """Return the ``(rows, columns)`` uint16 arrays of ``rNNcNN`` panel ids."""
    for panel_id in panel_ids:
        if not contract.PANEL_ID.fullmatch(panel_id):
            raise ValueError(f'panel id {panel_id!r} is not of the form rNNcNN')
    rows = np.array([int(p[1:3]) for p in panel_ids], dtype=np.uint16)
    columns = np.array([int(p[4:6]) for p in panel_ids], dtype=np.uint16)
    return rows, columns


def index_lookup(panel_ids: Sequence[str]) -> IndexArray:
    """Return an array that maps ``100 * row + column`` to the index of the id in ``panel_ids``.

    Entries of ids not in ``panel_ids`` are -1; :func:`indices` uses it.
    """
    rows, columns = id_numbers(panel_ids)
    lookup = np.full(10000, -1, dtype=np.int64)
    lookup[100 * rows.astype(np.int64) + columns] = np.arange(len(panel_ids))
    return lookup


def indices(table: Table, lookup: IndexArray) -> IndexArray:
    """Return each point's index by an :func:`index_lookup` (-1: a panel it does not know).

    A row or column beyond two digits (a foreign or hostile cloud) is a panel it does not know.
    """
    rows, columns = table['row'].astype(np.int64), table['column'].astype(np.int64)
    inside = (rows < 100) & (columns < 100)
    index = np.full(len(table), -1, dtype=np.int64)
    index[inside] = lookup[100 * rows[inside] + columns[inside]]
    return index


def panel_ids(table: Table) -> list[str]:
    """Return the panel ids of a table's points."""
    rows, columns = table['row'].tolist(), table['column'].tolist()
    return [f'r{r:02d}c{c:02d}' for r, c in zip(rows, columns)]


def fill_message(message: Any, table: Table, stamp: Any,
                 point_field: Callable[..., Any]) -> Any:
    """Make ``message`` (a ``PointCloud2``) carry ``table``; ``point_field`` is its field class.

    ``stamp`` is a ``builtin_interfaces/Time``; the frame is :data:`contract.SITE_FRAME`.
    """
    message.header.stamp = stamp
    message.header.frame_id = contract.SITE_FRAME
    message.height, message.width = 1, len(table)
    if len(message.fields) != len(FIELDS):
        message.fields = [point_field(name=name, offset=_OFFSETS[name], datatype=kind, count=1)
                          for name, kind, _ in FIELDS]
    message.is_bigendian = False
    message.point_step, message.row_step = POINT_STEP, POINT_STEP * len(table)
    message.data = table.tobytes()
    message.is_dense = True
    return message


def unpack(message: Any) -> Table:
    """Return the table a ``PointCloud2`` carries (rclpy or rosbags message).

    Raises ValueError when the message does not have this module's layout (another field
    set, byte order or point size, or data of the wrong length), so that a foreign cloud on
    the topic is rejected rather than misread.
    """
    layout = [(field.name, int(field.offset), int(field.datatype), int(field.count))
              for field in message.fields]
    expected = [(name, _OFFSETS[name], kind, 1) for name, kind, _ in FIELDS]
    if layout != expected:
        raise ValueError(f"panel_states fields {layout} are not the contract's {expected}")
    if message.is_bigendian or message.point_step != POINT_STEP:
        raise ValueError(f'panel_states must be little endian with {POINT_STEP}-byte points')
    count = int(message.width) * int(message.height)
    data = message.data
    data = data.tobytes() if hasattr(data, 'tobytes') else bytes(data)
    if len(data) != count * POINT_STEP:
        raise ValueError(f'panel_states: {len(data)} bytes for {count} points of '
                         f'{POINT_STEP}')
    return np.frombuffer(data, dtype=DTYPE)


def fault_words(table: Table) -> list[str]:
    """Return each point's fault word; ``unknown`` for a code outside the contract's."""
    return _words(table['fault'], contract.FAULTS)


def status_words(table: Table) -> list[str]:
    """Return each point's status word; ``unknown`` for a code outside the contract's."""
    return _words(table['status'], contract.STATUSES)


def _words(codes: npt.NDArray[Any], words: Sequence[str]) -> list[str]:
    return [words[code] if code < len(words) else 'unknown' for code in codes.tolist()]


def stamp_ns(header: Any) -> int:
    """Nanoseconds of a ``std_msgs/Header`` stamp."""
    return header.stamp.sec * 10**9 + header.stamp.nanosec
