"""A quad Flectofold panel on the structural sheet: mesh, moulded pre-fold, supports, cushion.

The flat panel lies in ``z = 0`` with the mid-rib along ``x`` (supports B and C at
``x = -+L/2``) and the fold lines the drawn circular arcs
``y_c(x) = +-(y_apex - R + sqrt(R^2 - x^2))`` of :class:`~..kinematics.panel.PanelGeometry`.

* **Mesh**: structured, one column of nodes per ``x`` station; across, the mid-rib, each hinge
  zone and each flap get their own rows, so the hinge zones are bands of material between
  the arcs of radius ``R -+ hinge_width_m / 2`` concentric with the drawn one (the crease is
  fixed in the material on the drawn curve, whatever the fold asks). Each quad is split along
  a diagonal in a checker pattern, so the mesh keeps both mirror symmetries.
* **Laminates** per zone from :class:`~..actuation.statics.ActuatedPanel`.
* **Moulded pre-fold**: the hinge bands are given a rest curvature across the band (laid on
  each triangle's own edge vectors, on which the tilts give its curvature), scaled
  until the unloaded equilibrium held at the supports has the apex fold ``prefold_rad`` (the
  mid-rib and flaps resist the fold, as the curved fold makes them bend); that equilibrium is
  the moulded shape, and its curvatures and its triangles are then taken as the stress-free
  state, as the paper's moulded part is (how far it is from isometric to the flat pattern is
  reported as the membrane energy it would hold on the flat metric).
* **Supports as assumed**: the mid-rib's end edge between the hinge bands is held at both ends
  across the rib and out of plane (a line support, free to turn about the line); along the
  axis the edges slide, but for B's node on the axis, which holds the panel in place: the
  pin-and-slider of Koerner et al.'s kinematic model, up to a rigid translation symmetric
  about mid-span. The drawings of the built supports are not published.
* **Symmetry**: mesh, laminates, cushion and supports are their own images in both mirrors
  (``x -> -x``, ``y -> -y``), so the path is traced on a quarter of the unknowns and each
  equilibrium's stability read from all four symmetry classes (:mod:`.symmetry`).
* **Cushion**: the strip cushion's flat footprint (``flat_width_m`` x ``length_m``, centred)
  on the mid-rib presses as a follower pressure load; its back is the plane ``z =
  -mount_gap_m``. The strip cushion's shrinking contact width is not modelled: the whole
  footprint stays loaded.

The fold angle is read at each column across a hinge band, from the normal of the mid-rib face
at the band's inner edge to that of the flap face at its outer edge (positive closing), the
total rotation the hinge zone carries, which is what the kinematic model's fold angle is.
"""

from dataclasses import dataclass, fields, replace
from functools import cached_property
import math
from typing import Any, Callable, cast, ClassVar, Optional, Protocol, TYPE_CHECKING

import numpy as np
from threadpoolctl import threadpool_limits

from flectofold_model._validate import FloatArray, IntArray
from flectofold_model.actuation.circuit import PlantParameters
from flectofold_model.structure.sheet import (jumped, PathError, PathPoint, Sheet,
                                              SheetSystem, solve_prescribed)

if TYPE_CHECKING:  # the statics' module loads when used
    from flectofold_model.actuation.statics import ActuatedPanel
    from flectofold_model.kinematics.panel import PanelGeometry
    from flectofold_model.structure.symmetry import Mirror, MirroredSystem


class MeshedPanel(Protocol):
    """A meshed panel of either kind as the path reads it: a :class:`PanelSheet` or a hexagon's.

    Protocols, here and in :class:`MeshCounts`: the hexagon's module imports this one.
    """

    @property
    def sheet(self) -> Sheet:
        """The shell of the panel."""

    @property
    def tip_node(self) -> int:
        """Node of a flap tip."""

    @property
    def hinge_width_m(self) -> float:
        """Width of the hinge bands [m]."""

    def outward_xy(self, points_xy_m: FloatArray) -> FloatArray:
        """In-plane unit normal of the nearer drawn fold line at points, away from the axis."""

    def fold_angles_rad(self, positions_m: FloatArray) -> FloatArray:
        """Fold angle across the hinge bands [rad]."""

    def apex_fold_rad(self, folds: FloatArray) -> FloatArray:
        """Fold at the crease apex [rad]."""

    def support_fold_rad(self, folds: FloatArray) -> FloatArray:
        """Fold next to the supports [rad]."""

    def support_travel_m(self, open_positions_m: FloatArray, positions_m: FloatArray) -> float:
        """Travel of the supports since the open state [m]."""

    @property
    def mirrors(self) -> tuple['Mirror', ...]:
        """Mirrors of the mesh, supports and loads (:mod:`.symmetry`); none for no symmetry."""


class MeshCounts(Protocol):
    """A structured mesh's element counts: a dataclass of integers with ``columns``."""

    __dataclass_fields__: ClassVar[dict[str, Any]]

    @property
    def columns(self) -> int:
        """Elements along the mid-rib or a fold line (even)."""


#: Called after every equilibrium of a path with its pressure [Pa] and apex fold angle [rad].
Progress = Callable[[float, float], object]

#: Zone labels of the panel's triangles.
MIDRIB, HINGE, FLAP = 0, 1, 2

#: Attempts and relative tolerance of the moulded apex fold against the pre-fold.
MOULD_ATTEMPTS, MOULD_TOLERANCE = 6, 0.005

#: Steps in which the moulded pre-fold is raised from flat.
MOULD_STEPS = 2

#: Air, as a multiple of the reflection model's air to close, after which a path that has not
#: closed ends (the prototype's structure closes with 1.5 times it).
AIR_LIMIT_FACTOR = 2.0

#: Uniform pressure on the closed flaps' inner faces of :attr:`StructuralPath.closed_wind`
#: [Pa]: the 1.0 kN/m2 of the published wind-load case (Koerner et al.), as the energy
#: statics' ``wind_response`` takes it.
WIND_PRESSURE_PA = 1000.0
#: Rigid volume of tubing that shares the cushion's air when its valves are shut [m3]: the
#: pneumatic plant's default (``PlantParameters.dead_volume_m3``).
DEAD_VOLUME_M3: float = PlantParameters.dead_volume_m3


#: Fields of a mesh that shape its rows rather than count them (checked by the mesh itself).
SHAPE_FIELDS = ('flap_growth', 'outer_columns')
#: Bounds of :attr:`PanelMesh.flap_growth` [-]: beyond them the narrowest flap row is less
#: than a tenth of the widest (a hundredth of the width at the default 8 rows).
FLAP_GROWTH_BOUNDS = (0.1, 10.0)


def _power_of_two(value: int) -> bool:
    return value >= 1 and value & (value - 1) == 0


def check_mesh_counts(mesh: MeshCounts) -> None:
    """Refuse a structured mesh's counts that cannot be meshed (either panel kind).

    Every count (a field other than :data:`SHAPE_FIELDS`) an integer of at least 1;
    ``columns`` even and at least 4, so that the mesh has a middle column line and keeps its
    mirror symmetry.
    """
    for field in fields(mesh):
        if field.name in SHAPE_FIELDS:
            continue
        value = getattr(mesh, field.name)
        if not isinstance(value, (int, np.integer)) or value < 1:
            raise ValueError(f'{field.name} must be a positive integer, got {value!r}')
    if mesh.columns % 2 or mesh.columns < 4:
        raise ValueError(f'columns must be even and at least 4, got {mesh.columns}')


@dataclass(frozen=True)
class PanelMesh:
    """Element counts of the structured panel mesh."""

    columns: int = 80
    """Elements along the mid-rib, support to support (even)."""
    midrib_rows: int = 8
    """Rows across each half of the mid-rib."""
    hinge_rows: int = 4
    """Rows across each hinge band."""
    flap_rows: int = 8
    """Rows across each flap."""
    flap_growth: float = 1.0
    """Width of a flap's outermost row over its innermost (by the hinge) [-]; the rows between
    grow geometrically. Above 1 the flap is meshed finer where it bends most, beside the
    hinge band. Within :data:`FLAP_GROWTH_BOUNDS`."""
    outer_columns: int = 0
    """Fewest elements along a node line away from the hinge bands; 0: every line has
    ``columns`` (a structured grid). Otherwise the lines of the bands have ``columns``, and
    each line further from the nearest band line half as many as the one before, down to
    this many: lines of different counts are joined by rows of three triangles per coarse
    element. Even, at least 4, ``columns`` divided by a power of 2."""

    def __post_init__(self) -> None:
        check_mesh_counts(self)
        outer = self.outer_columns
        if (isinstance(outer, bool) or not isinstance(outer, (int, np.integer))
                or (outer != 0 and not (outer >= 4 and outer % 2 == 0
                                        and self.columns % outer == 0
                                        and _power_of_two(self.columns // outer)))):
            raise ValueError(f'outer_columns must be 0 or an even count of at least 4 that '
                             f'divides columns ({self.columns}) by a power of 2, '
                             f'got {outer!r}')
        low, high = FLAP_GROWTH_BOUNDS
        growth = self.flap_growth
        if (isinstance(growth, bool) or not isinstance(growth, (int, float, np.floating))
                or not low <= growth <= high):
            raise ValueError(f'flap_growth must be a number from {low:g} to {high:g}, '
                             f'got {growth!r}')

    def refined(self, factor: int) -> 'PanelMesh':
        """Return the same mesh with every count multiplied by ``factor`` (the growth kept)."""
        return PanelMesh(self.columns * factor, self.midrib_rows * factor,
                         self.hinge_rows * factor, self.flap_rows * factor, self.flap_growth,
                         self.outer_columns * factor)

    def line_columns(self) -> IntArray:
        """Elements along each node line of the whole sheet, from the ``-y`` edge."""
        half = self.midrib_rows + self.hinge_rows + self.flap_rows
        line = np.arange(2 * half + 1) - half  # signed line number from the axis
        inner, outer = self.midrib_rows, self.midrib_rows + self.hinge_rows
        away = np.maximum(np.maximum(inner - np.abs(line), np.abs(line) - outer), 0)
        if self.outer_columns == 0:
            return np.full(len(line), self.columns)
        return np.maximum(self.columns >> np.minimum(away, 62), self.outer_columns)


#: A quad mesh whose tip travel at every air is within 1 % of :data:`REFERENCE_MESH`'s, which
#: has twice its columns and flap rows, for every preset that closes
#: (``bench/bench_structure.py --converged``; figures in ``msg_docs/structure.md``, "A mesh
#: converged in tip travel"): the hinge bands need their elements fine both along and across,
#: the flap rows are graded from the hinge.
CONVERGED_MESH = PanelMesh(160, 8, 8, 8, 4.0)
#: The mesh :data:`CONVERGED_MESH` is measured against.
REFERENCE_MESH = PanelMesh(320, 8, 8, 16, 4.0)
#: :data:`CONVERGED_MESH` with its columns only in the hinge bands: 160 there, halving with
#: every node line away from them down to 20 (3,869 nodes against 7,889); within 1 % of
#: :data:`REFERENCE_MESH` in tip travel at every air for every preset that closes, at about
#: half the CPU (``bench/bench_structure.py --converged``; ``msg_docs/structure.md``, "A mesh
#: fine only in the hinge bands").
BANDED_MESH = PanelMesh(160, 8, 8, 8, 4.0, 20)


@dataclass(frozen=True)
class PanelSheet:
    """A panel as a :class:`~.sheet.Sheet` and where its parts are in the mesh."""

    sheet: Sheet
    grid: np.ndarray
    """Node index at (column, row) ``(columns + 1, rows + 1)``; row 0 is the ``-y`` edge."""
    x_m: np.ndarray
    """``x`` of each column [m]."""
    inner_row: int
    """Row of the upper (+y) hinge band's inner edge (mid-rib side)."""
    outer_row: int
    """Row of the upper hinge band's outer edge (flap side)."""
    tip_node: int
    """Node of flap tip A: mid-span of the +y flap edge."""
    geometry: 'PanelGeometry'
    """The :class:`~..kinematics.panel.PanelGeometry` meshed."""

    @property
    def hinge_width_m(self) -> float:
        """Width of the hinge bands [m]."""
        return self.geometry.hinge_width_m

    @property
    def mirrors(self) -> tuple['Mirror', ...]:
        """The mesh's mirrors ``x -> -x`` and ``y -> -y`` (:mod:`.symmetry`)."""
        from flectofold_model.structure.symmetry import Mirror
        kept = self.grid >= 0
        images = []
        for image in (self.grid[::-1, :], self.grid[:, ::-1]):
            node = np.empty(np.count_nonzero(kept), dtype=np.int64)
            node[self.grid[kept]] = image[kept]
            images.append(node)
        return Mirror(images[0], 0), Mirror(images[1], 1)

    def outward_xy(self, points_xy_m: FloatArray) -> FloatArray:
        """In-plane unit normal of the nearer drawn fold line at points, away from the axis."""
        geometry = self.geometry
        centre_y = np.sign(points_xy_m[:, 1]) * (
            geometry.midrib_width_m / 2 - geometry.fold_radius_m)
        outward = np.column_stack([points_xy_m[:, 0], points_xy_m[:, 1] - centre_y])
        return outward / np.linalg.norm(outward, axis=1, keepdims=True)

    def fold_angles_rad(self, positions_m: FloatArray) -> FloatArray:
        """Fold angle across the upper hinge band at each column of cells [rad].

        Cells of the lines on either side of the band; where those have fewer nodes than the
        band (:attr:`PanelMesh.outer_columns`), at their columns, with the flap edge's node
        nearest each for the sign.
        """
        return band_fold_angles_rad(self._measure, 1, 2, positions_m)

    @cached_property
    def _measure(self) -> IntArray:
        """The lines the fold is read on: beside the band, its edges, the flap edge."""
        lines = self.grid[:, [self.inner_row - 1, self.inner_row, self.outer_row,
                              self.outer_row + 1, -1]]
        columns = np.flatnonzero(np.all(lines[:, :4] >= 0, axis=1))
        edge = np.flatnonzero(lines[:, 4] >= 0)
        nearest = edge[np.argmin(np.abs(columns[:, None] - edge[None, :]), axis=1)]
        measure = lines[columns].copy()
        measure[:, 4] = lines[nearest, 4]
        return measure

    def apex_fold_rad(self, folds: FloatArray) -> FloatArray:
        """Fold at mid-span: the mean of the two columns of cells beside it (last axis)."""
        return _middle(folds)

    def support_fold_rad(self, folds: FloatArray) -> FloatArray:
        """Fold in the cells next to the supports, mean of both ends (last axis)."""
        return 0.5 * (folds[..., 0] + folds[..., -1])

    def support_travel_m(self, open_positions_m: FloatArray, positions_m: FloatArray) -> float:
        """Travel of the sliding support C toward B since the open state [m]."""
        slider = self.grid[-1, self.grid.shape[1] // 2]
        return float(open_positions_m[slider, 0] - positions_m[slider, 0])

    def flap_gap_m(self, positions_m: FloatArray) -> float:
        """Closest approach of the two flaps [m]: twice the least ``y`` of the +y flap.

        For a shape that is its own image in ``y -> -y`` (the path on the symmetry cell) this
        is exact for the triangles: the distance of a point ``p`` of one flap from a point
        ``q'`` of the other (the image of ``q``) is at least ``y_p + y_q``, reached at
        ``q = p``, and a triangle's least ``y`` is at a corner. Not above 0: the flaps touch
        or pass through each other.
        """
        return 2.0 * float(np.min(positions_m[self._upper_flap_nodes, 1]))

    @cached_property
    def _upper_flap_nodes(self) -> IntArray:
        """Nodes of the +y flap's triangles (made once)."""
        flap = np.asarray(self.sheet.zone) == FLAP
        nodes = np.unique(np.asarray(self.sheet.triangles)[flap])
        return nodes[np.asarray(self.sheet.reference_xy_m)[nodes, 1] > 0.0]


def build_panel_sheet(panel: 'ActuatedPanel', mesh: PanelMesh = PanelMesh()) -> PanelSheet:
    """Mesh an :class:`~..actuation.statics.ActuatedPanel` into a flat :class:`PanelSheet`."""
    geometry = panel.geometry
    half_length = geometry.length_m / 2
    x = np.linspace(-half_length, half_length, mesh.columns + 1)
    radius = geometry.fold_radius_m
    centre = geometry.midrib_width_m / 2 - radius
    half_band = geometry.hinge_width_m / 2
    # The band's edges are the arcs concentric with the drawn one, radius R -+ b/2.
    inner = centre + np.sqrt(np.maximum((radius - half_band)**2 - x**2, 0.0))
    outer = centre + np.sqrt((radius + half_band)**2 - x**2)
    if np.any(x**2 >= (radius - half_band)**2) or np.any(inner <= 0.0):
        raise ValueError('the hinge bands meet on the axis: the mid-rib is narrower than '
                         'the hinge zones at the supports')
    if np.any(outer >= geometry.width_m / 2):
        raise ValueError('the hinge bands reach the flap edge')
    fractions = np.concatenate([
        np.linspace(0.0, 1.0, mesh.midrib_rows + 1)[:, None] * inner,
        inner + np.linspace(0.0, 1.0, mesh.hinge_rows + 1)[1:, None] * (outer - inner),
        outer + graded_fractions(mesh.flap_rows, mesh.flap_growth)[1:, None]
        * (geometry.width_m / 2 - outer)])
    upper = fractions.T
    y = np.concatenate([-upper[:, :0:-1], upper], axis=1)
    rows = y.shape[1] - 1
    # A line of fewer elements keeps every (columns / its count)-th of the finest nodes.
    stride = mesh.columns // mesh.line_columns()
    kept = (np.arange(mesh.columns + 1)[:, None] % stride[None, :]) == 0
    grid = np.full((mesh.columns + 1, rows + 1), -1)
    grid[kept] = np.arange(np.count_nonzero(kept))
    xy = np.column_stack([np.broadcast_to(x[:, None], y.shape)[kept], y[kept]])
    triangles, row_of = (checker_triangles(grid) if mesh.outer_columns == 0
                         else banded_triangles(grid))
    half = rows // 2
    distance = np.abs(row_of - half + 0.5) + 0.5
    zone = np.where(distance <= mesh.midrib_rows, MIDRIB,
                    np.where(distance <= mesh.midrib_rows + mesh.hinge_rows, HINGE, FLAP))
    laminates = {MIDRIB: panel.midrib, HINGE: panel.hinge, FLAP: panel.flap}
    thickness = np.array([laminates[z].thickness_m for z in zone])
    modulus = np.array([laminates[z].youngs_modulus_pa for z in zone])
    poisson = np.array([laminates[z].poisson_ratio for z in zone])
    fixed = np.zeros((len(xy), 3), dtype=bool)
    rib_rows = slice(half - mesh.midrib_rows, half + mesh.midrib_rows + 1)
    # Both end edges held across and out of plane; along the axis only B's node on it (the
    # pin): the rest slide, so the supports are their own mirror images up to that pin.
    fixed[grid[0, rib_rows], 1:] = True
    fixed[grid[-1, rib_rows], 1:] = True
    fixed[grid[0, half], 0] = True
    centroid = xy[triangles].mean(axis=1)
    cushion = panel.cushion
    loaded = ((zone == MIDRIB) & (np.abs(centroid[:, 0]) <= cushion.length_m / 2)
              & (np.abs(centroid[:, 1]) <= cushion.flat_width_m / 2))
    sheet = Sheet(xy, triangles, thickness, modulus, poisson, fixed, loaded,
                  -cushion.mount_gap_m, zone)
    return PanelSheet(sheet, grid, x, half + mesh.midrib_rows,
                      half + mesh.midrib_rows + mesh.hinge_rows,
                      int(grid[mesh.columns // 2, -1]), geometry)


def graded_fractions(intervals: int, growth: float) -> FloatArray:
    """Fractions ``0 ... 1`` bounding ``intervals`` rows whose widths grow geometrically.

    The last row is ``growth`` times as wide as the first; ``growth == 1`` spaces them evenly.
    """
    if intervals == 1 or growth == 1.0:
        return np.linspace(0.0, 1.0, intervals + 1)
    widths = float(growth) ** (np.arange(intervals) / (intervals - 1))
    fractions = np.concatenate([[0.0], np.cumsum(widths) / widths.sum()])
    fractions[-1] = 1.0
    return fractions


def banded_triangles(grid: IntArray) -> tuple[IntArray, IntArray]:
    """Counter-clockwise triangles of a grid whose node lines have their own counts.

    ``grid`` as :attr:`PanelSheet.grid`, -1 where a line has no node. Two lines of one count
    are joined as :func:`checker_triangles` joins them (the checker by column and row);
    lines of counts ``n`` and ``2 n`` by three triangles per element of the coarser, its two
    corners and the finer line's three nodes over it. Mirror-symmetric in x and y for even
    counts and an even number of rows.
    """
    triangles, row_of = [], []
    for row in range(grid.shape[1] - 1):
        low, high = grid[:, row], grid[:, row + 1]
        low, high = low[low >= 0], high[high >= 0]
        if len(low) == len(high):
            strip, _ = checker_triangles(np.column_stack([low, high]), first_row=row)
            triangles.append(strip)
            row_of.append(np.full(len(strip), row))
            continue
        coarse, fine = (low, high) if len(low) < len(high) else (high, low)
        if len(fine) != 2 * len(coarse) - 1:
            raise ValueError('neighbouring lines must have equal counts or one twice the other')
        j = np.arange(len(coarse) - 1)
        left, right = coarse[j], coarse[j + 1]
        first, middle, last = fine[2 * j], fine[2 * j + 1], fine[2 * j + 2]
        three = [np.stack([left, first, middle], 1), np.stack([left, middle, right], 1),
                 np.stack([right, middle, last], 1)]
        # Counter-clockwise as written where the coarser line is the upper (+y) one.
        triangles += three if len(high) < len(low) else [t[:, ::-1] for t in three]
        row_of.append(np.full(3 * len(j), row))
    return np.concatenate(triangles), np.concatenate(row_of)


def checker_triangles(grid: IntArray, first_row: int = 0) -> tuple[IntArray, IntArray]:
    """Counter-clockwise triangles of a structured grid, diagonals in a checker pattern.

    ``first_row``: the row of the whole mesh the grid's first row of cells is, for the
    checker's parity (a strip of a :func:`banded_triangles` mesh).
    """
    columns, rows = grid.shape[0] - 1, grid.shape[1] - 1
    i, j = np.meshgrid(np.arange(columns), np.arange(rows), indexing='ij')
    i, j = i.ravel(), j.ravel()
    a, b = grid[i, j], grid[i + 1, j]
    c, d = grid[i + 1, j + 1], grid[i, j + 1]
    # Diagonal a-c on even cells, b-d on odd: mirror-symmetric in x and y for even counts.
    even = ((i + j + first_row) % 2 == 0)
    first = np.where(even[:, None], np.stack([a, b, c], 1), np.stack([a, b, d], 1))
    second = np.where(even[:, None], np.stack([a, c, d], 1), np.stack([b, c, d], 1))
    return np.concatenate([first, second]), np.concatenate([j, j])


def mould_prefold(panel_sheet: MeshedPanel, prefold_rad: float,
                  like: 'SheetSystem | MirroredSystem | None' = None
                  ) -> tuple[Sheet, FloatArray, float]:
    """Give the hinge bands the moulded pre-fold and return the sheet and its rest unknowns.

    ``like``: a system of the panel (:func:`equilibrium_system`) whose store of tangent
    layouts the mould's systems share.

    Returns
    -------
    sheet : Sheet
        The panel's sheet with ``rest_tilt_sine`` of the moulded shape.
    start : ndarray
        Free unknowns of the unloaded moulded shape held at the supports.
    moulding_membrane_energy_j : float
        Membrane energy the moulded shape would hold on the flat pattern's metric: how far
        from isometric the mould is (it is stress-free by construction).
    """
    sheet = panel_sheet.sheet
    system = SheetSystem(sheet)
    if prefold_rad == 0.0:
        return sheet, system.reference[system.free].copy(), 0.0
    outward = panel_sheet.outward_xy(sheet.reference_xy_m[sheet.triangles].mean(axis=1))
    # Negative about the outward normal: the flaps rise toward +z, the side the cushion
    # arches the mid-rib to, so that arching the mid-rib folds them further (closing).
    curvature = np.where(sheet.zone == HINGE, -prefold_rad / panel_sheet.hinge_width_m, 0.0)
    target = curvature[:, None, None] * np.einsum('mi,mj->mij', outward, outward)
    # The tilts give the second fundamental form on each face's own edge vectors
    # (``I S``, :mod:`.shell`): the target is laid onto them, not onto x and y.
    corners = sheet.reference_xy_m[sheet.triangles]
    edges = np.stack([corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]], axis=-1)
    form = np.einsum('mia,mij,mjb->mab', edges, target, edges)
    metric = np.einsum('mia,mib->mab', edges, edges)
    basis = np.einsum('mab,mkbc->mkac', metric, system.bending.shape_basis)
    matrix = np.stack([basis[:, :, 0, 0], basis[:, :, 0, 1], basis[:, :, 1, 1]], axis=1)
    rhs = np.stack([form[:, 0, 0], form[:, 0, 1], form[:, 1, 1]], axis=1)
    rest = np.linalg.solve(matrix, rhs[:, :, None])[:, :, 0]
    # The hinge's rest curvature is scaled until the unloaded shape's apex fold is the
    # pre-fold (the mid-rib and flaps resist the fold, as the curved fold makes them bend).
    held = np.column_stack([sheet.reference_xy_m, np.zeros(sheet.node_count)])
    achieved, scale = 0.0, 0.0
    # Raised from flat in steps, then rescaled from the last shape until the fold is met;
    # each solve starts from the shapes before, extrapolated linearly in the scale.
    shapes = [(0.0, system.reference[system.free].copy())]
    scales = list(np.linspace(0.0, 1.0, MOULD_STEPS + 1)[1:])
    for attempt in range(MOULD_STEPS + MOULD_ATTEMPTS):
        scale = scales[attempt] if attempt < MOULD_STEPS else scale * prefold_rad / achieved
        folded = replace(sheet, rest_tilt_sine=np.clip(scale * rest, -1.0, 1.0))
        system = equilibrium_system(panel_sheet, folded, like=like)
        guess = shapes[-1][1]
        if len(shapes) > 1:
            (before, older), (last, newer) = shapes[-2:]
            guess = newer + (scale - last) / (last - before) * (newer - older)
        try:
            first = solve_prescribed(folded, held, held, guess_unknowns=guess,
                                     system=None if isinstance(system, SheetSystem) else system)
        except PathError as error:
            raise ValueError(f'could not mould the pre-fold {prefold_rad:g} rad on this mesh: '
                             f'{error}') from None
        shapes.append((scale, cast(FloatArray, first.unknowns)))
        if attempt + 1 >= MOULD_STEPS:
            achieved = float(panel_sheet.apex_fold_rad(
                panel_sheet.fold_angles_rad(first.positions_m)))
            if abs(achieved - prefold_rad) <= MOULD_TOLERANCE * abs(prefold_rad):
                break
    else:
        raise ValueError(f'could not mould the pre-fold {prefold_rad:g} rad: the unloaded '
                         f'panel holds {achieved:g} rad at the apex')
    # The mould's shape is the stress-free state: its curvatures and its metric.
    moulded = replace(sheet, rest_tilt_sine=first.tilt_sine,
                      rest_positions_m=first.positions_m)
    return moulded, cast(FloatArray, first.unknowns), first.membrane_energy_j  # always set


def band_fold_angles_rad(grid: IntArray, inner_row: int, outer_row: int,
                         positions_m: FloatArray) -> FloatArray:
    """Fold angle across a hinge band at each column of cells ``(columns,)`` [rad].

    ``grid`` holds node indices ``(columns + 1, rows + 1)`` with rows running from the driven
    part (mid-rib, central part) across the band to the flap, columns and rows a right-handed
    pair in the flat sheet. The fold is the angle from the normal of the driven part's cell next
    to the band's inner edge to that of the flap's cell next to its outer edge; positive when
    the flap has turned toward ``+z`` (closing).
    """
    normals = []
    for row in (inner_row - 1, outer_row):
        # The two triangles of each cell in that row, averaged: a cell normal.
        a, b = grid[:-1, row], grid[1:, row]
        c, d = grid[1:, row + 1], grid[:-1, row + 1]
        normal = np.cross(positions_m[c] - positions_m[a], positions_m[d] - positions_m[b])
        normals.append(normal / np.linalg.norm(normal, axis=1, keepdims=True))
    rib, flap = normals
    cosine = np.clip(np.einsum('ij,ij->i', rib, flap), -1.0, 1.0)
    # The flap's outer edge above or below the driven part's plane gives the sign.
    rise = np.einsum('ij,ij->i', positions_m[grid[:-1, -1]] + positions_m[grid[1:, -1]]
                     - positions_m[grid[:-1, inner_row]] - positions_m[grid[1:, inner_row]],
                     rib)
    return np.sign(rise) * np.arccos(cosine)


def fold_angles_rad(panel_sheet: MeshedPanel, positions_m: FloatArray) -> FloatArray:
    """Fold angle across the upper hinge band at each column of cells ``(columns,)`` [rad].

    From the normal of the mid-rib face next to the band's inner edge to that of the flap face
    next to its outer edge; positive when the flap has turned toward ``+z`` (closing).
    """
    return panel_sheet.fold_angles_rad(positions_m)


def apex_fold_angle_rad(panel_sheet: MeshedPanel, positions_m: FloatArray) -> float:
    """Fold angle at the apex (mid-span) [rad]."""
    return float(panel_sheet.apex_fold_rad(panel_sheet.fold_angles_rad(positions_m)))


def _middle(folds: FloatArray) -> FloatArray:
    """Mean of the two columns of cells beside the middle, along the last axis of ``folds``."""
    middle = folds.shape[-1] // 2
    return 0.5 * (folds[..., middle - 1] + folds[..., middle])


@dataclass(frozen=True)
class WindOnFlaps:
    """How far the closed panel's flaps give under a uniform pressure on their inner faces.

    The linear response at the last equilibrium of the path, ``f`` the pressure's load on the
    flap triangles (normal to them, on the faces that look at each other when closed, pushing
    the flaps open), in two cases:

    * **the cushion pressure held** (the pressure loop keeps it): ``K du = f`` with ``K`` the
      tangent there, the counterpart of the energy statics' ``ActuationModel.wind_response``;
    * **the air held** (the valves shut): ``K du = f + dp g_V`` and
      ``g_V . du = -C dp``, ``g_V`` the gradient of the cushion's volume and
      ``C = (V + V_dead) / p_abs`` the compliance of its air, isothermal as the plant's
      (:mod:`~..actuation.plant`), with the tubing's dead volume: the flaps squeeze the
      cushion, its pressure rises by ``dp`` and pushes back.
    """

    wind_pressure_pa: float
    """Pressure on the flaps' inner faces [Pa]."""
    flap_force_n: float
    """That pressure times the area of one flap as it is [N]."""
    tip_deflection_m: float
    """Travel of flap tip A it causes [m]."""
    stiffness_n_per_m: float
    """``flap_force_n / tip_deflection_m`` [N/m]: larger is stiffer."""
    apex_fold_change_rad: float
    """Change of the apex fold it causes, to first order [rad]: negative where the flaps
    open."""
    air_held_tip_deflection_m: float
    """Travel of flap tip A with the cushion's air held [m]."""
    air_held_stiffness_n_per_m: float
    """``flap_force_n / air_held_tip_deflection_m`` [N/m]."""
    air_held_pressure_rise_pa: float
    """Rise of the cushion pressure with the air held [Pa]."""
    air_held_volume_change_m3: float
    """Change of the cushion's volume with the air held, ``-C dp`` [m3]."""


@dataclass(frozen=True)
class StructuralPath:
    """The equilibrium path of one panel from open toward closed, one entry per equilibrium.

    Every array has one value per equilibrium of the path, the open (moulded) shape first.
    """

    pressure_pa: np.ndarray
    """Cushion gauge pressure [Pa]."""
    air_m3: np.ndarray
    """Air pushed into the cushion since the open state, at its volume [m3]."""
    apex_fold_rad: np.ndarray
    """Fold angle across the hinge band at mid-span [rad]."""
    support_fold_rad: np.ndarray
    """Fold angle across the hinge band in the cells next to the supports, mean of both
    ends [rad] (hexagon: next to the triangle's vertices)."""
    fold_along_rad: np.ndarray
    """Fold angle at every column of cells ``(points, columns)`` [rad]."""
    tip_travel_m: np.ndarray
    """Distance flap tip A (hexagon: flap tip H_0) moved from the open state [m]."""
    support_travel_m: np.ndarray
    """Travel of the sliding support C toward B since the open state [m] (hexagon: of each
    triangle vertex toward the centre)."""
    peak_strain: dict
    """Peak surface strain per zone (``'midrib'``, ``'hinge'``, ``'flap'``): the change of
    curvature from the moulded state times half the thickness plus the membrane strain."""
    strain_energy_j: np.ndarray
    """Membrane and bending strain energy stored since the open state [J]; by the energy
    balance, the work of the cushion."""
    stable_at_pressure: np.ndarray
    """True where the equilibrium holds with the pressure set (a pressure regulator)."""
    stable_at_volume: np.ndarray
    """True where it holds with the air in the cushion held."""
    ended: str
    """Why the path ended: ``'closed'`` (the apex fold reached the target), the air limit
    (:data:`AIR_LIMIT_FACTOR`) or the solver's reason."""
    node_count: int
    """Nodes of the mesh."""
    moulding_energy_j: float
    """Membrane energy the moulded shape would hold on the flat pattern's metric [J]."""
    positions_m: Optional[np.ndarray] = None
    """Node positions at every equilibrium ``(points, nodes, 3)`` [m]."""
    surface_strain: Optional[np.ndarray] = None
    """Peak surface strain of every triangle at every equilibrium ``(points, triangles)``
    (bending from the moulded state times half the thickness plus the membrane strain)."""
    triangles: Optional[np.ndarray] = None
    """Node indices of the mesh's triangles ``(triangles, 3)``, counter-clockwise."""
    open_volume_m3: Optional[float] = None
    """Cushion volume of the open state, between the loaded footprint and the back [m3]."""
    zone: Optional[np.ndarray] = None
    """Zone of each triangle (:data:`MIDRIB`, :data:`HINGE`, :data:`FLAP`)."""
    negative_by_class: Optional[np.ndarray] = None
    """Negative eigenvalues of the tangent with the pressure held, per equilibrium and
    symmetry class ``(points, classes)``, the even class first; -1 where unknown."""
    class_names: tuple[str, ...] = ('whole',)
    """The classes of :attr:`negative_by_class` (``'even'``, ``'odd in y'``, ... or
    ``'whole'`` for a panel solved without its symmetry)."""
    closed_wind: Optional['WindOnFlaps'] = None
    """The closed panel's give under wind on its flaps (quad panels whose path closed)."""
    flap_gap_m: Optional[np.ndarray] = None
    """Closest approach of the two flaps at every equilibrium [m]
    (:meth:`PanelSheet.flap_gap_m`; quad panels). Contact between them is not modelled: a
    path ends at the first equilibrium where it is not above 0."""
    pressure_slope_pa_per_m3: Optional[np.ndarray] = None
    """``dp/dV`` along the path at every equilibrium [Pa/m3], from its tangent; NaN where
    unknown."""

    @property
    def limit_points(self) -> IntArray:
        """Indices of pressure maxima (limit points).

        The last equilibrium stable at its pressure before one that is not; beyond it a
        pressure regulator snaps the panel through.
        """
        stable = np.asarray(self.stable_at_pressure, dtype=bool)
        held = np.asarray(self.stable_at_volume, dtype=bool)
        # At a pressure maximum the tangent turns indefinite along the volume gradient: the
        # equilibrium stays stable with the air held. Otherwise it is a bifurcation.
        return np.flatnonzero(stable[:-1] & ~stable[1:] & held[1:])

    @property
    def bifurcations(self) -> IntArray:
        """Indices of the last equilibria stable with the air held before one that is not.

        The tangent has turned indefinite in a direction that keeps the volume: a branch
        crosses the path (with the pressure still rising, or past a maximum), and the panel
        leaves the path there even with its valves closed.
        """
        held = np.asarray(self.stable_at_volume, dtype=bool)
        return np.flatnonzero(held[:-1] & ~held[1:])

    @property
    def symmetry_breaking(self) -> list[tuple[int, str]]:
        """Where the path first loses stability in a mode that breaks its symmetry.

        ``(index, class name)`` for every odd class whose tangent gets a negative eigenvalue
        (the first equilibrium where it has one): from there the symmetric path the solver
        follows is not the panel's, which leaves it in that mode (a bifurcation).
        """
        if self.negative_by_class is None:
            return []
        found = []
        for column, name in enumerate(self.class_names):
            if name in ('even', 'whole'):
                continue
            negative = np.flatnonzero(np.asarray(self.negative_by_class)[:, column] > 0)
            if len(negative):
                found.append((int(negative[0]), name))
        return sorted(found)

    @property
    def jumps(self) -> IntArray:
        """Indices of equilibria the path reached by a jump: :func:`~.sheet.jumped`."""
        pressure = np.asarray(self.pressure_pa)
        slope = self.pressure_slope_pa_per_m3
        return np.flatnonzero(jumped(
            np.diff(self.air_m3), pressure[:-1], pressure[1:], np.diff(self.strain_energy_j),
            None if slope is None else slope[:-1], None if slope is None else slope[1:])) + 1


def structural_path(panel: 'ActuatedPanel', mesh: PanelMesh = PanelMesh(),
                    target_fold_rad: Optional[float] = None, steps: int = 24,
                    air_estimate_m3: Optional[float] = None, tolerance: float = 1e-8,
                    progress: Optional[Progress] = None) -> StructuralPath:
    """Trace a quad panel's equilibrium path under rising cushion volume.

    Parameters
    ----------
    panel : ActuatedPanel
    mesh : PanelMesh
    target_fold_rad : float, optional
        Apex fold angle at which the path ends ("closed"); default the kinematic model's
        closed fold angle of the panel.
    steps : int
        Volume steps the path aims for up to the target (the step is the kinematic model's air
        to close divided by ``steps``, or ``air_estimate_m3 / steps``); a step is halved when
        Newton's method needs it. A path that has not closed ends after
        :data:`AIR_LIMIT_FACTOR` times that air.
    progress : callable, optional
        ``progress(pressure_pa, apex_fold_rad)`` after every equilibrium.
    """
    from flectofold_model.actuation.statics import ActuationModel

    if target_fold_rad is None or air_estimate_m3 is None:
        model = ActuationModel([panel])
        if target_fold_rad is None:
            target_fold_rad = float(model.fold.closed_fold_angle_rad[0])
        if air_estimate_m3 is None:
            air_estimate_m3 = float(model.cushion_volume_m3(model.fold.closed_shape)[0]
                                    - model.cushion_volume_m3(model.fold.open_shape)[0])
    return trace_panel_path(build_panel_sheet(panel, mesh), panel.geometry.prefold_rad,
                            target_fold_rad, air_estimate_m3, steps, tolerance, progress)


def trace_panel_path(panel_sheet: MeshedPanel, prefold_rad: float, target_fold_rad: float,
                     air_estimate_m3: float, steps: int = 24, tolerance: float = 1e-8,
                     progress: Optional[Progress] = None) -> StructuralPath:
    """Mould a panel's pre-fold and trace its path until the apex fold reaches the target.

    ``panel_sheet`` is a meshed panel of either kind (:class:`PanelSheet`,
    :class:`~.hexagon.HexagonSheet`); the other parameters are those of
    :func:`structural_path`.

    BLAS runs on one thread while the path is traced (process-wide, restored after): a second
    thread costs CPU without shortening the path (measured in ``msg_docs/structure.md``).
    """
    with threadpool_limits(limits=1, user_api='blas'):
        return _trace_panel_path(panel_sheet, prefold_rad, target_fold_rad, air_estimate_m3,
                                 steps, tolerance, progress)


def _trace_panel_path(panel_sheet: MeshedPanel, prefold_rad: float, target_fold_rad: float,
                      air_estimate_m3: float, steps: int, tolerance: float,
                      progress: Optional[Progress]) -> StructuralPath:
    from flectofold_model.structure.sheet import trace_path

    # A system of the flat sheet first: the mould's and the path's share its layouts.
    system = equilibrium_system(panel_sheet, panel_sheet.sheet)
    sheet, start, moulding_energy = mould_prefold(panel_sheet, prefold_rad, like=system)
    system = equilibrium_system(panel_sheet, sheet, like=system)
    ended = ['closed']
    air_limit = AIR_LIMIT_FACTOR * air_estimate_m3
    try:
        def reached(point: PathPoint) -> bool:
            fold = apex_fold_angle_rad(panel_sheet, point.positions_m)
            if progress is not None:
                progress(point.pressure_pa, fold)
            if (isinstance(panel_sheet, PanelSheet)
                    and panel_sheet.flap_gap_m(point.positions_m) <= 0.0):
                ended[0] = (f'the flaps touch at {math.degrees(fold):.1f} deg apex fold '
                            f'(contact between them is not modelled)')
                return True
            if fold >= target_fold_rad:
                return True
            if point.volume_m3 - opened >= air_limit:
                ended[0] = (f'not closed with {air_limit * 1e3:.3g} L of air, '
                            f'{AIR_LIMIT_FACTOR:g} times what the reflection model needs')
                return True
            return False

        values = system.restrict_sheet(start)
        opened = system.volume_m3(values)
        points = trace_path(sheet, air_estimate_m3 / steps, reached, max_steps=8 * steps,
                            tolerance=tolerance, start=values, system=system)
    except PathError as error:
        points, ended[0] = error.points, str(error)
    path = _path_from_points(panel_sheet, sheet, points, ended[0], moulding_energy,
                             system.class_names)
    if ended[0] == 'closed' and isinstance(panel_sheet, PanelSheet):
        path = replace(path, closed_wind=wind_on_flaps(panel_sheet, sheet, system, points[-1]))
    return path


def wind_on_flaps(panel_sheet: 'PanelSheet', sheet: Sheet, system: 'SheetSystem | MirroredSystem',
                  point: PathPoint, wind_pressure_pa: float = WIND_PRESSURE_PA,
                  dead_volume_m3: float = DEAD_VOLUME_M3) -> WindOnFlaps:
    """Return the flaps' give at an equilibrium of the path under wind on their inner faces.

    ``sheet`` is the moulded sheet the path was traced on and ``system`` its equations; the
    cushion's pressure is held at the point's, and then its air with ``dead_volume_m3`` [m3]
    of tubing. See :class:`WindOnFlaps`.
    """
    from flectofold_model.actuation.flow import ATMOSPHERIC_PRESSURE_PA
    from flectofold_model.structure.sheet import factorise

    if not np.isfinite(wind_pressure_pa) or wind_pressure_pa <= 0.0:
        raise ValueError(f'wind_pressure_pa must be finite and > 0, got {wind_pressure_pa!r}')
    if not np.isfinite(dead_volume_m3) or dead_volume_m3 < 0.0:
        raise ValueError(f'dead_volume_m3 must be finite and >= 0, got {dead_volume_m3!r}')
    flaps = np.asarray(sheet.zone) == FLAP
    unknowns = cast(FloatArray, point.unknowns)  # trace_path gives every point its own
    values = system.restrict_sheet(unknowns)
    positions = system.positions(values)
    triangles = np.asarray(sheet.triangles)[flaps]
    corners = positions[triangles]
    # Counter-clockwise in the flat pattern: the area normal of a flap triangle points out of
    # its +z face, the face that looks at the other flap when closed; pressure on that face
    # pushes against it, a third of the triangle's load on each corner.
    area_normal = 0.5 * np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    forces = np.zeros((sheet.node_count, 3))
    np.add.at(forces, triangles, np.repeat(-wind_pressure_pa / 3.0 * area_normal[:, None, :],
                                           3, axis=1))
    factor = factorise(system.hessians(values, point.pressure_pa))
    change = factor.solve(system.nodal_load(forces))
    # The air held: du = change + dp per_pressure, g_V . du = -C dp.
    _, volume_gradient = system.gradients(values)
    per_pressure = factor.solve(volume_gradient)
    air_compliance = ((point.volume_m3 + dead_volume_m3)
                      / (ATMOSPHERIC_PRESSURE_PA + point.pressure_pa))
    pressure_rise = -float(volume_gradient @ change) / float(
        volume_gradient @ per_pressure + air_compliance)
    held_change = change + pressure_rise * per_pressure
    tip = panel_sheet.tip_node
    # Positions are linear in the unknowns: the tip's travel is exact for the linear change;
    # the fold is not, so its first-order change is read over a thousandth of it.
    deflection, held_deflection = (
        float(np.linalg.norm(system.positions(values + moved)[tip] - positions[tip]))
        for moved in (change, held_change))
    fold = (lambda moved: float(panel_sheet.apex_fold_rad(panel_sheet.fold_angles_rad(moved))))
    fold_change = (fold(system.positions(values + 1e-3 * change)) - fold(positions)) / 1e-3
    flap_area = float(np.linalg.norm(area_normal, axis=1).sum()) / 2.0  # one flap, as it is
    force = wind_pressure_pa * flap_area
    return WindOnFlaps(wind_pressure_pa, force, deflection, force / deflection, fold_change,
                       held_deflection, force / held_deflection, pressure_rise,
                       float(volume_gradient @ held_change))


def equilibrium_system(panel_sheet: MeshedPanel, sheet: Sheet,
                       like: 'SheetSystem | MirroredSystem | None' = None
                       ) -> 'SheetSystem | MirroredSystem':
    """Return the equations to solve a panel's sheet with: its symmetry cell's if it has one.

    A panel with mirrors is traced on its even unknowns, its stability read from every
    symmetry class (:mod:`.symmetry`): the quad on a quarter (two mirrors, four classes), the
    hexagon on a half (one mirror, two classes). ``like``: a system of the same panel in
    another rest state, whose tangent layouts are shared where they are the same
    (:meth:`~.symmetry.MirroredSystem.adopt_layouts`).
    """
    if not panel_sheet.mirrors:
        return SheetSystem(sheet)
    from flectofold_model.structure.symmetry import MirroredSystem
    system = MirroredSystem(sheet, panel_sheet.mirrors)
    if isinstance(like, MirroredSystem):
        system.adopt_layouts(like)
    return system


def _path_from_points(panel_sheet: MeshedPanel, sheet: Sheet, points: list[PathPoint],
                      ended: str, moulding_energy: float,
                      class_names: tuple[str, ...] = ('whole',)) -> StructuralPath:
    system = SheetSystem(sheet)
    folds = np.array([panel_sheet.fold_angles_rad(p.positions_m) for p in points])
    tip = np.array([p.positions_m[panel_sheet.tip_node] for p in points])
    half_thickness = 0.5 * sheet.thickness_m
    zones = {'midrib': MIDRIB, 'hinge': HINGE, 'flap': FLAP}
    peaks: dict[str, list[float]] = {name: [] for name in zones}
    strains = []
    for point in points:
        unknowns = cast(FloatArray, point.unknowns)  # trace_path gives every point its own
        bending = np.abs(system.curvatures_per_m(unknowns, from_rest=True)[:, 0])
        membrane = np.abs(system.membrane_strains(unknowns)[:, 0])
        surface = bending * half_thickness + membrane
        strains.append(surface)
        for name, zone in zones.items():
            peaks[name].append(float(surface[sheet.zone == zone].max()))
    return StructuralPath(
        pressure_pa=np.array([p.pressure_pa for p in points]),
        air_m3=np.array([p.volume_m3 - points[0].volume_m3 for p in points]),
        apex_fold_rad=panel_sheet.apex_fold_rad(folds),
        support_fold_rad=panel_sheet.support_fold_rad(folds),
        fold_along_rad=folds,
        tip_travel_m=np.linalg.norm(tip - tip[0], axis=1),
        support_travel_m=np.array([panel_sheet.support_travel_m(points[0].positions_m,
                                                                p.positions_m)
                                   for p in points]),
        peak_strain={name: np.array(values) for name, values in peaks.items()},
        strain_energy_j=np.array([p.membrane_energy_j + p.bending_energy_j
                                  - points[0].membrane_energy_j - points[0].bending_energy_j
                                  for p in points]),
        stable_at_pressure=np.array([bool(p.stable_at_pressure) for p in points]),
        stable_at_volume=np.array([bool(p.stable_at_volume) for p in points]),
        negative_by_class=np.array([p.negative_by_class if p.negative_by_class is not None
                                    else (-1,) * len(class_names) for p in points]),
        class_names=class_names,
        ended=ended, node_count=sheet.node_count, moulding_energy_j=moulding_energy,
        positions_m=np.array([p.positions_m for p in points]),
        surface_strain=np.array(strains), triangles=np.asarray(sheet.triangles),
        open_volume_m3=float(points[0].volume_m3),
        zone=np.asarray(sheet.zone),
        flap_gap_m=(np.array([panel_sheet.flap_gap_m(p.positions_m) for p in points])
                    if isinstance(panel_sheet, PanelSheet) else None),
        pressure_slope_pa_per_m3=np.array([np.nan if p.pressure_per_m3 is None
                                           else p.pressure_per_m3 for p in points]))
