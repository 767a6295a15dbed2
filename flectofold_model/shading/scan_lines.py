"""Scan lines across a panel's footprint, and the exact length of a union of intervals.

The ray casting of :mod:`.ray_casting` measures the blocked share of a footprint along
parallel **scan lines**: on each line the points whose ray toward the sun meets a given
triangle form one interval (Moller-Trumbore's barycentric coordinates are affine along the
line), the union of a line's intervals is measured exactly, and the lines, at the midpoints
of equal strips across the footprint, are summed (the midpoint rule across them). So a
shadow's outline costs no error where it crosses the lines, only where it runs along them.

Straight shadow edges run along x and y in every sun (the shadows of the sheets' edges along
the mid-rib and across it stay parallel to them), and a hexagon's outline and spokes run at
multiples of 30 degrees: the lines are tilted away from those directions
(:data:`QUAD_LINE_ANGLE_RAD`, :data:`HEXAGON_LINE_ANGLE_RAD`). On a grid of points, instead,
such edges align with rows of points, and the error reaches a whole row.

Footprints are intersections of slabs ``|n_j . p| <= h_j``: the ``L x W`` rectangle of a quad
panel, in units of ``(L, W)``, or the hexagon, in units of its circumradius ``R``.
"""

from dataclasses import dataclass
import math
from typing import Any

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import FloatArray, IntArray

#: Angle of the scan lines to the x axis (the mid-rib) of a quad panel's footprint, in units
#: of ``(L, W)``: the golden-ratio slope, far from the x and y axes.
QUAD_LINE_ANGLE_RAD = math.atan((math.sqrt(5.0) - 1.0) / 2.0)
#: Angle of the scan lines to the x axis of a hexagon: midway between the hexagon's edge
#: directions (multiples of 30 degrees).
HEXAGON_LINE_ANGLE_RAD = math.radians(15.0)
#: Scan lines per ``samples`` (the rays per side of a grid of points that they replace).
LINES_PER_SAMPLE = 3
#: Units per line parameter in the exact (integer) union of intervals: ``2**-30`` units.
_QUANTUM = float(2**30)
#: Spacing of the groups (panel, line) of intervals in the integer union: above the range of a
#: quantised ``t`` (``|t| <= 2``, ``2**31`` quanta either way); (panel x lines + line) x
#: spacing stays within int64 for up to ``2**30`` panel lines at once.
_GROUP_SPACING = 2**33


@dataclass(frozen=True)
class ScanLines:
    """Parallel lines ``p = origin + t direction``, ``start <= t <= end``, across a footprint.

    Points are rows ``(xi, eta, 1)`` in units of the footprint's bounding box (``L x W``, or
    ``sqrt(3) R x 2 R``); ``t`` is in a unit common to all lines, so chord lengths in ``t``
    are proportional to lengths on the footprint. The lines are the midlines of equal strips.
    """

    origin: np.ndarray
    """(M, 3) rows ``(xi, eta, 1)``: the point ``t = 0`` of each line."""
    direction: np.ndarray
    """(3,) row ``(d_xi, d_eta, 0)``: the step of the lines per unit of ``t``."""
    start: np.ndarray
    """(M,) ``t`` where each line enters the footprint."""
    end: np.ndarray
    """(M,) ``t`` where each line leaves the footprint."""
    across: np.ndarray
    """(2,) ``a`` with ``a . (xi, eta)`` the offset of the point across the lines."""
    offset: np.ndarray
    """(M,) offset of each line across the lines: its origin is ``offset unit_origin``."""
    unit_origin: np.ndarray
    """(2,) ``(xi, eta)`` of the origin of the line at offset 1."""
    first_offset: float
    """Offset across the lines of line 0."""
    spacing: float
    """Offset from one line to the next (the strips' width)."""

    def index_range(self, low_offset: FloatArray, high_offset: FloatArray,
                    margin: float = 0.01) -> tuple[IntArray, IntArray]:
        """First and last lines (clipped to the footprint's) with offsets within the bounds.

        ``margin`` (in line spacings) widens the bounds, so a line through a bound's end counts.
        """
        first = np.ceil((low_offset - self.first_offset) / self.spacing - margin)
        last = np.floor((high_offset - self.first_offset) / self.spacing + margin)
        top = self.start.size - 1
        return (np.clip(first, 0, top + 1).astype(np.int64),
                np.clip(last, -1, top).astype(np.int64))

    @property
    def offset32(self) -> npt.NDArray[np.float32]:
        """:attr:`offset` in float32."""
        return self.offset.astype(np.float32)

    @property
    def start32(self) -> npt.NDArray[np.float32]:
        """:attr:`start` in float32 (exact: the ends are float32 numbers)."""
        return self.start.astype(np.float32)

    @property
    def end32(self) -> npt.NDArray[np.float32]:
        """:attr:`end` in float32 (exact)."""
        return self.end.astype(np.float32)

    def quantised(self) -> tuple[IntArray, IntArray]:
        """(M,) starts and ends on the integer grid of :func:`covered_length`."""
        return _quantise(self.start), _quantise(self.end)


def line_count(samples: int) -> int:
    """Scan lines for ``samples``: ``LINES_PER_SAMPLE * samples``."""
    return LINES_PER_SAMPLE * int(samples)


def quad_lines(samples: int) -> ScanLines:
    """Scan lines across the ``L x W`` footprint of a quad panel (units of ``(L, W)``)."""
    normals = np.array([[1.0, 0.0], [0.0, 1.0]])
    origin, direction, start, end, offsets = _lines_across(
        normals, np.array([0.5, 0.5]), QUAD_LINE_ANGLE_RAD, line_count(samples))
    return _scan_lines(origin, direction, start, end, offsets, np.ones(2))


def hexagon_lines(samples: int, side_normals: FloatArray) -> ScanLines:
    """Scan lines across a hexagon with sides ``|n_j . p| <= sqrt(3) R / 2`` (``t`` in R).

    ``side_normals`` (3, 2) are the unit normals of its three pairs of opposite sides; the
    points are returned in units of the bounding box ``sqrt(3) R x 2 R``.
    """
    half = np.full(len(side_normals), math.sqrt(3.0) / 2)
    origin, direction, start, end, offsets = _lines_across(
        side_normals, half, HEXAGON_LINE_ANGLE_RAD, line_count(samples))
    return _scan_lines(origin, direction, start, end, offsets, np.array([1.0 / math.sqrt(3.0),
                                                                         0.5]))


def covered_length(owner: IntArray, line: IntArray, start: npt.NDArray[np.floating[Any]],
                   end: npt.NDArray[np.floating[Any]], count: int, lines: int) -> FloatArray:
    """Length (in ``t``) of the union of the intervals on each of ``count`` panels' lines.

    ``owner`` and ``line`` (K,) name the panel and the line of each interval
    ``[start, end]`` (K,), which lies within the line's chord. The union is taken on the
    integer grid of ``2**-30`` units of ``t`` (exact: no rounding depends on how panels are
    batched); the result (count,) is the sum over each panel's lines, in units of ``t``.
    """
    base = (owner.astype(np.int64) * lines + line) * _GROUP_SPACING
    low = base + _quantise(start)
    # Ties need no order: the integer union is exact whatever the order of equal starts.
    order = np.argsort(low)
    low = low[order]
    high = base[order] + _quantise(end[order])
    reach = np.maximum.accumulate(high)
    before = np.concatenate([low[:1], reach[:-1]])
    covered = np.maximum(high - np.maximum(low, before), 0)
    return np.bincount(owner[order], weights=covered, minlength=count) / _QUANTUM


def chord_length(lines: ScanLines) -> float:
    """Sum of the lines' chords across the footprint, on the grid of :func:`covered_length`."""
    start, end = lines.quantised()
    return float(np.sum(end - start)) / _QUANTUM


def _quantise(t: npt.ArrayLike) -> npt.NDArray[np.int64]:
    """``t`` on the grid of ``2**-30`` units, rounded toward zero."""
    return (np.asarray(t) * _QUANTUM).astype(np.int64)


def _lines_across(normals: FloatArray, half: FloatArray, angle_rad: float, count: int
                  ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray,
                             tuple[FloatArray, FloatArray, float]]:
    """``count`` lines at ``angle_rad`` across the slabs ``|normals . p| <= half``.

    They are the midlines of ``count`` equal strips that together cover the footprint.
    Returns the origins (count, 2), the direction (2,), the chords' ends (count,) and the
    offsets across the lines: ``(across, offsets, spacing)``, ``across`` the unit normal.
    """
    direction = np.array([math.cos(angle_rad), math.sin(angle_rad)])
    across = np.array([-direction[1], direction[0]])
    # The footprint's extent across the lines: its support along ``across``, from the corners.
    corners = _corners(normals, half)
    low, high = (corners @ across).min(), (corners @ across).max()
    spacing = (high - low) / count
    offset = low + (np.arange(count) + 0.5) * spacing
    origin = offset[:, None] * across
    along = normals @ direction
    centre = origin @ normals.T
    with np.errstate(divide='ignore'):
        first = (-half - centre) / along
        second = (half - centre) / along
    start = np.minimum(first, second).max(axis=1)
    end = np.maximum(first, second).min(axis=1)
    return origin, direction, start, np.maximum(end, start), (across, offset, spacing)


def _corners(normals: FloatArray, half: FloatArray) -> FloatArray:
    """Corners of the convex polygon ``|normals . p| <= half`` (pairwise slab crossings)."""
    points = []
    for i in range(len(normals)):
        for j in range(i + 1, len(normals)):
            matrix = np.array([normals[i], normals[j]])
            for si in (-1.0, 1.0):
                for sj in (-1.0, 1.0):
                    points.append(np.linalg.solve(matrix, [si * half[i], sj * half[j]]))
    points = np.array(points)
    inside = np.all(np.abs(points @ normals.T) <= half * (1 + 1e-12), axis=1)
    return points[inside]


def _scan_lines(origin: FloatArray, direction: FloatArray, start: FloatArray, end: FloatArray,
                offsets: tuple[FloatArray, FloatArray, float], scale: FloatArray) -> ScanLines:
    """Make the ScanLines of lines in footprint units, scaled by ``scale`` to the box's."""
    across, offset, spacing = offsets
    rows = np.column_stack([origin * scale, np.ones(len(origin))])
    step = direction * scale
    # The chords' ends are float32 numbers, so the casting's float32 intervals end on them.
    start, end = (np.asarray(t, dtype=np.float32).astype(np.float64) for t in (start, end))
    return ScanLines(origin=rows, direction=np.array([step[0], step[1], 0.0]), start=start,
                     end=end, across=across / scale, offset=offset,
                     unit_origin=across * scale, first_offset=float(offset[0]),
                     spacing=float(spacing))
