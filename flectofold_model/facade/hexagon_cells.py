"""Hexagonal tessellation of facade surfaces: regular hexagon cells on a hexagonal lattice.

A parametric surface (:class:`~.surfaces.ParametricSurface`) is tessellated in its
**developed parameter plane** ``(s, t)``: ``s`` is the arc length along the surface's
horizontal centre line (``v = 0``), ``t`` the arc length along its vertical centre line
(``u = 0``), and a point ``(s, t)`` is the surface point at ``u = U(s)``, ``v = V(t)`` with
``U``, ``V`` the inverse arc lengths. The map is exact (an isometry) for a plane and a
cylinder; on a dome or a saddle it keeps the two centre lines' lengths and the cells stretch
a little away from them (the measured size is what each panel gets).

Cells are regular hexagons of circumradius ``R`` with a corner pointing along ``+t`` (up the
facade); their centres lie on the hexagonal lattice with rows ``1.5 R`` apart and centres
``sqrt(3) R`` apart along a row, alternate rows shifted by half that, so neighbouring cells
share an edge. Only cells that lie wholly inside the surface's boundary are kept (no half
panels); the lattice is centred on the surface, in whichever of the two centred layouts
(every row the same length, or rows alternating one cell shorter) keeps more cells.

Per cell: the frame at the centre (origin on the surface, ``z`` the outward normal, ``y`` the
tangent up the facade, which is the direction of the hexagon's corner at 90 degrees, the
triangle vertex ``T_0`` of :mod:`flectofold_model.kinematics.hexagon_panel`; ``x = y x z``
points right), the mean on-surface circumradius (centre to corner chords) and the signed
normal curvatures (convex positive) along the three flap axes, from the centre toward the
flap tips ``H_i`` at 150 + 120 i degrees, i.e. across each fold line.

An OBJ mesh of hexagonal faces gives one cell per face (:func:`obj_hexagon_cells`).
"""

from dataclasses import dataclass
import math

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import FloatArray, FloatOrArray, IntArray, PathLike
from flectofold_model.facade.surfaces import ParametricSurface

#: Azimuths of the flap axes (toward H_0, H_1, H_2) in the panel frame [rad].
FLAP_AXIS_AZIMUTHS_RAD = np.radians([150.0, 270.0, 30.0])
#: Most rows or cells in a row: panel ids carry two digits each.
MAX_LINES = 100
_SQRT3 = math.sqrt(3.0)
_ARC_SAMPLES = 4097
#: Near-regular hexagonal OBJ faces: allowed relative spread of corner radii and side
#: lengths, of the 60 degree corner spacing, and out-of-plane distance, over the mean radius.
OBJ_TOLERANCE = 0.1
OBJ_PLANARITY = 0.05


@dataclass(frozen=True)
class HexagonCells:
    """The hexagonal cells of a tessellated surface, in the facade frame; arrays over cells."""

    row: np.ndarray
    """Row, counted up from the bottom."""
    column: np.ndarray
    """Position in its row, counted from the left seen from outside."""
    origin_m: np.ndarray
    """(N, 3) cell centres on the surface [m]."""
    rotation: np.ndarray
    """(N, 3, 3) panel frames: columns x (right), y (up, a corner), z (outward normal)."""
    circumradius_m: np.ndarray
    """Mean distance from the centre to the six corners on the surface [m]."""
    corners_m: np.ndarray
    """(N, 6, 3) the corners on the surface, at 30 + 60 j degrees in the panel frame [m]."""
    curvature_flap_per_m: np.ndarray
    """(N, 3) signed normal curvature along each flap axis, convex positive [1/m]."""

    def __len__(self) -> int:
        return self.row.shape[0]

    @property
    def gaussian_sign(self) -> IntArray:
        """Sign of the Gaussian curvature from the three flap-axis curvatures: -1, 0 or +1."""
        a, b, c = second_form(self.curvature_flap_per_m, FLAP_AXIS_AZIMUTHS_RAD)
        determinant = a * c - b * b
        return np.sign(np.where(np.abs(determinant) < 1e-9, 0.0, determinant)).astype(int)


def second_form(curvatures: npt.ArrayLike,
                azimuths_rad: npt.ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Coefficients ``a, b, c`` of ``kappa(theta) = a cos^2 + 2 b cos sin + c sin^2``.

    ``curvatures`` (N, 3) are normal curvatures along three distinct directions
    ``azimuths_rad`` (3,) (Euler's formula: three directions fix the second fundamental form).
    """
    cos, sin = np.cos(azimuths_rad), np.sin(azimuths_rad)
    system = np.stack([cos * cos, 2 * cos * sin, sin * sin], axis=-1)
    solved = np.linalg.solve(system, np.asarray(curvatures, dtype=float).T)
    return solved[0], solved[1], solved[2]


def lattice(s_range: tuple[float, float], t_range: tuple[float, float],
            radius_m: float) -> tuple[FloatArray, IntArray, IntArray]:
    """Centres (N, 2), rows and columns of the centred lattice of whole cells in a rectangle.

    ``s_range``, ``t_range`` are the rectangle's ``(low, high)`` [m]; cells have a corner
    along ``+t``. Returns empty arrays when no cell fits.
    """
    pitch, rise = _SQRT3 * radius_m, 1.5 * radius_m
    width, height = s_range[1] - s_range[0], t_range[1] - t_range[0]
    rows = int(math.floor((height - 2 * radius_m) / rise + 1e-9)) + 1 if height >= 2 * radius_m \
        else 0
    full = int(math.floor(width / pitch + 1e-9))  # cells in a row of layout 'alternate'
    even = int(math.floor(width / pitch - 0.5 + 1e-9))  # layout 'staggered': all rows alike
    if rows > MAX_LINES or max(full, even) > MAX_LINES:
        raise ValueError(f'the surface holds {rows} rows of up to {max(full, even)} hexagonal '
                         f'cells of circumradius {radius_m:g} m; at most {MAX_LINES} of each '
                         f'(panel ids carry two digits)')
    staggered = [even] * rows
    alternate = [full if j % 2 == 0 else full - 1 for j in range(rows)]
    counts, shifted = (staggered, True) if sum(staggered) >= sum(alternate) else (alternate,
                                                                                  False)
    s_middle, t_middle = sum(s_range) / 2, sum(t_range) / 2
    centres, row, column = [], [], []
    for j, count in enumerate(counts):
        if count <= 0:
            continue
        offset = (0.25 if j % 2 == 0 else -0.25) * pitch if shifted else 0.0
        for i in range(count):
            centres.append((s_middle + offset + (i - (count - 1) / 2) * pitch,
                            t_middle + (j - (rows - 1) / 2) * rise))
            row.append(j)
            column.append(i)
    return (np.array(centres, dtype=float).reshape(-1, 2), np.array(row, dtype=int),
            np.array(column, dtype=int))


def corner_offsets(radius_m: float) -> FloatArray:
    """Corner offsets (6, 2) of a hexagon with a corner along +y: azimuths 30 + 60 j deg."""
    angle = np.radians(30.0 + 60.0 * np.arange(6))
    return radius_m * np.stack([np.cos(angle), np.sin(angle)], axis=-1)


class Development:
    """The developed parameter plane of a parametric surface: arc lengths along its centre lines.

    ``s(u)`` is the arc length along ``v = 0`` from ``u = 0``, ``t(v)`` along ``u = 0``;
    :meth:`parameters` maps ``(s, t)`` back to ``(u, v)``.
    """

    def __init__(self, surface: ParametricSurface) -> None:
        self.surface = surface
        u = np.linspace(-surface.width_m / 2, surface.width_m / 2, _ARC_SAMPLES)
        v = np.linspace(-surface.height_m / 2, surface.height_m / 2, _ARC_SAMPLES)
        self._u, self._s = u, _arc_length(surface.point(u, np.zeros_like(u)), u)
        self._v, self._t = v, _arc_length(surface.point(np.zeros_like(v), v), v)

    @property
    def s_range(self) -> tuple[float, float]:
        """Developed extent along the horizontal centre line ``(low, high)`` [m]."""
        return self._s[0], self._s[-1]

    @property
    def t_range(self) -> tuple[float, float]:
        """Developed extent along the vertical centre line ``(low, high)`` [m]."""
        return self._t[0], self._t[-1]

    def parameters(self, s: FloatArray, t: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Surface parameters ``(u, v)`` [m] of developed coordinates ``(s, t)`` [m]."""
        return np.interp(s, self._s, self._u), np.interp(t, self._t, self._v)


def _arc_length(points: FloatArray, parameter: FloatArray) -> FloatArray:
    """Cumulative arc length along sampled points, zero where the parameter is zero."""
    steps = np.linalg.norm(np.diff(points, axis=0), axis=-1)
    length = np.concatenate([[0.0], np.cumsum(steps)])
    return length - np.interp(0.0, parameter, length)


def tessellate(surface: ParametricSurface, cell_circumradius_m: float) -> HexagonCells:
    """Hexagonal cells of circumradius ``cell_circumradius_m`` [m] on a parametric surface.

    See the module docstring for the layout, the frames and the edge rule.
    """
    development = Development(surface)
    centres, row, column = lattice(development.s_range, development.t_range,
                                   cell_circumradius_m)
    if not len(centres):
        raise ValueError(f'no whole hexagonal cell of circumradius {cell_circumradius_m:g} m '
                         f'fits on the {surface.width_m:g} x {surface.height_m:g} m surface')
    u, v = development.parameters(centres[:, 0], centres[:, 1])
    origin = surface.point(u, v)
    tangent_u, tangent_v, normal = surface.frame_vectors(u, v)
    rotation = np.stack([tangent_u, tangent_v, normal], axis=-1)
    corner = centres[:, None, :] + corner_offsets(cell_circumradius_m)[None]
    corner_u, corner_v = development.parameters(corner[..., 0], corner[..., 1])
    corners = surface.point(corner_u, corner_v)
    radius = np.linalg.norm(corners - origin[:, None, :], axis=-1).mean(axis=-1)
    curvature = np.stack([_normal_curvature(surface, u, v, rotation, azimuth)
                          for azimuth in FLAP_AXIS_AZIMUTHS_RAD], axis=-1)
    return HexagonCells(row=row, column=column, origin_m=origin, rotation=rotation,
                        circumradius_m=radius, corners_m=corners,
                        curvature_flap_per_m=curvature)


def _normal_curvature(surface: ParametricSurface, u: FloatOrArray, v: FloatOrArray,
                      rotation: FloatArray, azimuth_rad: float, step: float = 1e-4) -> FloatArray:
    """Return normal curvatures (N,) along the tangent ``azimuth_rad`` from each frame's x."""
    direction = math.cos(azimuth_rad) * rotation[..., 0] + math.sin(azimuth_rad) * rotation[..., 1]
    d_u = (surface.point(u + step, v) - surface.point(u - step, v)) / (2 * step)
    d_v = (surface.point(u, v + step) - surface.point(u, v - step)) / (2 * step)
    jacobian = np.stack([d_u, d_v], axis=-1)  # (N, 3, 2)
    du, dv = np.einsum('nij,nj->ni', np.linalg.pinv(jacobian), direction).T
    return surface.normal_curvature(u, v, du, dv, rotation[..., 2])


def obj_hexagon_cells(vertices: FloatArray, faces: IntArray, lines: IntArray,
                      source: PathLike) -> HexagonCells:
    """Cells from an OBJ mesh of hexagonal faces: one per face.

    ``faces`` (F, 6) index ``vertices`` (M, 3) in the facade frame [m]; ``lines`` (F,) are the
    faces' line numbers in ``source`` (for messages). Each face must be a near-regular
    hexagon (corner radii and sides within :data:`OBJ_TOLERANCE` of the mean radius, corners
    60 degrees apart within that fraction, corners within :data:`OBJ_PLANARITY` of the
    best-fit plane); ``ValueError`` names the first face that is not. The frame sits at the
    face's centroid, ``z`` the best-fit plane's normal (outward, ``+e3``), ``y`` toward the
    corner nearest to up; the size is the mean circumradius; the normal curvature along a
    direction comes from the turn of the face normals to the neighbours across the edges.
    """
    corners = vertices[faces]
    centre = corners.mean(axis=1)
    rotation = np.empty((len(faces), 3, 3))
    radius = np.empty(len(faces))
    for index in range(len(faces)):
        where = f'{source}:{lines[index]}: face {index + 1}'
        rotation[index], radius[index] = _face_frame(corners[index] - centre[index], where)
    curvature = _neighbour_curvature(centre, rotation, faces)
    row, column = _rows_and_columns(centre, radius)
    local = np.einsum('fci,fij->fcj', corners - centre[:, None], rotation)
    azimuth = np.mod(np.arctan2(local[..., 1], local[..., 0]) - math.radians(30.0) + 0.5,
                     2 * math.pi)  # counter-clockwise from the corner at 30 degrees
    ordered = np.take_along_axis(corners, np.argsort(azimuth, axis=1)[..., None], axis=1)
    return HexagonCells(row=row, column=column, origin_m=centre, rotation=rotation,
                        circumradius_m=radius, corners_m=ordered,
                        curvature_flap_per_m=curvature)


def _face_frame(offsets: FloatArray, where: str) -> tuple[FloatArray, float]:
    """Frame (3, 3) and mean circumradius of one face given corner offsets from its centroid."""
    normal = np.linalg.svd(offsets)[2][-1]
    normal = normal if normal[2] >= 0 else -normal
    flat = offsets - np.outer(offsets @ normal, normal)
    radii = np.linalg.norm(flat, axis=-1)
    mean = radii.mean()
    if mean < 1e-9:
        raise ValueError(f'{where} is degenerate (all corners at its centre)')
    worst = int(np.argmax(np.abs(offsets @ normal)))
    if abs(offsets[worst] @ normal) > OBJ_PLANARITY * mean:
        raise ValueError(f'{where} is not a near-regular hexagon: corner {worst + 1} lies '
                         f'{abs(offsets[worst] @ normal) / mean:.2f} R off its plane '
                         f'(at most {OBJ_PLANARITY:g} R)')
    _check_regular(flat, radii, mean, normal, where)
    up = np.array([0.0, 1.0, 0.0])
    y_axis = flat[int(np.argmax(flat @ up / radii))] / radii[int(np.argmax(flat @ up / radii))]
    return np.stack([np.cross(y_axis, normal), y_axis, normal], axis=-1), mean


def _check_regular(flat: FloatArray, radii: FloatArray, mean: float, normal: FloatArray,
                   where: str) -> None:
    worst = int(np.argmax(np.abs(radii / mean - 1)))
    if abs(radii[worst] / mean - 1) > OBJ_TOLERANCE:
        raise ValueError(f'{where} is not a near-regular hexagon: corner {worst + 1} is '
                         f'{radii[worst] / mean:.2f} R from its centre ({1 - OBJ_TOLERANCE:g} to '
                         f'{1 + OBJ_TOLERANCE:g} R allowed)')
    sides = np.linalg.norm(np.roll(flat, -1, axis=0) - flat, axis=-1) / mean
    worst = int(np.argmax(np.abs(sides - 1)))
    if abs(sides[worst] - 1) > OBJ_TOLERANCE:
        raise ValueError(f'{where} is not a near-regular hexagon: side {worst + 1} is '
                         f'{sides[worst]:.2f} R long ({1 - OBJ_TOLERANCE:g} to '
                         f'{1 + OBJ_TOLERANCE:g} R allowed)')
    following = np.roll(flat, -1, axis=0)
    turn = np.arctan2(np.cross(flat, following) @ normal, np.sum(flat * following, axis=-1))
    turn = turn * np.sign(turn.sum())  # either winding order
    worst = int(np.argmax(np.abs(turn - math.pi / 3)))
    if abs(turn[worst] - math.pi / 3) > OBJ_TOLERANCE * math.pi / 3:
        raise ValueError(f'{where} is not a near-regular hexagon: corners {worst + 1} and '
                         f'{(worst + 1) % 6 + 1} are {math.degrees(turn[worst]):.0f} deg apart '
                         f'around its centre (60 deg expected)')


def _neighbour_curvature(centre: FloatArray, rotation: FloatArray, faces: IntArray) -> FloatArray:
    """Estimate normal curvatures (F, 3) along the flap axes from the normals' turn.

    Across each shared edge the turn of the normal over the centre distance is the normal
    curvature along the line to the neighbour (convex positive, as for the quad mesh). The
    three edge directions (0, 60 and 120 degrees, either side) fix the second fundamental
    form; a direction without a neighbour (a boundary face) counts as flat.
    """
    owners: dict[tuple[int, int], list[int]] = {}
    for face, corners in enumerate(faces):
        for a, b in zip(corners, np.roll(corners, -1)):
            owners.setdefault((min(a, b), max(a, b)), []).append(face)
    normal = rotation[..., 2]
    total = np.zeros((len(faces), 3))
    count = np.zeros((len(faces), 3))
    for pair in owners.values():
        if len(pair) != 2:
            continue
        offset = centre[pair[1]] - centre[pair[0]]
        turn = np.dot(normal[pair[1]] - normal[pair[0]], offset) / np.dot(offset, offset)
        for face in pair:
            azimuth = math.atan2(offset @ rotation[face, :, 1], offset @ rotation[face, :, 0])
            line = int(round(math.degrees(azimuth) / 60.0)) % 3
            total[face, line] += turn
            count[face, line] += 1
    edge_curvature = np.divide(total, count, out=np.zeros_like(total), where=count > 0)
    a, b, c = second_form(edge_curvature, np.radians([0.0, 60.0, 120.0]))
    cos, sin = np.cos(FLAP_AXIS_AZIMUTHS_RAD), np.sin(FLAP_AXIS_AZIMUTHS_RAD)
    return (a[:, None] * cos * cos + 2 * b[:, None] * cos * sin + c[:, None] * sin * sin)


def _rows_and_columns(centre: FloatArray, radius: FloatArray) -> tuple[IntArray, IntArray]:
    """Rows (centres within half a radius in height) up from the bottom; columns left to right."""
    order = np.argsort(centre[:, 1], kind='stable')
    row = np.empty(len(centre), dtype=int)
    current, last = 0, None
    for index in order:
        if last is not None and centre[index, 1] - last > 0.5 * radius.mean():
            current += 1
        row[index], last = current, centre[index, 1]
    column = np.empty(len(centre), dtype=int)
    for line in range(current + 1):
        members = np.flatnonzero(row == line)
        column[members[np.argsort(centre[members, 0], kind='stable')]] = np.arange(members.size)
    if current + 1 > MAX_LINES or column.max() + 1 > MAX_LINES:
        raise ValueError(f'the mesh has {current + 1} rows of up to {column.max() + 1} faces; '
                         f'at most {MAX_LINES} of each (panel ids carry two digits)')
    return row, column
