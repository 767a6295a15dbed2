"""Triangle meshes of folded panels, computed for many panels at once.

Each panel's mesh has three grid blocks that share one topology: the mid-rib, the +y flap and
the -y flap. Rows run along the mid-rib (``stations`` arc-length stations from support B to
support C); columns run across a block. The mid-rib's outer columns and each flap's first
column lie on the crease, so every triangle stays on one side of it. Between two stations
the mid-rib is a planar strip (the surface is a cylinder with generators along y) and each flap
strip is its mirror image, so the mesh is an exactly developable polyhedron: every edge keeps
its length in the flat pattern of :func:`flat_coordinates`.
The crease vertices are duplicated between the mid-rib and the flap so each side keeps its
own normal, as a sharp fold should render.

Vertices are in the panel frame (x along the mid-rib, y across, z out of the facade) [m].
Triangles wind counter-clockwise seen from the sheet's front side (the +z side when open), and
the vertex normals point out of that side.
"""

from dataclasses import dataclass
from typing import Any, Iterable, Optional

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import FloatArray, FloatOrArray, IntArray
from flectofold_model.kinematics import elastica
from flectofold_model.kinematics.panel import PanelBatch
from flectofold_model.kinematics.reflection import crease_flat_y, fold_plane, reflect


@dataclass(frozen=True)
class FoldMesh:
    """Meshes of N panels; the faces are shared by all of them."""

    vertices: np.ndarray
    """(N, V, 3) vertex positions in the panel frame [m]."""
    normals: np.ndarray
    """(N, V, 3) unit vertex normals on the front side."""
    faces: np.ndarray
    """(F, 3) vertex indices, counter-clockwise seen from the front."""


def check_counts(topology: object, least_counts: Iterable[tuple[str, int]]) -> None:
    """Refuse a topology field that is not an integer of at least its least count."""
    for name, least in least_counts:
        value = getattr(topology, name)
        is_integer = isinstance(value, (int, np.integer)) and not isinstance(value, bool)
        if not is_integer or value < least:
            raise ValueError(f'{name} must be an integer of at least {least}, got {value!r}')


@dataclass(frozen=True)
class MeshTopology:
    """Grid resolution, vertex layout and faces of a panel mesh."""

    stations: int
    midrib_columns: int
    flap_columns: int

    def __post_init__(self) -> None:
        check_counts(self, (('stations', 2), ('midrib_columns', 2), ('flap_columns', 2)))

    @property
    def vertex_count(self) -> int:
        """Vertices per panel."""
        return self.stations * (self.midrib_columns + 2 * self.flap_columns)

    @property
    def midrib(self) -> slice:
        """Slice of the mid-rib's vertices."""
        return slice(0, self.stations * self.midrib_columns)

    def flap(self, side: int) -> slice:
        """Slice of the vertices of the flap on ``side`` (+1 or -1)."""
        start = self.stations * (self.midrib_columns + (0 if side > 0 else self.flap_columns))
        return slice(start, start + self.stations * self.flap_columns)

    @property
    def midrib_fractions(self) -> FloatArray:
        """Column positions across the mid-rib: -1 on the -y crease, +1 on the +y crease."""
        return np.linspace(-1.0, 1.0, self.midrib_columns)

    @property
    def flap_fractions(self) -> FloatArray:
        """Column positions across a flap: 0 on the crease, 1 on the panel edge."""
        return np.linspace(0.0, 1.0, self.flap_columns)

    @property
    def station_fractions(self) -> FloatArray:
        """Row positions along the mid-rib as fractions of its length, -1/2 ... 1/2.

        Exactly antisymmetric, so a shape evaluated on one half mirrors onto the other.
        """
        even = np.linspace(-0.5, 0.5, self.stations)
        return (even - even[::-1]) / 2

    @property
    def faces(self) -> npt.NDArray[np.int32]:
        """(F, 3) int32 triangle indices of one panel."""
        blocks = [_grid_faces(self.stations, self.midrib_columns, 0, flip=False),
                  _grid_faces(self.stations, self.flap_columns, self.flap(+1).start, flip=False),
                  _grid_faces(self.stations, self.flap_columns, self.flap(-1).start, flip=True)]
        return np.concatenate(blocks).astype(np.int32)


def _grid_faces(rows: int, columns: int, base: int, flip: bool) -> IntArray:
    index = base + np.arange(rows * columns).reshape(rows, columns)
    a, b = index[:-1, :-1], index[1:, :-1]
    c, d = index[1:, 1:], index[:-1, 1:]
    first = np.stack([a, b, c], axis=-1).reshape(-1, 3)
    second = np.stack([a, c, d], axis=-1).reshape(-1, 3)
    faces = np.concatenate([first, second])
    return faces[:, ::-1] if flip else faces


#: A realistic resolution for display: 21 stations x (7 + 2 x 17) columns = 861 vertices.
DEFAULT_TOPOLOGY = MeshTopology(stations=21, midrib_columns=7, flap_columns=17)


def flat_coordinates(batch: PanelBatch, k: npt.ArrayLike,
                     topology: MeshTopology = DEFAULT_TOPOLOGY) -> FloatArray:
    """(N, V, 2) coordinates of every vertex in the unfolded sheet [m] (x along, y across).

    Along the mid-rib a vertex sits at the polyline length of the folded mid-rib from mid-span
    (which tends to the arc length as the stations get denser); across, at its flat y. The
    crease vertices follow the reflected crease, which depends on the fold state ``k``.
    """
    k = np.broadcast_to(np.asarray(k, dtype=np.float64), (len(batch),))
    shape = _station_shape(batch, k, topology)
    crease_y = crease_flat_y(batch, shape.normalized_height)
    chords = np.hypot(np.diff(shape.x_m, axis=-1), np.diff(shape.z_m, axis=-1))
    polyline = np.concatenate([np.zeros((len(batch), 1)), np.cumsum(chords, axis=-1)], axis=-1)
    stations = polyline - polyline[:, -1:] / 2
    flat = np.empty((len(batch), topology.vertex_count, 2))
    midrib = _block(flat, topology.midrib, topology.midrib_columns)
    midrib[..., 0] = stations[..., None]
    midrib[..., 1] = crease_y[..., None] * topology.midrib_fractions
    for side in (+1, -1):
        flap = _block(flat, topology.flap(side), topology.flap_columns)
        flap[..., 0] = stations[..., None]
        flap[..., 1] = side * _flap_flat_y(batch, crease_y, topology)
    return flat


def fold_mesh(batch: PanelBatch, k: npt.ArrayLike, topology: MeshTopology = DEFAULT_TOPOLOGY,
              dtype: npt.DTypeLike = np.float64, out: Optional[FoldMesh] = None) -> FoldMesh:
    """Folded meshes of every panel of ``batch`` at elastica moduli ``k`` (shape ``(N,)``).

    Every row of a block is straight (a generator of the mid-rib cylinder, or its mirror
    image), so each row follows from its two end points. ``out``, a :class:`FoldMesh` of an
    earlier call with the same batch size, topology and dtype, is refilled in place, which
    saves allocating (and page-faulting) fresh arrays on every frame.
    """
    if not isinstance(batch, PanelBatch):
        raise TypeError(f'fold_mesh needs a PanelBatch, got {type(batch).__name__}')
    k = np.broadcast_to(np.asarray(k, dtype=np.float64), (len(batch),))
    vertices, normals = output_arrays(out, (len(batch), topology.vertex_count, 3), dtype)
    shape = _station_shape(batch, k, topology)
    crease_y = crease_flat_y(batch, shape.normalized_height)
    front = np.stack([-np.sin(shape.slope_rad), np.zeros_like(shape.slope_rad),
                      np.cos(shape.slope_rad)], axis=-1)

    def on_midrib(y: FloatOrArray) -> FloatArray:
        return np.stack([shape.x_m, np.broadcast_to(y, shape.x_m.shape), shape.z_m], axis=-1)

    _fill_rows(_block(vertices, topology.midrib, topology.midrib_columns),
               on_midrib(-crease_y), on_midrib(crease_y), (topology.midrib_fractions + 1) / 2)
    _fill_normals(_block(normals, topology.midrib, topology.midrib_columns), front)

    sag = elastica.sag_from_k(k, batch.length_m)
    for side in (+1, -1):
        normal, offset = fold_plane(batch, sag, side)
        normal, offset = normal[:, None, :], offset[:, None]
        _fill_rows(_block(vertices, topology.flap(side), topology.flap_columns),
                   reflect(on_midrib(side * crease_y), normal, offset),
                   reflect(on_midrib(side * batch.width_m[:, None] / 2), normal, offset),
                   topology.flap_fractions)
        # A mirror image turns the sheet over: the flap's front is the mirrored back.
        along = np.sum(front * normal, axis=-1, keepdims=True)
        _fill_normals(_block(normals, topology.flap(side), topology.flap_columns),
                      2 * along * normal - front)
    return FoldMesh(vertices=vertices, normals=normals, faces=topology.faces)


def _station_shape(batch: PanelBatch, k: FloatArray,
                   topology: MeshTopology) -> elastica.ElasticaShape:
    """Evaluate the mid-rib elastica on one half of the stations and mirror it.

    The pinned elastica is symmetric about mid-span: ``x`` and the slope change sign, ``z``
    does not. Halving the elliptic-function evaluations matters on the per-frame path.
    """
    fractions = topology.station_fractions
    upper = fractions.size // 2
    half = elastica.elastica_shape(k, batch.length_m, batch.length_m[:, None] * fractions[upper:])
    source = np.abs(np.arange(fractions.size) - upper + (fractions.size % 2 == 0) * 0.5)
    index = np.floor(source).astype(np.intp)
    sign = np.where(np.arange(fractions.size) < upper, -1.0, 1.0)
    return elastica.ElasticaShape(x_m=sign * half.x_m[:, index], z_m=half.z_m[:, index],
                                  slope_rad=sign * half.slope_rad[:, index],
                                  normalized_height=half.normalized_height[:, index])


def output_arrays(out: Optional[FoldMesh], shape: tuple[int, ...],
                  dtype: npt.DTypeLike) -> tuple[npt.NDArray[Any], npt.NDArray[Any]]:
    """Vertex and normal arrays of ``shape``: fresh, or those of ``out`` (a checked FoldMesh)."""
    if out is None:
        return np.empty(shape, dtype=dtype), np.empty(shape, dtype=dtype)
    if not isinstance(out, FoldMesh):
        raise TypeError(f'out must be a FoldMesh, got {type(out).__name__}')
    for array in (out.vertices, out.normals):
        if array.shape != shape or array.dtype != np.dtype(dtype):
            raise ValueError(f'out holds {array.dtype} arrays of shape {array.shape}; this call '
                             f'needs {np.dtype(dtype)} arrays of shape {shape}')
    return out.vertices, out.normals


def _fill_rows(block: npt.NDArray[Any], start: FloatArray, end: FloatArray,
               fractions: FloatArray) -> None:
    """Fill ``block`` (N, rows, columns, 3) with the points ``start + (end - start) t``."""
    coefficients = np.stack([start, end - start], axis=-2).astype(block.dtype)
    basis = np.stack([np.ones_like(fractions), fractions], axis=-1).astype(block.dtype)
    np.matmul(basis, coefficients, out=block)


def _fill_normals(block: npt.NDArray[Any], row_normals: FloatArray) -> None:
    """Give every vertex of a row (N, rows, columns, 3) its row's normal (N, rows, 3)."""
    for axis in range(3):
        block[..., axis] = row_normals[:, :, None, axis]


def _flap_flat_y(batch: PanelBatch, crease_y: FloatArray,
                 topology: MeshTopology) -> FloatArray:
    edge = batch.width_m[:, None, None] / 2
    return crease_y[..., None] + (edge - crease_y[..., None]) * topology.flap_fractions


def _block(array: npt.NDArray[Any], vertex_slice: slice, columns: int) -> npt.NDArray[Any]:
    """View of a vertex block as ``(N, stations, columns, dims)``."""
    block = array[:, vertex_slice]
    return block.reshape(array.shape[0], -1, columns, array.shape[-1])
