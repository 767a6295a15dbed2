"""A facade's folded panels as triangle meshes in the site frame: one implementation for all.

The Rerun scene (``flectofold_ros.rerun.scene``), the CAD export (``facade_export``) and
anything else that needs the folded facade in space take it from :class:`FacadeMesher`:
each panel's mesh in its panel frame (:func:`~flectofold_model.kinematics.mesh.fold_mesh`
for quad panels, :func:`~flectofold_model.kinematics.hexagon_mesh.hexagon_mesh` for
hexagonal ones) turned by the panel's frame and moved to its origin.

Frame of every vertex here: the site frame ``site_enu`` (x east, y north, z up, metres;
REP-103), ``p_enu = R_panel_to_enu p_panel + origin_enu`` with ``R_panel_to_enu =
R_facade_to_enu R_panel`` (``msg_docs/facade.md``, "Frames").

Two ways from a fold angle to the shape parameter, both the fold model's own map (closure
linear in the apex fold angle, :mod:`~flectofold_model.kinematics.closure_map`):

- :meth:`FacadeMesher.exact_shapes`: the fold model's root finders
  (``shape_from_fold_angle``), for an export;
- :meth:`FacadeMesher.shapes`: the same map from tables, for a viewer that re-meshes many
  panels many times a second (quad: :func:`k_from_sag`, agreeing with the root finder to
  rounding; hexagon: the model's ``shape_table`` interpolated, within the table's step).
"""

from dataclasses import dataclass
from typing import Any, Callable, cast, Optional, Union

import numpy as np
import numpy.typing as npt
from scipy.special import ellipe, ellipk

from flectofold_model._validate import FloatArray, FloatOrArray, IntArray
from flectofold_model.facade.description import Facade
from flectofold_model.kinematics import elastica
from flectofold_model.kinematics.hexagon_closure import HexagonFoldModel
from flectofold_model.kinematics.hexagon_mesh import hexagon_mesh, HexagonTopology
from flectofold_model.kinematics.hexagon_panel import HexagonBatch
from flectofold_model.kinematics.kinds import Batch, fold_model_of, is_topology_for, panel_kind
from flectofold_model.kinematics.mesh import DEFAULT_TOPOLOGY, fold_mesh, FoldMesh, MeshTopology
from flectofold_model.kinematics.panel import PanelBatch
from flectofold_model.kinematics.reflection import sag_for_apex_fold_angle

#: Vertices of the whole facade mesh that :func:`facade_topology` stays within for a viewer.
FACADE_VERTEX_BUDGET = 60_000
#: The budget of an export: the display resolution (21 stations, 12 rulings a sector) up to
#: some 15,000 panels.
EXPORT_VERTEX_BUDGET = 2_000_000
#: Vertices of one panel closer than this are one vertex after :func:`weld` [m].
WELD_TOLERANCE_M = 1e-7
#: A mesh topology of either panel kind.
Topology = Union[MeshTopology, HexagonTopology]


def _sag_ratio(k: FloatOrArray) -> FloatArray:
    """``sag / L = k / K(k^2)`` of the pinned elastica (:func:`elastica.sag_from_k` / L)."""
    return k / ellipk(np.square(k))


_K_TABLE = np.linspace(0.0, elastica.K_MAX, 1025)
_RATIO_TABLE = _sag_ratio(_K_TABLE)


def k_from_sag(sag_m: npt.ArrayLike, length_m: FloatOrArray) -> FloatArray:
    """:func:`elastica.k_from_sag` without its general root finder, for the per-flush path.

    ``sag / L`` depends on ``k`` alone, so a table of it gives ``k`` to about 1e-7, and two
    Newton steps on the closed form (derivative from ``dK/dm = (E - (1 - m) K) / (2 m (1 -
    m))``) take that to rounding. The root finder costs about 10 ms a call whatever the
    panel count, this a few hundred microseconds for 1,000 panels; a test checks they agree.
    """
    ratio = np.clip(np.asarray(sag_m, dtype=float) / length_m, 0.0, _RATIO_TABLE[-1])
    k = np.interp(ratio, _RATIO_TABLE, _K_TABLE)
    for _ in range(2):
        m = np.square(k)
        big_k, big_e = ellipk(m), ellipe(m)
        slope = 1.0 / big_k - (big_e - (1.0 - m) * big_k) / ((1.0 - m) * np.square(big_k))
        k = np.clip(k - (k / big_k - ratio) / slope, 0.0, elastica.K_MAX)
    return k


def facade_topology(panel_count: int, vertex_budget: int = FACADE_VERTEX_BUDGET,
                    kind: str = 'quad') -> Topology:
    """Return the mesh topology for a facade of ``panel_count`` panels of ``kind``.

    Every row of a mesh block is a straight segment (a generator of the mid-rib cylinder or its
    mirror image) with one normal, so two columns per block give the same surface and shading
    as any finer column count; only the stations along the mid-rib shape the fold. This takes
    two columns per block and the most stations, odd (one at mid-span, the apex) and at most
    the display default's 21, for which the whole facade has at most ``vertex_budget``
    vertices, but at least 3. The demonstrator's 36 panels get 21 stations (126 vertices a
    panel, the default mesh's shape); 1,000 panels get 9 (54 vertices, within 4 mm of the
    fine mesh on a 1 m panel).

    A hexagonal panel's rulings are straight too, on the cone and on each flap, so one ring
    and two flap columns give the surface; this takes the most rulings per sector (even, at
    most 12, at least 2) within the budget: 115 vertices a panel for 36 panels, 43 for 1,000.
    """
    if kind == 'hexagon':
        rulings = 12
        while rulings > 2 and panel_count * (9 * rulings + 7) > vertex_budget:
            rulings -= 2
        return HexagonTopology(rulings_per_sector=rulings, rings=1, flap_columns=2)
    stations = DEFAULT_TOPOLOGY.stations
    while stations > 3 and panel_count * 6 * stations > vertex_budget:
        stations -= 2
    return MeshTopology(stations=stations, midrib_columns=2, flap_columns=2)


def outline(batch: Batch) -> FloatArray:
    """Corners (N, C, 3) of each flat panel's outline in its frame [m], counter-clockwise.

    A quad panel's rectangle (C = 4), a hexagonal panel's hexagon (C = 6, corners at 30 +
    60 k deg from the panel's x axis).
    """
    if isinstance(batch, HexagonBatch):
        angle = np.radians(30.0 + 60.0 * np.arange(6))
        unit = np.stack([np.cos(angle), np.sin(angle), np.zeros(6)], axis=-1)
        return batch.circumradius_m[:, None, None] * unit
    half = np.stack([batch.length_m / 2, batch.width_m / 2, np.zeros(len(batch))], -1)
    signs = np.array([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], dtype=float)
    return half[:, None, :] * signs


class FacadeMesher:
    """Folded meshes of a facade's panels in the site ENU frame.

    Parameters
    ----------
    facade : Facade
        A built facade (:func:`~flectofold_model.facade.load_facade`), quad or hexagonal.
    topology : MeshTopology or HexagonTopology, optional
        Mesh resolution of every panel; default :func:`facade_topology` for
        ``vertex_budget``.
    vertex_budget : int
        Vertices of the whole facade the default topology stays within.
    """

    def __init__(self, facade: Facade, topology: Optional[Topology] = None,
                 vertex_budget: int = FACADE_VERTEX_BUDGET) -> None:
        self.facade = facade
        self.model = fold_model_of(facade.panels)
        self.kind = panel_kind(self.model.batch)
        self.topology = topology or facade_topology(len(facade), vertex_budget, self.kind)
        if not is_topology_for(self.model.batch, self.topology):
            raise TypeError(f'a {type(self.topology).__name__} does not fit {self.kind} panels')
        self.panel_ids = list(facade.panel_ids)
        self.panel_to_enu = facade.panel_to_enu
        """(N, 3, 3) rotations from each panel frame to ENU."""
        self.positions_enu = facade.origin_m @ facade.facade_to_enu.T
        """(N, 3) panel origins in the site ENU frame [m]."""
        self.angle_limits_rad = (self.model.open_fold_angle_rad,
                                 self.model.closed_fold_angle_rad)
        """Open and closed apex fold angles (N,) of every panel [rad]."""
        self._frames: dict[np.dtype[Any], tuple[npt.NDArray[Any], npt.NDArray[Any]]] = {}
        self._rise_table_m: Optional[FloatArray] = None
        if self.kind == 'quad':
            self._sag_limit_m = elastica.sag_from_k(elastica.K_MAX,
                                                    cast(PanelBatch, self.model.batch).length_m)

    def __len__(self) -> int:
        return len(self.panel_ids)

    @property
    def faces(self) -> npt.NDArray[np.int32]:
        """(F, 3) triangle indices of one panel's mesh, shared by all panels."""
        return self.topology.faces

    def batch(self, panels: IntArray) -> Batch:
        """Return the panel batch of the facade indices ``panels``."""
        if len(panels) == len(self):
            return self.model.batch
        return self.model.batch.take(panels)

    def exact_shapes(self, fold_angle_rad: npt.ArrayLike) -> FloatArray:
        """Shape parameters (N,) of every panel at apex fold angles [rad], by the root finders.

        Raises ``ValueError`` for an angle outside a panel's open-closed interval (beyond
        the closure rounding) or not finite.
        """
        return self.model.shape_from_fold_angle(fold_angle_rad)

    def shapes(self, panels: IntArray, fold_angle_rad: npt.ArrayLike,
               batch: Optional[Batch] = None) -> FloatArray:
        """Shape parameters of ``panels`` at fold angles [rad] from tables (clipped to limits)."""
        batch = self.batch(panels) if batch is None else batch
        angle = np.clip(fold_angle_rad, self.angle_limits_rad[0][panels],
                        self.angle_limits_rad[1][panels])
        if self.kind == 'quad':
            quad = cast(PanelBatch, batch)
            sag = np.minimum(sag_for_apex_fold_angle(quad, angle), self._sag_limit_m[panels])
            return k_from_sag(sag, quad.length_m)
        if self._rise_table_m is None:
            self._rise_table_m = cast(HexagonFoldModel, self.model).shape_table()
        opened, closed = self.angle_limits_rad[0][panels], self.angle_limits_rad[1][panels]
        table = self._rise_table_m[panels]
        position = np.clip((angle - opened) / (closed - opened), 0.0, 1.0) * (table.shape[1] - 1)
        lower = np.minimum(position.astype(np.intp), table.shape[1] - 2)
        rows = np.arange(len(panels))
        low, high = table[rows, lower], table[rows, lower + 1]
        return low + (position - lower) * (high - low)

    def world_mesh(self, panels: IntArray, shape: npt.ArrayLike, batch: Optional[Batch] = None,
                   dtype: npt.DTypeLike = np.float32) -> tuple[npt.NDArray[Any], npt.NDArray[Any]]:
        """(M, V, 3) vertices [m] and unit normals of ``panels`` in ENU at shape parameters."""
        batch = self.batch(panels) if batch is None else batch
        build: Callable[..., FoldMesh] = hexagon_mesh if self.kind == 'hexagon' else fold_mesh
        mesh = build(batch, shape, topology=self.topology, dtype=dtype)
        rotation_t, origin = self._frames_of(dtype)
        rotation_t = rotation_t[panels]
        vertices = np.matmul(mesh.vertices, rotation_t)
        vertices += origin[panels]
        return vertices, np.matmul(mesh.normals, rotation_t)

    def _frames_of(self, dtype: npt.DTypeLike) -> tuple[npt.NDArray[Any], npt.NDArray[Any]]:
        """Transposed rotations (N, 3, 3) and origins (N, 1, 3) in ``dtype``, cached."""
        key = np.dtype(dtype)
        if key not in self._frames:
            self._frames[key] = (
                np.ascontiguousarray(np.transpose(self.panel_to_enu, (0, 2, 1)), dtype=key),
                self.positions_enu.astype(key)[:, None, :])
        return self._frames[key]

    def outline_enu(self, depth_m: float = 0.0) -> FloatArray:
        """(N, C, 3) corners of every flat panel's outline in ENU, ``depth_m`` behind it [m]."""
        corners = outline(self.model.batch)
        corners[..., 2] = -depth_m
        return (np.einsum('nij,nkj->nki', self.panel_to_enu, corners)
                + self.positions_enu[:, None, :])


@dataclass(frozen=True)
class PanelMesh:
    """One panel's folded triangle mesh in the site ENU frame."""

    panel_id: str
    vertices_m: np.ndarray
    """(V, 3) vertex positions, x east, y north, z up [m]."""
    faces: np.ndarray
    """(F, 3) vertex indices, counter-clockwise seen from the panel's front (outside)."""


def fold_angles(facade_or_mesher: Union[Facade, FacadeMesher],
                closure: Optional[npt.ArrayLike] = None,
                fold_angle_rad: Optional[npt.ArrayLike] = None) -> FloatArray:
    """Apex fold angles (N,) [rad] of every panel from closures or fold angles (exactly one).

    ``closure`` in [0, 1] goes through the fold model's own map (linear in the apex fold
    angle between each panel's open and closed limits); both take a scalar for every panel
    or one value per panel. Raises ``ValueError`` for a value that is not finite or out of
    its interval, ``TypeError`` for one that is not a number.
    """
    mesher = _mesher(facade_or_mesher)
    if (closure is None) == (fold_angle_rad is None):
        raise ValueError('give either closure or fold_angle_rad, not both or neither')
    if closure is not None:
        return mesher.model.fold_angle_from_closure(closure)
    # Through the closure, which checks the interval (and clips the root finders' rounding).
    return mesher.model.fold_angle_from_closure(
        mesher.model.closure_from_fold_angle(cast(npt.ArrayLike, fold_angle_rad)))


def folded_meshes(facade_or_mesher: Union[Facade, FacadeMesher],
                  closure: Optional[npt.ArrayLike] = None,
                  fold_angle_rad: Optional[npt.ArrayLike] = None,
                  weld_vertices: bool = True) -> list[PanelMesh]:
    """Every panel's folded mesh in the site ENU frame, one :class:`PanelMesh` per panel.

    Parameters
    ----------
    facade_or_mesher : Facade or FacadeMesher
        A facade (meshed at the export resolution, :data:`EXPORT_VERTEX_BUDGET`) or a
        mesher of it with the topology wanted.
    closure : float or array-like, optional
        0 open ... 1 closed, for every panel or one per panel (facade order).
    fold_angle_rad : float or array-like, optional
        Apex fold angles [rad] instead of closures.
    weld_vertices : bool
        Merge the vertices the panel mesh duplicates along its creases (there for sharp
        normals in a viewer; a CAD model wants one connected sheet), see :func:`weld`.

    Returns
    -------
    list of PanelMesh
        In the facade's panel order, named by panel id; float64 vertices.
    """
    mesher = _mesher(facade_or_mesher)
    angle = fold_angles(mesher, closure, fold_angle_rad)
    panels = np.arange(len(mesher))
    vertices, _ = mesher.world_mesh(panels, mesher.exact_shapes(angle), dtype=np.float64)
    meshes = []
    for panel_id, points in zip(mesher.panel_ids, vertices):
        if weld_vertices:
            points, faces = weld(points, mesher.faces)
        else:
            faces = np.asarray(mesher.faces, dtype=np.int64)
        meshes.append(PanelMesh(panel_id=panel_id, vertices_m=points, faces=faces))
    return meshes


def weld(vertices: npt.ArrayLike, faces: npt.ArrayLike,
         tolerance_m: float = WELD_TOLERANCE_M) -> tuple[FloatArray, npt.NDArray[np.int64]]:
    """Merge vertices closer than ``tolerance_m``; drop the triangles that collapse.

    Each vertex becomes the lowest-numbered vertex within the tolerance. Returns the kept
    vertices (in their order) and the renumbered faces (int64).
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    distance = np.linalg.norm(vertices[:, None, :] - vertices[None, :, :], axis=-1)
    first = np.argmax(distance < tolerance_m, axis=1)
    kept, number = np.unique(first, return_inverse=True)
    renumbered = number[np.asarray(faces)]
    distinct = ((renumbered[:, 0] != renumbered[:, 1]) & (renumbered[:, 1] != renumbered[:, 2])
                & (renumbered[:, 0] != renumbered[:, 2]))
    return vertices[kept], renumbered[distinct].astype(np.int64)


def _mesher(facade_or_mesher: Union[Facade, FacadeMesher]) -> FacadeMesher:
    if isinstance(facade_or_mesher, FacadeMesher):
        return facade_or_mesher
    return FacadeMesher(facade_or_mesher, vertex_budget=EXPORT_VERTEX_BUDGET)
