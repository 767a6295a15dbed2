"""Facade surfaces and their tessellation into Flectofold patches.

Surfaces live in the **facade frame**: ``e1`` along the facade to the right as seen from
outside, ``e2`` up, ``e3`` the outward normal at the surface's centre; metres. A parametric
surface maps ``(u, v)`` (metres along ``e1`` and ``e2``) to a point; an OBJ quad mesh gives its
patches directly.

Signed normal curvatures are positive where the surface is **convex** seen from outside
(it curves away from its outward normal). A dome is convex both ways (synclastic, Gaussian
curvature ``K > 0``), a saddle is convex one way and concave the other (anticlastic,
``K < 0``).

Per patch the tessellation gives the panel frame (origin at the patch centre on the surface,
``z`` the outward normal, ``x`` along the mid-rib, ``y = z x x``), the panel size and the normal
curvatures along ``x`` and ``y``.
"""

from dataclasses import dataclass
import math
from pathlib import Path
from typing import Callable

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import FloatArray, FloatOrArray, IntArray, PathLike

#: The height ``w(u, v)`` of a parametric surface over its parameters [m].
Depth = Callable[[FloatArray, FloatArray], FloatArray]


@dataclass(frozen=True)
class Patches:
    """The patches of a tessellated surface, in the facade frame; arrays over patches."""

    row: np.ndarray
    column: np.ndarray
    origin_m: np.ndarray
    """(N, 3) patch centres on the surface [m]."""
    rotation: np.ndarray
    """(N, 3, 3) panel frames: columns are x (mid-rib), y and z (outward normal)."""
    length_m: np.ndarray
    """Patch extent along x [m]."""
    width_m: np.ndarray
    """Patch extent along y [m]."""
    curvature_x_per_m: np.ndarray
    """Signed normal curvature along x (convex positive) [1/m]."""
    curvature_y_per_m: np.ndarray
    """Signed normal curvature along y (convex positive) [1/m]."""

    def __len__(self) -> int:
        return self.row.shape[0]

    @property
    def gaussian_sign(self) -> IntArray:
        """Sign of the Gaussian curvature estimate per patch: -1 anticlastic, +1 synclastic."""
        product = self.curvature_x_per_m * self.curvature_y_per_m
        return np.sign(np.where(np.abs(product) < 1e-9, 0.0, product)).astype(int)


class ParametricSurface:
    """A surface ``p(u, v) = u e1 + v e2 + w(u, v) e3`` for ``|u| <= W/2, |v| <= H/2``."""

    def __init__(self, kind: str, width_m: float, height_m: float, depth: Depth) -> None:
        self.kind = kind
        self.width_m = width_m
        self.height_m = height_m
        self._depth = depth

    def point(self, u: npt.ArrayLike, v: npt.ArrayLike) -> FloatArray:
        """Points (..., 3) of the surface at parameters ``u``, ``v`` [m]."""
        u, v = np.broadcast_arrays(np.asarray(u, dtype=float), np.asarray(v, dtype=float))
        return np.stack([u, v, self._depth(u, v)], axis=-1)

    def tessellate(self, rows: int, columns: int, midrib_along: str = 'v') -> Patches:
        """Split into ``rows x columns`` equal parameter cells, one patch each.

        Rows count upward from the bottom, columns rightward. ``midrib_along`` is ``'v'``
        (mid-ribs run up the facade), ``'u'`` (across) or ``'auto'`` (per patch, whichever
        direction is more convex, which gives the panel more pre-fold).
        """
        row, column = np.meshgrid(np.arange(rows), np.arange(columns), indexing='ij')
        row, column = row.ravel(), column.ravel()
        du, dv = self.width_m / columns, self.height_m / rows
        u = -self.width_m / 2 + (column + 0.5) * du
        v = -self.height_m / 2 + (row + 0.5) * dv
        centre = self.point(u, v)
        tangent_u, tangent_v, normal = self.frame_vectors(u, v)
        curvature_u = self.normal_curvature(u, v, 1.0, 0.0, normal)
        curvature_v = self.normal_curvature(u, v, 0.0, 1.0, normal)
        span_u = np.linalg.norm(self.point(u + du / 2, v) - self.point(u - du / 2, v), axis=-1)
        span_v = np.linalg.norm(self.point(u, v + dv / 2) - self.point(u, v - dv / 2), axis=-1)
        if midrib_along == 'auto':
            along_v = curvature_v >= curvature_u
        elif midrib_along in ('u', 'v'):
            along_v = np.full(u.shape, midrib_along == 'v')
        else:
            raise ValueError(f"midrib_along must be 'u', 'v' or 'auto', got {midrib_along!r}")
        x_axis = np.where(along_v[:, None], tangent_v, tangent_u)
        y_axis = np.cross(normal, x_axis)
        return Patches(
            row=row, column=column, origin_m=centre,
            rotation=np.stack([x_axis, y_axis, normal], axis=-1),
            length_m=np.where(along_v, span_v, span_u), width_m=np.where(along_v, span_u, span_v),
            curvature_x_per_m=np.where(along_v, curvature_v, curvature_u),
            curvature_y_per_m=np.where(along_v, curvature_u, curvature_v))

    def grid_quads(self, rows: int, columns: int) -> tuple[FloatArray, IntArray]:
        """Return the cell grid of :meth:`tessellate` as a quad mesh on the surface (facade frame).

        Returns vertices ``((rows + 1) (columns + 1), 3)`` [m], the grid nodes row by row from
        the bottom left, and quads ``(rows columns, 4)``, counter-clockwise seen from outside,
        in :meth:`tessellate`'s patch order. Neighbouring quads share their corner vertices.
        """
        u = np.linspace(-self.width_m / 2, self.width_m / 2, columns + 1)
        v = np.linspace(-self.height_m / 2, self.height_m / 2, rows + 1)
        vertices = self.point(*np.meshgrid(u, v, indexing='xy')).reshape(-1, 3)
        node = np.arange((rows + 1) * (columns + 1)).reshape(rows + 1, columns + 1)
        quads = np.stack([node[:-1, :-1], node[:-1, 1:], node[1:, 1:], node[1:, :-1]], axis=-1)
        return vertices, quads.reshape(-1, 4)

    def frame_vectors(self, u: FloatOrArray, v: FloatOrArray,
                      step: float = 1e-4) -> tuple[FloatArray, FloatArray, FloatArray]:
        d_u = (self.point(u + step, v) - self.point(u - step, v)) / (2 * step)
        d_v = (self.point(u, v + step) - self.point(u, v - step)) / (2 * step)
        normal = _unit(np.cross(d_u, d_v))
        tangent_v = _unit(d_v - np.sum(d_v * normal, axis=-1, keepdims=True) * normal)
        tangent_u = np.cross(tangent_v, normal)
        return tangent_u, tangent_v, normal

    def normal_curvature(self, u: FloatOrArray, v: FloatOrArray, du: FloatOrArray,
                         dv: FloatOrArray, normal: FloatArray, step: float = 1e-3) -> FloatArray:
        ahead = self.point(u + du * step, v + dv * step)
        behind = self.point(u - du * step, v - dv * step)
        middle = self.point(u, v)
        second = (ahead - 2 * middle + behind) / step**2
        first = (ahead - behind) / (2 * step)
        # Convex seen from outside: the surface bends away from its outward normal.
        return -np.sum(second * normal, axis=-1) / np.sum(first * first, axis=-1)


def plane(width_m: float, height_m: float) -> ParametricSurface:
    """Build a flat facade."""
    return ParametricSurface('plane', width_m, height_m, lambda u, v: np.zeros_like(u))


def cylinder(width_m: float, height_m: float, radius_m: float) -> ParametricSurface:
    """Build a vertical cylinder of signed radius (positive: convex, bulging out)."""
    radius = float(radius_m)
    if abs(radius) <= width_m / 2:
        raise ValueError(f'cylinder radius_m={radius:g} m must exceed half the width '
                         f'({width_m / 2:g} m) in magnitude')
    sign = math.copysign(1.0, radius)
    return ParametricSurface('cylinder', width_m, height_m,
                             lambda u, v: sign * (np.sqrt(radius**2 - u**2) - abs(radius)))


def dome(width_m: float, height_m: float, semi_axis_u_m: float, semi_axis_v_m: float,
         depth_m: float) -> ParametricSurface:
    """Build the cap of an ellipsoid (synclastic): semi-axes along ``e1``, ``e2``, and depth."""
    for name, value, least in (('semi_axis_u_m', semi_axis_u_m, width_m / 2),
                               ('semi_axis_v_m', semi_axis_v_m, height_m / 2)):
        if value <= least:
            raise ValueError(f'dome {name}={value:g} m must exceed half the facade extent '
                             f'({least:g} m) so the cap covers it')
    if depth_m <= 0:
        raise ValueError(f'dome depth_m must be positive, got {depth_m:g} m')

    def depth(u: FloatArray, v: FloatArray) -> FloatArray:
        return depth_m * (np.sqrt(1.0 - (u / semi_axis_u_m)**2 - (v / semi_axis_v_m)**2) - 1.0)
    return ParametricSurface('dome', width_m, height_m, depth)


def saddle(width_m: float, height_m: float, curvature_u_per_m: float,
           curvature_v_per_m: float) -> ParametricSurface:
    """Build a hyperbolic paraboloid ``w = -(k_u u**2 + k_v v**2) / 2`` (anticlastic).

    The signed curvatures must differ in sign.
    """
    if curvature_u_per_m * curvature_v_per_m >= 0:
        raise ValueError('a saddle needs curvatures of opposite sign, got '
                         f'{curvature_u_per_m:g} and {curvature_v_per_m:g} 1/m')
    return ParametricSurface(
        'saddle', width_m, height_m,
        lambda u, v: -(curvature_u_per_m * u**2 + curvature_v_per_m * v**2) / 2)


def read_obj_quads(path: PathLike) -> tuple[FloatArray, IntArray]:
    """Vertices (M, 3) and quad faces (Q, 4) of an OBJ file [facade frame, metres].

    Only ``v`` and ``f`` lines matter; face entries may carry ``/vt/vn`` indices, negative
    indices count from the end. Every face must be a quad.
    """
    vertices, faces, _ = read_obj_faces(path, 4)
    return vertices, faces


#: What a face of each corner count makes, for the messages.
_FACE_NAMES = {4: ('quad', 'only quad faces make panels'),
               6: ('hexagonal', 'a hexagon facade takes only hexagonal faces (a facade is all '
                                'quad or all hexagon panels)')}


def read_obj_faces(path: PathLike, corners: int) -> tuple[FloatArray, IntArray, IntArray]:
    """Vertices (M, 3), faces (F, corners) and the faces' line numbers (F,) of an OBJ file.

    As :func:`read_obj_quads`, for faces of ``corners`` corners (4 or 6): every face must have
    that many.
    """
    name, rule = _FACE_NAMES[corners]
    vertices: list[list[float]] = []
    faces: list[list[int]] = []
    lines: list[int] = []
    try:
        text = Path(path).read_text()
    except OSError as error:
        raise ValueError(f'cannot read the OBJ file: {error}') from None
    for number, line in enumerate(text.splitlines(), start=1):
        fields = line.split('#', 1)[0].split()
        if not fields:
            continue
        if fields[0] == 'v':
            try:
                vertices.append([float(x) for x in fields[1:4]])
            except ValueError:
                raise ValueError(f'{path}:{number}: a vertex needs three numbers') from None
            if len(fields) < 4 or not all(math.isfinite(x) for x in vertices[-1]):
                raise ValueError(f'{path}:{number}: a vertex needs three finite numbers')
        elif fields[0] == 'f':
            if len(fields) != corners + 1:
                raise ValueError(f'{path}:{number}: face {len(faces) + 1}: {rule}, got '
                                 f'{len(fields) - 1} corners')
            try:
                indices = [int(entry.split('/')[0]) for entry in fields[1:]]
            except ValueError:
                raise ValueError(f'{path}:{number}: bad face indices') from None
            faces.append([i - 1 if i > 0 else len(vertices) + i for i in indices])
            lines.append(number)
    if not faces:
        raise ValueError(f'{path}: no {name} faces found')
    indices = np.array(faces)
    if indices.min() < 0 or indices.max() >= len(vertices):
        raise ValueError(f'{path}: a face refers to a vertex that does not exist')
    return np.array(vertices), indices, np.array(lines)


def obj_patches(vertices: FloatArray, faces: IntArray, midrib_along: str = 'v') -> Patches:
    """Patches from a quad mesh: one per quad, frames from the quad, curvature from neighbours.

    The normal curvature along a direction is estimated from the change of the face normal to
    the neighbouring quads across the edges that direction crosses. Rows and columns are
    the quad's order along ``e2`` and ``e1`` after sorting by centre (a designer's grid).
    """
    corners = vertices[faces]
    centre = corners.mean(axis=1)
    normal = _unit(np.cross(corners[:, 2] - corners[:, 0], corners[:, 3] - corners[:, 1]))
    normal *= np.where(normal[:, 2:3] < 0, -1.0, 1.0)
    if np.any(np.linalg.norm(np.cross(corners[:, 2] - corners[:, 0],
                                      corners[:, 3] - corners[:, 1]), axis=-1) < 1e-9):
        raise ValueError('the OBJ mesh has a degenerate quad')
    up = np.array([0.0, 1.0, 0.0])
    tangent_v = _unit(up - np.sum(up * normal, axis=-1, keepdims=True) * normal)
    tangent_u = np.cross(tangent_v, normal)
    along_v = midrib_along != 'u'
    x_axis = tangent_v if along_v else tangent_u
    y_axis = np.cross(normal, x_axis)
    edges_x = np.abs(np.einsum('qci,qi->qc', corners - centre[:, None], x_axis))
    edges_y = np.abs(np.einsum('qci,qi->qc', corners - centre[:, None], y_axis))
    curvature_x = _neighbour_curvature(centre, normal, x_axis, faces)
    curvature_y = _neighbour_curvature(centre, normal, y_axis, faces)
    row = np.unique(np.round(centre[:, 1], 3), return_inverse=True)[1]
    column = np.unique(np.round(centre[:, 0], 3), return_inverse=True)[1]
    return Patches(row=row, column=column, origin_m=centre,
                   rotation=np.stack([x_axis, y_axis, normal], axis=-1),
                   length_m=2 * edges_x.max(axis=1), width_m=2 * edges_y.max(axis=1),
                   curvature_x_per_m=curvature_x, curvature_y_per_m=curvature_y)


def _neighbour_curvature(centre: FloatArray, normal: FloatArray, direction: FloatArray,
                         faces: IntArray) -> FloatArray:
    shared: dict[tuple[int, int], list[int]] = {}
    for face, corners in enumerate(faces):
        for a, b in zip(corners, np.roll(corners, -1)):
            shared.setdefault((min(a, b), max(a, b)), []).append(face)
    curvature = np.zeros(len(faces))
    weight = np.zeros(len(faces))
    for pair in shared.values():
        if len(pair) != 2:
            continue
        first, second = pair
        offset = centre[second] - centre[first]
        for face in (first, second):
            along = abs(np.dot(offset, direction[face])) / np.linalg.norm(offset)
            if along < 0.7:  # this edge is crossed by the other direction
                continue
            # Normals spread apart across a convex fold: positive, as for the parametric kinds.
            turn = np.dot(normal[second] - normal[first], offset) / np.dot(offset, offset)
            curvature[face] += turn * along
            weight[face] += along
    return np.divide(curvature, weight, out=np.zeros_like(curvature), where=weight > 0)


def _unit(vectors: FloatArray) -> FloatArray:
    return vectors / np.linalg.norm(vectors, axis=-1, keepdims=True)
