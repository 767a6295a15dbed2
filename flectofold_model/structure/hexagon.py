"""A hexagonal Flectofold panel on the structural sheet: mesh, supports, cushion and path.

The flat panel is the regular hexagon of :class:`~..kinematics.hexagon_panel.HexagonPanel`
in ``z = 0``: triangle vertices ``T_i`` at the azimuths 90 + 120 i degrees, flap tips ``H_i``
between them, fold line ``i`` the drawn quadratic B-spline from ``T_i`` to ``T_(i+1)``
(:mod:`~..kinematics.hexagon_fold_lines`).

* **Mesh**: structured per sector, the three sectors turned copies of one. The columns are
  rays from the centre ``C`` through points of the drawn fold line at even spline parameters
  (the first and last ray are the spokes ``C T_i``); along each ray, rows for the central part
  (from ``C``), the hinge band and the flap (out to the hexagon's edge). The band's edges lie
  ``hinge_width_m / 2`` either side of the drawn line, measured across the line (along the ray
  that is ``b / (2 sin psi)``, ``psi`` the angle between ray and line), so the crease is fixed in
  the material on the drawn curve. Toward each vertex the flap narrows to nothing (the drawn
  line meets the hexagon's corner there); where the flap is narrower than half a band the
  band's outer edge is kept halfway between the drawn line and the edge, and at the vertex the
  bands of the two fold lines meet on the spoke. The rows of a ray that fall together (the
  centre, the flap at a vertex) are one node; each sector is mirror-symmetric and the sheet
  three-fold symmetric.
* **Laminates** per zone from :class:`~..actuation.hexagon_statics.HexagonActuatedPanel`
  (central part, hinge, flap); the pre-fold is moulded into the hinge bands as for the quad
  panel (:func:`~.panel.mould_prefold`).
* **Supports as assumed**: the triangle vertices on slides in the facade plane toward the
  centre (no travel out of plane; the centre held in the plane and ``T_0`` held across its
  slide, which leaves every vertex free to move toward the centre as the kinematic model's
  ``R - sqrt(R^2 - d^2)`` asks). The built supports are not published.
* **Cushion**: the round pouch's flat disc (``flat_radius_m``, centred) on the central part
  presses as a follower pressure load; its back is the plane ``z = -mount_gap_m``. Its
  shrinking contact disc is not modelled: the whole disc stays loaded.

Fold angles are read across each hinge band along its rays as for the quad panel
(:func:`~.panel.band_fold_angles_rad`); the apex fold is the mean over the three sectors of the
two columns of cells beside each apex.
"""

from dataclasses import dataclass
import math
from typing import Optional, TYPE_CHECKING

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from flectofold_model._validate import FloatArray
from flectofold_model.kinematics.hexagon_fold_lines import fold_line_spline
from flectofold_model.kinematics.hexagon_panel import (hexagon_radius_m, HexagonBatch,
                                                       HexagonPanel, SECTOR_RAD)
from flectofold_model.structure.panel import (band_fold_angles_rad, check_mesh_counts,
                                              checker_triangles, FLAP, HINGE, MIDRIB,
                                              Progress, StructuralPath, trace_panel_path)
from flectofold_model.structure.sheet import Sheet

if TYPE_CHECKING:  # the hexagon's statics load when used
    from flectofold_model.actuation.hexagon_statics import HexagonActuatedPanel
    from flectofold_model.structure.symmetry import Mirror

#: Nodes closer than this fraction of the circumradius are one node [-].
MERGE_TOLERANCE = 1e-9
#: Fraction of the flap's width beyond the drawn line the band may take near a vertex [-].
BAND_SHARE_OF_FLAP = 0.5


@dataclass(frozen=True)
class HexagonMesh:
    """Element counts of the structured hexagon mesh, per sector."""

    columns: int = 48
    """Rays per sector from vertex to vertex, less one (even)."""
    centre_rows: int = 12
    """Rows from the centre to the hinge band."""
    hinge_rows: int = 4
    """Rows across each hinge band."""
    flap_rows: int = 6
    """Rows across each flap."""

    def __post_init__(self) -> None:
        check_mesh_counts(self)


#: A hexagon mesh whose flap tip travel is within 1 % of :data:`HEXAGON_REFERENCE_MESH`'s at
#: every air where the tip has moved more than 10 mm, and within 0.1 mm where it has moved
#: less (the preset module, whose moulded pre-fold first unfolds: its tip comes back to about
#: 1 mm near 7 L); its pressure within 0.4 % (``bench/bench_structure.py --hexagon-converged``;
#: figures in ``msg_docs/structure.md``, "A hexagon mesh converged in tip travel").
HEXAGON_CONVERGED_MESH = HexagonMesh(96, 24, 8, 12)
#: The mesh :data:`HEXAGON_CONVERGED_MESH` is measured against: every count 1.5 times.
HEXAGON_REFERENCE_MESH = HexagonMesh(144, 36, 12, 18)


@dataclass(frozen=True)
class HexagonSheet:
    """A hexagonal panel as a :class:`~.sheet.Sheet` and where its parts are in the mesh."""

    sheet: Sheet
    grids: np.ndarray
    """Node index at (sector, column, row) ``(3, columns + 1, rows + 1)``; columns run from
    ``T_(i+1)`` to ``T_i``, rows from the centre out."""
    inner_row: int
    """Row of the hinge band's inner edge (central side)."""
    outer_row: int
    """Row of the hinge band's outer edge (flap side)."""
    tip_node: int
    """Node of flap tip ``H_0``."""
    vertex_nodes: np.ndarray
    """Nodes of the triangle vertices ``T_0, T_1, T_2``."""
    centre_node: int
    """Node of the centre point ``C``."""
    geometry: HexagonPanel
    """The :class:`~..kinematics.hexagon_panel.HexagonPanel` meshed."""
    fold_line_xy_m: np.ndarray
    """Dense points ``(3, P, 2)`` of the drawn fold lines [m]."""
    fold_line_outward_xy: np.ndarray
    """In-plane unit normals ``(3, P, 2)`` of the drawn fold lines, away from the centre."""

    @property
    def mirrors(self) -> tuple['Mirror', ...]:
        """The mirror ``x -> -x`` through ``T_0`` and the centre (:mod:`.symmetry`).

        It takes sector 1 (``T_2`` to ``T_1``) to itself and sectors 0 and 2 to each other,
        each with its columns reversed. The other two mirrors and the three-fold turn are
        not used (:mod:`.symmetry` handles mirrors of ``x`` or ``y`` only).
        """
        from flectofold_model.structure.symmetry import Mirror
        images = np.arange(self.sheet.node_count)
        for sector, image in ((0, 2), (1, 1), (2, 0)):
            images[self.grids[sector]] = self.grids[image][::-1]
        return (Mirror(images, 0),)

    @property
    def hinge_width_m(self) -> float:
        """Width of the hinge bands [m]."""
        return self.geometry.hinge_width_m

    def outward_xy(self, points_xy_m: FloatArray) -> FloatArray:
        """In-plane unit normal of the nearest drawn fold line at points, away from the centre."""
        lines = self.fold_line_xy_m.reshape(-1, 2)
        _, nearest = cKDTree(lines).query(points_xy_m)
        return self.fold_line_outward_xy.reshape(-1, 2)[nearest]

    def fold_angles_rad(self, positions_m: FloatArray) -> FloatArray:
        """Fold angle across each hinge band along its rays ``(3 * columns,)`` [rad]."""
        return np.concatenate([band_fold_angles_rad(grid, self.inner_row, self.outer_row,
                                                    positions_m) for grid in self.grids])

    def _per_sector(self, folds: FloatArray) -> FloatArray:
        return folds.reshape(folds.shape[:-1] + (3, -1))

    def apex_fold_rad(self, folds: FloatArray) -> FloatArray:
        """Fold at the apexes: the two columns beside each, mean over the sectors (last axis)."""
        sectors = self._per_sector(folds)
        middle = sectors.shape[-1] // 2
        return 0.5 * (sectors[..., middle - 1] + sectors[..., middle]).mean(axis=-1)

    def support_fold_rad(self, folds: FloatArray) -> FloatArray:
        """Fold in the cells next to the vertices, mean over both ends and sectors."""
        sectors = self._per_sector(folds)
        return 0.5 * (sectors[..., 0] + sectors[..., -1]).mean(axis=-1)

    def support_travel_m(self, open_positions_m: FloatArray, positions_m: FloatArray) -> float:
        """Mean travel of the triangle vertices toward the centre since open [m]."""
        open_xy = open_positions_m[self.vertex_nodes, :2]
        now_xy = positions_m[self.vertex_nodes, :2]
        centre = open_positions_m[self.centre_node, :2]
        return float(np.mean(np.linalg.norm(open_xy - centre, axis=1)
                             - np.linalg.norm(now_xy - centre, axis=1)))


def _fold_line(geometry: HexagonPanel, parameter: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Points, unit tangents (P, 2) of fold line 0 at spline parameters (P,)."""
    spline = fold_line_spline(HexagonBatch.from_panels([geometry]))
    tangent = spline.derivative()(parameter)[:, 0]
    return spline(parameter)[:, 0], tangent / np.linalg.norm(tangent, axis=1, keepdims=True)


def _sector_points(geometry: HexagonPanel, mesh: HexagonMesh) -> FloatArray:
    """Flat points (columns + 1, rows + 1, 2) of sector 0, columns from T_1 to T_0."""
    parameter = np.linspace(1.0, 0.0, mesh.columns + 1)
    point, tangent = _fold_line(geometry, parameter)
    drawn = np.linalg.norm(point, axis=1)
    ray = point / drawn[:, None]
    sine = np.abs(ray[:, 0] * tangent[:, 1] - ray[:, 1] * tangent[:, 0])
    sector_angle = np.mod(np.arctan2(ray[:, 1], ray[:, 0]) - math.pi / 2, 2 * math.pi)
    edge = hexagon_radius_m(geometry.circumradius_m, sector_angle)
    # At the vertices the drawn line meets the corner: no flap there.
    edge = np.where(np.isclose(edge, drawn, rtol=0.0, atol=1e-12), drawn, edge)
    half = geometry.hinge_width_m / (2.0 * sine)
    inner = drawn - half
    outer = drawn + np.minimum(half, BAND_SHARE_OF_FLAP * (edge - drawn))
    if np.any(inner <= 0.0):
        raise ValueError('the hinge bands reach the centre')
    radii = np.concatenate([
        np.linspace(0.0, 1.0, mesh.centre_rows + 1)[:, None] * inner,
        inner + np.linspace(0.0, 1.0, mesh.hinge_rows + 1)[1:, None] * (outer - inner),
        outer + np.linspace(0.0, 1.0, mesh.flap_rows + 1)[1:, None] * (edge - outer)]).T
    return radii[:, :, None] * ray[:, None, :]


def _turned(points: FloatArray, turns: int) -> FloatArray:
    angle = turns * SECTOR_RAD
    rotation = np.array([[math.cos(angle), -math.sin(angle)],
                         [math.sin(angle), math.cos(angle)]])
    return points @ rotation.T


def build_hexagon_sheet(panel: 'HexagonActuatedPanel',
                        mesh: HexagonMesh = HexagonMesh()) -> HexagonSheet:
    """Mesh a :class:`~..actuation.hexagon_statics.HexagonActuatedPanel` into a flat sheet."""
    geometry = panel.geometry
    sector = _sector_points(geometry, mesh)
    shape = sector.shape[:2]
    raw = np.concatenate([_turned(sector.reshape(-1, 2), turns) for turns in range(3)])
    # Rows that fall together (the centre, the flap at a vertex) and the spokes the sectors
    # share become one node each.
    pairs = np.array(sorted(cKDTree(raw).query_pairs(MERGE_TOLERANCE
                                                     * geometry.circumradius_m)))
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])),
                       shape=(len(raw), len(raw)))
    _, label = connected_components(graph, directed=False)
    first = np.full(label.max() + 1, len(raw))
    np.minimum.at(first, label, np.arange(len(raw)))
    order = np.argsort(first)
    index_of = np.empty_like(order)
    index_of[order] = np.arange(len(order))
    xy = raw[first[order]]
    grids = index_of[label].reshape((3,) + shape)
    triangles, row_of = [], []
    for grid in grids:
        faces, rows = checker_triangles(grid)
        triangles.append(faces)
        row_of.append(rows)
    triangles, row_of = np.concatenate(triangles), np.concatenate(row_of)
    whole = ((triangles[:, 0] != triangles[:, 1]) & (triangles[:, 1] != triangles[:, 2])
             & (triangles[:, 0] != triangles[:, 2]))
    triangles, row_of = triangles[whole], row_of[whole]
    zone = np.where(row_of < mesh.centre_rows, MIDRIB,
                    np.where(row_of < mesh.centre_rows + mesh.hinge_rows, HINGE, FLAP))
    laminates = {MIDRIB: panel.midrib, HINGE: panel.hinge, FLAP: panel.flap}
    thickness = np.array([laminates[z].thickness_m for z in zone])
    modulus = np.array([laminates[z].youngs_modulus_pa for z in zone])
    poisson = np.array([laminates[z].poisson_ratio for z in zone])
    # Grids run from T_(i+1) (column 0) to T_i (last column); the vertex is the ray's end.
    vertices = grids[:, -1, -1]
    centre = int(grids[0, 0, 0])
    fixed = np.zeros((len(xy), 3), dtype=bool)
    fixed[vertices, 2] = True
    fixed[centre, :2] = True
    fixed[vertices[0], 0] = True
    centroid = xy[triangles].mean(axis=1)
    loaded = ((zone == MIDRIB)
              & (np.linalg.norm(centroid, axis=1) <= panel.cushion.flat_radius_m))
    sheet = Sheet(xy, triangles, thickness, modulus, poisson, fixed, loaded,
                  -panel.cushion.mount_gap_m, zone)
    parameter = np.linspace(0.0, 1.0, 2001)
    line, tangent = _fold_line(geometry, parameter)
    # Fold line 0 runs counter-clockwise about the centre: its outward normal is the tangent
    # turned clockwise.
    outward = np.column_stack([tangent[:, 1], -tangent[:, 0]])
    lines = np.stack([_turned(line, turns) for turns in range(3)])
    normals = np.stack([_turned(outward, turns) for turns in range(3)])
    return HexagonSheet(sheet, grids, mesh.centre_rows, mesh.centre_rows + mesh.hinge_rows,
                        int(grids[0, mesh.columns // 2, -1]), vertices, centre, geometry,
                        lines, normals)


def hexagon_structural_path(panel: 'HexagonActuatedPanel', mesh: HexagonMesh = HexagonMesh(),
                            target_fold_rad: Optional[float] = None, steps: int = 24,
                            air_estimate_m3: Optional[float] = None, tolerance: float = 1e-8,
                            progress: Optional[Progress] = None) -> StructuralPath:
    """Trace a hexagonal panel's equilibrium path under rising cushion volume.

    The parameters are those of :func:`~.panel.structural_path`; the defaults come from the
    hexagonal panel's kinematic model and energy statics
    (:class:`~..actuation.hexagon_statics.HexagonActuationModel`). Returns a
    :class:`~.panel.StructuralPath`.
    """
    from flectofold_model.actuation.hexagon_statics import HexagonActuationModel

    if target_fold_rad is None or air_estimate_m3 is None:
        model = HexagonActuationModel([panel])
        if target_fold_rad is None:
            target_fold_rad = float(model.fold.closed_fold_angle_rad[0])
        if air_estimate_m3 is None:
            air_estimate_m3 = float(model.cushion_volume_m3(model.fold.closed_shape)[0]
                                    - model.cushion_volume_m3(model.fold.open_shape)[0])
    return trace_panel_path(build_hexagon_sheet(panel, mesh), panel.geometry.prefold_rad,
                            target_fold_rad, air_estimate_m3, steps, tolerance, progress)
