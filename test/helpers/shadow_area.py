"""Exact blocked share of a footprint, from the shadows of a mesh: a reference for the tests.

Independent of :mod:`flectofold_model.shading.ray_casting`: no rays and no barycentric
coordinates. The mesh's triangles (and their copies on the facade's lattice) are projected
along the sun onto the footprint plane ``z = -standoff``; every row ``y = y_j`` of the
footprint (the midlines of ``rows`` equal strips, along x) meets each shadow triangle in an
interval, found where two of its edges cross the row; the union of a row's intervals,
clipped to the footprint, is measured exactly and the rows are summed (the midpoint rule
across them: an error of at most half a strip's share per shadow edge along x, 2e-4 for
2048 rows, and far less in practice).

A footprint point is blocked exactly when it lies in a triangle's shadow, because every mesh
point lies in front of the footprint plane (checked).
"""

import math

import numpy as np

ROWS = 2048


def quad_footprint(length_m, width_m):
    """Footprint ``|x| <= L/2, |y| <= W/2`` and its lattice of cells (b1, b2) [m]."""
    return {'half_y': width_m / 2, 'area': length_m * width_m,
            'half_x': lambda y: np.full_like(y, length_m / 2),
            'basis': (np.array([length_m, 0.0]), np.array([0.0, width_m]))}


def hexagon_footprint(radius_m):
    """Footprint of the hexagon of circumradius R (corners at 30 + 60 j deg) and its lattice."""
    root3 = math.sqrt(3.0)
    return {'half_y': radius_m, 'area': 1.5 * root3 * radius_m**2,
            'half_x': lambda y: np.minimum(root3 * radius_m / 2, root3 * (radius_m - np.abs(y))),
            'basis': (np.array([root3 * radius_m, 0.0]),
                      np.array([root3 * radius_m / 2, 1.5 * radius_m]))}


def blocked_share(vertices, faces, footprint, sun, standoff_m, tessellated=True, rows=ROWS):
    """Share of the footprint's area in the shadows of the mesh (and of its copies)."""
    assert vertices[:, 2].min() >= -standoff_m
    shadow = vertices[:, :2] - (vertices[:, 2:3] + standoff_m) * sun[:2] / sun[2]
    half_y = footprint['half_y']
    offsets = np.zeros((1, 2))
    if tessellated:
        reach = 2 * half_y + footprint['basis'][0][0] + np.linalg.norm(shadow, axis=-1).max()
        b1, b2 = footprint['basis']
        count = int(math.ceil(reach / min(b1[0], b2[1]))) + 2
        i, j = np.meshgrid(np.arange(-count, count + 1), np.arange(-count, count + 1))
        offsets = i.reshape(-1, 1) * b1 + j.reshape(-1, 1) * b2
    triangles = (shadow[faces][None] + offsets[:, None, None, :]).reshape(-1, 3, 2)
    low, high = triangles.min(axis=1), triangles.max(axis=1)
    reach_x = footprint['half_x'](np.zeros(1))[0]
    keep = ((low[:, 0] < reach_x) & (high[:, 0] > -reach_x) & (low[:, 1] < half_y)
            & (high[:, 1] > -half_y))
    triangles, low, high = triangles[keep], low[keep], high[keep]
    step = 2 * half_y / rows
    first = np.ceil((low[:, 1] + half_y) / step - 0.5).astype(int).clip(0, rows)
    last = np.floor((high[:, 1] + half_y) / step - 0.5).astype(int).clip(-1, rows - 1)
    counts = np.maximum(last - first + 1, 0)
    owner = np.repeat(np.arange(len(triangles)), counts)
    row = first[owner] + np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    y = -half_y + (row + 0.5) * step
    corners = triangles[owner]
    start = np.full(y.shape, np.inf)
    end = np.full(y.shape, -np.inf)
    for a, b in ((0, 1), (1, 2), (2, 0)):
        ya, yb = corners[:, a, 1], corners[:, b, 1]
        crosses = (ya - y) * (yb - y) < 0.0
        with np.errstate(divide='ignore', invalid='ignore'):
            x = corners[:, a, 0] + (y - ya) * (corners[:, b, 0] - corners[:, a, 0]) / (yb - ya)
        start = np.where(crosses, np.minimum(start, x), start)
        end = np.where(crosses, np.maximum(end, x), end)
    edge = footprint['half_x'](y)
    start, end = np.maximum(start, -edge), np.minimum(end, edge)
    valid = end > start
    return _union_length(row[valid], start[valid], end[valid]) * step / footprint['area']


def _union_length(group, start, end):
    """Total length of the unions of the intervals ``[start, end]`` of each group.

    Sorted by group, then start: an interval adds what reaches past the furthest end before
    it in its group (the groups are moved apart along the line so that none overlaps the next).
    """
    if not len(start):
        return 0.0
    spread = 2.0 * max(np.abs(start).max(), np.abs(end).max()) + 1.0
    order = np.lexsort((start, group))
    offset = spread * group[order]
    start, end = start[order] + offset, end[order] + offset
    before = np.concatenate([[-np.inf], np.maximum.accumulate(end)[:-1]])
    return float(np.maximum(end - np.maximum(start, before), 0.0).sum())
