"""The aperture of a hexagonal panel and the tiling of the facade by its copies, for ray casting.

Geometry (the panel frame of :mod:`~flectofold_model.kinematics.hexagon_panel`): the flat
panel is the regular hexagon of circumradius ``R`` around the origin with corners at the
azimuths ``30 + 60 j`` degrees, so two of its sides are parallel to y at ``x = +-sqrt(3) R / 2``.
Its bounding box is ``sqrt(3) R`` along x by ``2 R`` along y.

**Scan lines.** The ray casting measures the hexagon along parallel lines across it
(:func:`.scan_lines.hexagon_lines`), so its shares are shares of the hexagon's area (not of
its bounding box).

**Tiling.** Identical hexagonal panels in one orientation tile the facade edge to edge on the
lattice ``i b1 + j b2`` with ``b1 = (sqrt(3) R, 0)`` and ``b2 = (sqrt(3) R / 2, 3 R / 2)``: the
neighbours across the six sides, ``sqrt(3) R`` away.
"""

import math

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import FloatArray, IntArray

#: Unit normals (3, 2) of the hexagon's three pairs of opposite sides (azimuths 0, 60 and
#: 120 degrees); the hexagon is ``|n . p| <= sqrt(3) R / 2`` for all three.
SIDE_NORMALS = np.array([[math.cos(a), math.sin(a)] for a in np.radians([0.0, 60.0, 120.0])])
#: Slack on the reach of a lattice cell (relative): a cell exactly at the reach is crossed.
_REACH_SLACK = 1e-9


def bounding_box_m(circumradius_m: npt.ArrayLike) -> FloatArray:
    """(N, 2) size of each hexagon's bounding box, ``(sqrt(3) R, 2 R)`` [m]."""
    radius = np.asarray(circumradius_m, dtype=float)
    return np.stack([math.sqrt(3.0) * radius, 2.0 * radius], axis=-1)


def lattice_basis(circumradius_m: npt.ArrayLike) -> FloatArray:
    """(N, 2, 2) tiling lattice of each panel, the columns ``b1`` and ``b2`` [m]."""
    radius = np.asarray(circumradius_m, dtype=float)
    basis = np.empty(radius.shape + (2, 2))
    basis[..., 0, 0] = math.sqrt(3.0) * radius
    basis[..., 1, 0] = 0.0
    basis[..., 0, 1] = math.sqrt(3.0) / 2 * radius
    basis[..., 1, 1] = 1.5 * radius
    return basis


def cells_crossed(start_m: FloatArray, span_m: FloatArray, basis: FloatArray,
                  reach_m: FloatArray) -> tuple[IntArray, FloatArray]:
    """Lattice cells that the rays of each panel can meet, with the panel each belongs to.

    The rays of panel n start within ``reach_m`` of the point ``start_m[n]`` (its footprint's
    rays, moved by their run to the meshes' lowest height) and run by ``tau span_m[n]``,
    ``0 <= tau <= 1``, across the meshes' height range [m]. A copy of the mesh at lattice
    point ``c = basis @ (i, j)`` can be met only if ``c`` lies within ``reach_m`` (the
    footprint's radius plus the mesh's) of that segment. Returns the panel index (K,) and the
    integer lattice coordinates (K, 2) (as floats) of every such (panel, cell) pair.
    """
    inverse = np.linalg.inv(basis)
    first = np.einsum('nij,nj->ni', inverse, start_m)
    last = np.einsum('nij,nj->ni', inverse, start_m + span_m)
    reach = reach_m * (1.0 + _REACH_SLACK)
    # A disc of radius r spans r |row i of the inverse| in lattice coordinate i.
    extent = reach[:, None] * np.linalg.norm(inverse, axis=-1)
    low = np.ceil(np.minimum(first, last) - extent).astype(np.int64)
    high = np.floor(np.maximum(first, last) + extent).astype(np.int64)
    size = high - low + 1
    counts = size[:, 0] * size[:, 1]
    panel = np.repeat(np.arange(start_m.shape[0]), counts)
    local = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    cells = low[panel] + np.stack([local // size[panel, 1], local % size[panel, 1]], axis=-1)
    point = np.einsum('kij,kj->ki', basis[panel], cells) - start_m[panel]
    direction = span_m[panel]
    length2 = np.einsum('ki,ki->k', direction, direction)
    along = np.einsum('ki,ki->k', point, direction)
    tau = np.clip(np.divide(along, length2, out=np.zeros_like(along), where=length2 > 0.0),
                  0.0, 1.0)
    distance = np.linalg.norm(point - tau[:, None] * direction, axis=-1)
    near = distance <= reach[panel]
    return panel[near], cells[near].astype(np.float64)
