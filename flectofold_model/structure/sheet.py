"""A thin sheet as membrane triangles and mid-edge bending, and its equilibrium path.

:class:`Sheet` holds a flat triangulated sheet with a laminate per triangle, the supported
degrees of freedom and the triangles a cushion presses on; :func:`trace_path` follows its
equilibrium under rising cushion volume (volume control: each step fixes the volume of air
under the loaded triangles and solves for the shape and the pressure together), so that a
pressure that stops rising, a limit point, is passed and reported rather than hidden. Newton's
method on the augmented system ``[H - p H_V, -g_V; -g_V^T, 0]``, with sparse Cholesky where
the tangent is positive definite and sparse LU beyond a limit point (:mod:`.factor`). The
equations come from a :class:`SheetSystem` (every unknown) or a
:class:`~.symmetry.MirroredSystem` (a symmetric sheet's symmetry cell); both have the
:class:`EquilibriumSystem` interface the solvers use.
"""

from dataclasses import dataclass
from typing import Callable, Iterable, Optional, Protocol

import numpy as np
import numpy.typing as npt
from scipy.sparse import csc_matrix, identity
from scipy.sparse.linalg import splu, SuperLU

from flectofold_model._validate import FloatArray, IntArray
from flectofold_model.structure import elements, kernels
from flectofold_model.structure.factor import (CholeskyFactor, positive_definite,
                                               symmetric_factor)
from flectofold_model.structure.shell import MidEdgeBending


#: Largest ratio of successive out-of-balance forces for which the factorised tangent is kept.
REFACTOR_CONTRACTION = 0.2
#: Share of a step's largest possible cushion work by which the stored strain energy may
#: leave its bounds before the step counts as a jump to another branch [-] (:func:`jumped`).
JUMP_TOLERANCE = 0.01
#: Share of a step's work by the Hermite rule by which the stored strain energy may miss it
#: before the step counts as a jump [-] (:func:`jumped`): the smooth steps measured (the
#: demonstrator, the 1000 mm variant, the hexagon) miss it by at most 2 %, the 1000 mm
#: variant's jump from a stable equilibrium by 40 % (``msg_docs/structure.md``, "Path
#: following").
HERMITE_JUMP_TOLERANCE = 0.05
#: Halvings of a Newton step of :func:`solve_prescribed` that raises the strain energy.
LINE_SEARCH_HALVINGS = 12


@dataclass(frozen=True)
class Sheet:
    """A flat triangulated sheet with its laminates, supports and cushion footprint."""

    reference_xy_m: np.ndarray
    """Flat node positions ``(n, 2)`` [m]; the sheet lies in ``z = 0``."""
    triangles: np.ndarray
    """Node indices ``(m, 3)``, counter-clockwise."""
    thickness_m: np.ndarray
    """Laminate thickness per triangle ``(m,)`` [m]."""
    youngs_modulus_pa: np.ndarray
    """In-plane Young's modulus per triangle ``(m,)`` [Pa]."""
    poisson_ratio: np.ndarray
    """Poisson's ratio per triangle ``(m,)``."""
    fixed: np.ndarray
    """Supported degrees of freedom ``(n, 3)``, True where the coordinate is held."""
    loaded: np.ndarray
    """Triangles the cushion presses on ``(m,)``, bool."""
    base_z_m: float
    """Height of the plane that holds the cushion's back [m] (below the sheet: negative)."""
    zone: Optional[np.ndarray] = None
    """Optional label per triangle ``(m,)`` (e.g. 0 mid-rib, 1 hinge, 2 flap)."""
    rest_tilt_sine: Optional[np.ndarray] = None
    """Sines of the director tilts of the stress-free (moulded) shape ``(m, 3)``; None: the
    sheet is stress-free flat (see :mod:`.shell`)."""
    rest_positions_m: Optional[np.ndarray] = None
    """Node positions ``(n, 3)`` of the moulded shape whose triangles are the membrane's
    stress-free shapes; None: the flat pattern."""

    def __post_init__(self) -> None:
        xy = np.asarray(self.reference_xy_m, dtype=np.float64)
        triangles = np.asarray(self.triangles, dtype=np.int64)
        count = len(triangles)
        if xy.ndim != 2 or xy.shape[1] != 2 or not np.all(np.isfinite(xy)):
            raise ValueError('reference_xy_m must be finite with shape (n, 2)')
        if triangles.ndim != 2 or triangles.shape[1] != 3 or triangles.min() < 0 \
                or triangles.max() >= len(xy):
            raise ValueError('triangles must be (m, 3) indices into reference_xy_m')
        for name in ('thickness_m', 'youngs_modulus_pa'):
            values = np.asarray(getattr(self, name), dtype=np.float64)
            if values.shape != (count,) or not np.all(values > 0.0):
                raise ValueError(f'{name} must be positive, one per triangle')
        poisson = np.asarray(self.poisson_ratio, dtype=np.float64)
        if poisson.shape != (count,) or not np.all((poisson >= 0.0) & (poisson < 0.5)):
            raise ValueError('poisson_ratio must lie in [0, 0.5), one per triangle')
        if np.asarray(self.fixed).shape != xy.shape[:1] + (3,):
            raise ValueError('fixed must have shape (n, 3)')
        if np.asarray(self.loaded).shape != (count,):
            raise ValueError('loaded must have one flag per triangle')
        if self.rest_tilt_sine is not None:
            rest = np.asarray(self.rest_tilt_sine, dtype=np.float64)
            if rest.shape != (count, 3) or not np.all(np.abs(rest) <= 1.0):
                raise ValueError('rest_tilt_sine must be sines in [-1, 1], three per triangle')
        if self.rest_positions_m is not None:
            moulded = np.asarray(self.rest_positions_m, dtype=np.float64)
            if moulded.shape != (len(xy), 3) or not np.all(np.isfinite(moulded)):
                raise ValueError('rest_positions_m must be finite with shape (n, 3)')
        _check_manifold(triangles)

    @property
    def node_count(self) -> int:
        """Number of nodes."""
        return len(self.reference_xy_m)

    @property
    def plate_stiffness_nm(self) -> FloatArray:
        """``D = E t^3 / (12 (1 - nu^2))`` per triangle [N m]."""
        return (self.youngs_modulus_pa * self.thickness_m**3
                / (12.0 * (1.0 - self.poisson_ratio**2)))

    @property
    def reference_areas_m2(self) -> FloatArray:
        """Flat triangle areas [m2]."""
        return membrane_data(self)[1]


def _check_manifold(triangles: IntArray) -> None:
    """Refuse edges shared by more than two triangles or by two of opposite orientation."""
    local = np.array([[0, 1], [1, 2], [2, 0]])
    start = triangles[:, local[:, 0]].ravel()
    end = triangles[:, local[:, 1]].ravel()
    key = np.minimum(start, end) * (triangles.max() + 1) + np.maximum(start, end)
    order = np.argsort(key, kind='stable')
    key_sorted = key[order]
    if np.any(key_sorted[2:] == key_sorted[:-2]):
        raise ValueError('an edge is shared by more than two triangles')
    shared = np.flatnonzero(key_sorted[1:] == key_sorted[:-1])
    if np.any(start[order[shared]] != end[order[shared + 1]]):
        raise ValueError('neighbouring triangles must have the same orientation')


def membrane_data(sheet: Sheet) -> tuple[FloatArray, FloatArray]:
    """Inverse reference edge matrices and areas of the sheet's triangles.

    The stress-free shape of each triangle is its flat pattern, or, for a moulded sheet
    (``rest_positions_m``), its moulded shape laid into its own plane.
    """
    if sheet.rest_positions_m is None:
        return elements.membrane_reference(sheet.reference_xy_m[sheet.triangles])
    corners = np.asarray(sheet.rest_positions_m, dtype=np.float64)[sheet.triangles]
    first = corners[:, 1] - corners[:, 0]
    second = corners[:, 2] - corners[:, 0]
    length = np.linalg.norm(first, axis=1)
    along = np.einsum('mi,mi->m', second, first) / length
    across = np.linalg.norm(elements.cross_rows(first, second), axis=1) / length
    local = np.zeros(corners.shape[:2] + (2,))
    local[:, 1, 0] = length
    local[:, 2, 0] = along
    local[:, 2, 1] = across
    return elements.membrane_reference(local)


class SheetSystem:
    """Energy, gradient and sparse Hessian of a sheet over its free unknowns.

    The unknowns are the node coordinates (``3 n``, the supported ones held) followed by
    one rotation per edge (the mid-edge directors of :mod:`.shell`, all free).

    With ``faces`` (indices into ``sheet.triangles``) only those triangles' membrane, bending
    and cushion terms are summed, over the same unknowns: a symmetric sheet's energy is a
    whole multiple of one symmetry cell's (:mod:`.symmetry`).
    """

    def __init__(self, sheet: Sheet, faces: Optional[npt.ArrayLike] = None) -> None:
        self.sheet = sheet
        chosen = (np.arange(len(sheet.triangles)) if faces is None
                  else np.asarray(faces, dtype=np.int64))
        triangles = np.asarray(sheet.triangles)[chosen]
        inverse, area = membrane_data(sheet)
        self.inverse = np.ascontiguousarray(inverse[chosen])
        self.area = np.ascontiguousarray(area[chosen])
        self.membrane_modulus = np.ascontiguousarray(
            (sheet.youngs_modulus_pa * sheet.thickness_m
             / (1.0 - sheet.poisson_ratio**2))[chosen], dtype=np.float64)
        self.poisson = np.ascontiguousarray(
            np.asarray(sheet.poisson_ratio, dtype=np.float64)[chosen])
        self.bending = MidEdgeBending(sheet.reference_xy_m, sheet.triangles,
                                      sheet.plate_stiffness_nm, sheet.poisson_ratio,
                                      sheet.rest_tilt_sine)
        if faces is not None:
            self.bending = self.bending.subset(chosen)
        self.triangles = triangles
        self.loaded_triangles = triangles[np.asarray(sheet.loaded, dtype=bool)[chosen]]
        nodes = sheet.node_count
        position_dofs = 3 * nodes
        self.size_all = position_dofs + self.bending.edge_count
        fixed = np.concatenate([np.asarray(sheet.fixed, dtype=bool).ravel(),
                                np.zeros(self.bending.edge_count, dtype=bool)])
        self.free = np.flatnonzero(~fixed)
        self.reference = np.concatenate([
            np.column_stack([sheet.reference_xy_m, np.zeros(nodes)]).ravel(),
            np.zeros(self.bending.edge_count)])
        reduced = np.full(self.size_all, -1)
        reduced[self.free] = np.arange(len(self.free))

        def node_dofs(nodes_of: IntArray) -> IntArray:
            count, per = nodes_of.shape
            return (3 * nodes_of[:, :, None] + np.arange(3)).reshape(count, 3 * per)

        bending_dofs = np.concatenate([node_dofs(self.bending.stencil),
                                       position_dofs + self.bending.edges], axis=1)
        self._groups = [
            _Group(node_dofs(triangles), reduced, self._membrane_gradient, 1,
                   self._membrane_hessian),
            _Group(bending_dofs, reduced, self.bending.local_gradient, 1,
                   self.bending.local_hessian),
            _Group(node_dofs(self.loaded_triangles), reduced, self._prism_gradient, 0),
        ]
        self._size = len(self.free)
        self._layout: Optional[tuple[IntArray, IntArray, IntArray]] = None
        self.extent_m = float(np.ptp(sheet.reference_xy_m, axis=0).max())
        self.moves_positions = self.free < position_dofs
        """True for the free unknowns that are coordinates (the others edge rotations)."""

    def _tangent_layout(self) -> tuple[IntArray, IntArray, IntArray]:
        """Where each element Hessian entry goes in the tangent's CSC arrays (made once)."""
        if self._layout is None:
            self._layout = csc_layout(self.entry_rows, self.entry_cols, self._size)
        return self._layout

    def rest_values(self) -> FloatArray:
        """Return the free unknowns of the reference (flat) shape."""
        return self.reference[self.free].copy()

    def sheet_unknowns(self, free_values: FloatArray) -> FloatArray:
        """Return the sheet's free unknowns of a solution: the values themselves."""
        return free_values

    def restrict_sheet(self, sheet_unknowns: npt.ArrayLike) -> FloatArray:
        """Return the unknowns of a shape given as the sheet's free unknowns: a copy."""
        return np.array(sheet_unknowns, dtype=np.float64)

    def nodal_load(self, forces_n: FloatArray) -> FloatArray:
        """Return the load on the free unknowns of forces ``(n, 3)`` on the nodes [N]."""
        full = np.zeros(self.size_all)
        full[:3 * self.sheet.node_count] = np.asarray(forces_n, dtype=np.float64).ravel()
        return full[self.free]

    class_names: tuple[str, ...] = ('whole',)
    """The one block's name (:class:`~.symmetry.MirroredSystem` has one per class)."""

    def tangent_blocks(self, free_values: FloatArray, pressure_pa: float) -> list[csc_matrix]:
        """Return the tangent as one block (:class:`~.symmetry.MirroredSystem` has several)."""
        return [self.hessians(free_values, pressure_pa)]

    def full(self, free_values: FloatArray) -> FloatArray:
        """Every unknown from the free ones."""
        full = self.reference.copy()
        full[self.free] = free_values
        return full

    def positions(self, free_values: FloatArray) -> FloatArray:
        """Node positions ``(n, 3)`` from the free unknowns [m]."""
        return self.full(free_values)[:3 * self.sheet.node_count].reshape(-1, 3)

    def energies_j(self, free_values: FloatArray) -> tuple[float, float]:
        """``(membrane, bending)`` strain energies [J]."""
        unknowns = self.full(free_values)
        positions = unknowns[:3 * self.sheet.node_count].reshape(-1, 3)
        membrane = elements.membrane_energy(positions[self.triangles], self.inverse,
                                            self.area, self.membrane_modulus, self.poisson)
        bending = self.bending.local_energy(unknowns[self._groups[1].dofs])
        return float(membrane.sum()), float(bending.sum())

    def curvatures_per_m(self, free_values: FloatArray, from_rest: bool = False) -> FloatArray:
        """Principal curvatures of every face ``(m, 2)`` [1/m], largest magnitude first.

        With ``from_rest`` the change from the stress-free shape, which strains the laminate.
        """
        return self.bending.curvature_per_m(self.full(free_values)[self._groups[1].dofs],
                                            from_rest)

    def membrane_strains(self, free_values: FloatArray) -> FloatArray:
        """Principal membrane strains of every face ``(m, 2)``, largest magnitude first."""
        positions = self.positions(free_values)
        return elements.membrane_principal_strain(positions[self.triangles], self.inverse)

    def tilt_sine(self, free_values: FloatArray) -> FloatArray:
        """Sines of every face's director tilts ``(m, 3)`` (a moulded shape's rest tilts)."""
        return self.bending.tilt_sine(self.full(free_values)[self._groups[1].dofs])

    def volume_m3(self, free_values: FloatArray) -> float:
        """Volume under the loaded triangles down to the base plane [m3]."""
        positions = self.positions(free_values)
        return float(elements.prism_volume(positions[self.loaded_triangles],
                                           self.sheet.base_z_m).sum())

    def _membrane_gradient(self, local: FloatArray) -> FloatArray:
        """:func:`.elements.membrane_gradient`, compiled (:func:`.kernels.membrane_gradient`)."""
        return kernels.membrane_gradient(np.ascontiguousarray(local.reshape(-1, 9)),
                                         self.inverse, self.area, self.membrane_modulus,
                                         self.poisson).reshape(local.shape)

    def _membrane_hessian(self, local: FloatArray) -> FloatArray:
        """:func:`.elements.membrane_hessian`, compiled (:func:`.kernels.membrane_hessian`)."""
        return kernels.membrane_hessian(np.ascontiguousarray(local.reshape(-1, 9)),
                                        self.inverse, self.area, self.membrane_modulus,
                                        self.poisson).reshape(-1, 9, 9)

    def _prism_gradient(self, local: FloatArray) -> FloatArray:
        corners = local.reshape(-1, 3, 3)
        return elements.prism_gradient(corners, self.sheet.base_z_m).reshape(local.shape)

    def gradients(self, free_values: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Strain-energy gradient and volume gradient over the free unknowns."""
        unknowns = self.full(free_values)
        energy = np.zeros(self.size_all)
        volume = np.zeros(self.size_all)
        for group in self._groups:
            values = group.function(unknowns[group.dofs])
            target = energy if group.strain else volume
            target += np.bincount(group.dofs.ravel(), weights=values.ravel(),
                                  minlength=self.size_all)
        return energy[self.free], volume[self.free]

    def hessians(self, free_values: FloatArray, pressure_pa: float) -> csc_matrix:
        """Sparse ``H - p H_V`` over the free unknowns (CSC)."""
        slot, indices, indptr = self._tangent_layout()
        data = np.bincount(slot, weights=self.hessian_entries(free_values, pressure_pa),
                           minlength=len(indices))
        return csc_matrix((data, indices, indptr), shape=(self._size, self._size))

    def hessian_entries(self, free_values: FloatArray, pressure_pa: float) -> FloatArray:
        """Every element's entries of ``H - p H_V`` between free unknowns, unsummed.

        In the order of :attr:`entry_rows` and :attr:`entry_cols` (free unknowns): the
        tangent is their sum at each position.
        """
        unknowns = self.full(free_values)
        parts = []
        for group in self._groups:
            if group.hessian is None:
                local = elements.finite_difference_hessian(group.function,
                                                           unknowns[group.dofs])
            else:
                local = group.hessian(unknowns[group.dofs])
            scale = 1.0 if group.strain else -pressure_pa
            keep = group.entries[0]
            parts.append(scale * local.reshape(len(local), keep.shape[1])[keep])
        return np.concatenate(parts)

    @property
    def entry_rows(self) -> IntArray:
        """Free unknown of each row of :meth:`hessian_entries`."""
        return np.concatenate([g.entries[1] for g in self._groups])

    @property
    def entry_cols(self) -> IntArray:
        """Free unknown of each column of :meth:`hessian_entries`."""
        return np.concatenate([g.entries[2] for g in self._groups])


def csc_layout(rows: IntArray, cols: IntArray,
               size: int) -> tuple[IntArray, IntArray, IntArray]:
    """Where entries at ``(rows, cols)`` of a ``size`` square matrix go in CSC arrays.

    Returns ``(slot, indices, indptr)``: the CSC data of the summed entries is
    ``np.bincount(slot, weights=entries, minlength=len(indices))``.
    """
    # Sorted column by column, the distinct entries are the CSC layout.
    unique, slot = np.unique(cols * size + rows, return_inverse=True)
    indptr = np.concatenate([[0], np.cumsum(np.bincount(unique // size, minlength=size))])
    return slot, unique % size, indptr


def factorise(matrix: csc_matrix) -> 'SuperLU | CholeskyFactor':
    """Factorise a symmetric tangent: Cholesky where it is positive definite, else sparse LU.

    :func:`~.factor.symmetric_factor` (CHOLMOD's Cholesky, or SuperLU's symmetric mode: a
    third of column ordering's fill-in on the sheet's tangent); when a diagonal pivot vanishes
    (a tangent that is singular there) SuperLU's default partial pivoting before giving up.
    """
    try:
        factor, _ = symmetric_factor(matrix)
        if isinstance(factor, CholeskyFactor):
            return factor
        probe = np.ones(matrix.shape[0])
        if np.all(np.isfinite(factor.solve(probe))):
            return factor
    except RuntimeError:
        pass
    return splu(matrix)


def positive_definite_factor(matrix: csc_matrix,
                             max_shifts: int = 20) -> 'SuperLU | CholeskyFactor':
    """Factorise ``matrix + mu I`` with the least ``mu >= 0`` tried that is positive definite.

    ``mu`` is 0 where the tangent is positive definite (Newton's method); otherwise it starts
    at ``1e-8`` of the largest diagonal entry and grows tenfold (the modified Newton method of
    energy minimisation: every step then goes downhill, so a solve started near a saddle
    leaves it toward a stable equilibrium instead of converging onto the unstable one).
    """
    scale = float(np.max(np.abs(matrix.diagonal())))
    shift = 0.0
    for _ in range(max_shifts):
        shifted = matrix if shift == 0.0 else (matrix + shift * identity(
            matrix.shape[0], format='csc')).tocsc()
        try:
            found = positive_definite(shifted)
        except RuntimeError:
            found = None
        if found is not None:
            return found
        shift = 1e-8 * scale if shift == 0.0 else 10.0 * shift
    return factorise(matrix)


class _Group:
    """One element kind: its unknowns, its gradient and where its Hessian entries go."""

    def __init__(self, dofs: IntArray, reduced: IntArray,
                 function: Callable[[FloatArray], FloatArray], strain: int,
                 hessian: Optional[Callable[[FloatArray], FloatArray]] = None) -> None:
        self.dofs = dofs
        self.function = function
        self.hessian = hessian
        self.strain = bool(strain)
        self._reduced = reduced
        self._entries: Optional[tuple[np.ndarray, IntArray, IntArray]] = None

    @property
    def entries(self) -> tuple[np.ndarray, IntArray, IntArray]:
        """``(keep, rows, cols)``: which local Hessian entries join free unknowns, and those.

        Made on first use: a system that only evaluates energies and gradients (a whole
        sheet beside its symmetry cell) never needs them.
        """
        if self._entries is None:
            per = self.dofs.shape[1]
            # A local Hessian's entries row by row: row k // per, column k % per.
            local = np.arange(per)
            rows = self._reduced[self.dofs[:, np.repeat(local, per)]]
            cols = self._reduced[self.dofs[:, np.tile(local, per)]]
            keep = (rows >= 0) & (cols >= 0)
            self._entries = keep, rows[keep], cols[keep]
        return self._entries


@dataclass(frozen=True)
class PathPoint:
    """One equilibrium of the path."""

    pressure_pa: float
    """Cushion gauge pressure [Pa]."""
    volume_m3: float
    """Volume under the loaded triangles [m3]."""
    positions_m: np.ndarray
    """Node positions ``(n, 3)`` [m]."""
    membrane_energy_j: float
    """Membrane strain energy [J]."""
    bending_energy_j: float
    """Bending strain energy [J]."""
    iterations: int
    """Newton iterations the step took."""
    residual_n: float
    """Largest out-of-balance force left at the free nodes [N]."""
    unknowns: Optional[np.ndarray] = None
    """The free unknowns (coordinates and edge rotations) of this equilibrium."""
    stable_at_pressure: Optional[bool] = None
    """True where the tangent is positive definite: stable with the pressure held (a
    pressure regulator); None where its inertia could not be read."""
    stable_at_volume: Optional[bool] = None
    """True where the tangent is positive definite on the fixed-volume directions: stable
    with the air in the cushion held (closed valves); None where unknown."""
    negative_by_class: Optional[tuple[int, ...]] = None
    """Negative eigenvalues of the tangent in each symmetry class, the even one first (one
    entry for a sheet solved whole; :class:`~.symmetry.MirroredSystem`); None where
    unknown."""
    pressure_per_m3: Optional[float] = None
    """``dp/dV`` along the path here [Pa/m3], from the tangent; None where unknown."""


class EquilibriumSystem(Protocol):
    """What the path and the prescribed solve ask of a system of equations.

    :class:`SheetSystem` (every unknown) and :class:`~.symmetry.MirroredSystem` (the even
    unknowns of a symmetric sheet) have it.
    """

    extent_m: float
    moves_positions: np.ndarray
    class_names: tuple[str, ...]

    def rest_values(self) -> FloatArray:
        """Return the unknowns of the reference shape."""

    def sheet_unknowns(self, values: FloatArray) -> FloatArray:
        """Return the sheet's own free unknowns of a solution."""

    def restrict_sheet(self, sheet_unknowns: npt.ArrayLike) -> FloatArray:
        """Return its unknowns nearest to the sheet's own free unknowns of a shape."""

    def positions(self, values: FloatArray) -> FloatArray:
        """Node positions ``(n, 3)`` [m]."""

    def volume_m3(self, values: FloatArray) -> float:
        """Volume under the loaded triangles [m3]."""

    def energies_j(self, values: FloatArray) -> tuple[float, float]:
        """``(membrane, bending)`` strain energies [J]."""

    def gradients(self, values: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Strain-energy and volume gradients."""

    def hessians(self, values: FloatArray, pressure_pa: float) -> csc_matrix:
        """Return the tangent ``H - p H_V`` the path solves with."""

    def tangent_blocks(self, values: FloatArray, pressure_pa: float) -> list[csc_matrix]:
        """Return the whole tangent in blocks, the one with the volume gradient first."""


def tangent_inertia(system: 'EquilibriumSystem', values: FloatArray,
                    pressure: float) -> Optional[tuple[int, float]]:
    """Negative eigenvalues of the tangent ``H - p H_V`` and ``g_V^T (H - p H_V)^-1 g_V``.

    From :func:`~.factor.symmetric_factor`: a Cholesky factor where the tangent is positive
    definite, else the signs of the pivots of ``P H P^T = L D L^T`` (Sylvester's law of
    inertia); of each block where the system gives the tangent in blocks
    (:meth:`~.symmetry.MirroredSystem.tangent_blocks`: the negative eigenvalues summed, the
    volume gradient in the first). None when a factorisation needed pivoting or failed.
    """
    found = block_inertia(system, values, pressure)
    return None if found is None else (sum(found[0]), found[1])


def block_inertia(system: 'EquilibriumSystem', values: FloatArray,
                  pressure: float) -> Optional[tuple[tuple[int, ...], float]]:
    """:func:`tangent_inertia` with the negative eigenvalues of each block apart."""
    found = _block_inertia(system, values, pressure)
    return None if found is None else found[:2]


def _block_inertia(system: 'EquilibriumSystem', values: FloatArray, pressure: float
                   ) -> Optional[tuple[tuple[int, ...], float, FloatArray]]:
    """:func:`block_inertia` and ``(H - p H_V)^-1 g_V`` of the first block."""
    negatives, curvature, load_step = [], np.nan, np.empty(0)
    for index, matrix in enumerate(system.tangent_blocks(values, pressure)):
        if matrix.shape[0] == 0:
            negatives.append(0)
            continue
        try:
            factor, count = symmetric_factor(matrix)
        except RuntimeError:
            return None
        if count is None:
            return None
        negatives.append(count)
        if index == 0:
            _, volume_gradient = system.gradients(values)
            load_step = factor.solve(volume_gradient)
            curvature = float(volume_gradient @ load_step)
    if not np.isfinite(curvature):
        return None
    return tuple(negatives), curvature, load_step


def _stability(system: 'EquilibriumSystem', values: FloatArray, pressure: float
               ) -> tuple[tuple[Optional[bool], Optional[bool], Optional[tuple[int, ...]]],
                          Optional['_Direction']]:
    """Return the stability from the tangent and the path's direction there.

    The stability is ``(stable_at_pressure, stable_at_volume, negatives per block)``, the
    direction None where it is not known. With the volume held, the bordered tangent has one
    negative eigenvalue from the constraint plus ``neg(H) - 1`` when ``g_V^T H^-1 g_V < 0``
    (Haynsworth), so it is stable when ``neg(H) + [g_V^T H^-1 g_V > 0] == 1``; with the
    pressure held, when ``neg(H) == 0``. Along the path ``H du = g_V dp`` and
    ``g_V . du = dV``: ``dp/dV = 1 / g_V^T H^-1 g_V``.
    """
    inertia = _block_inertia(system, values, pressure)
    if inertia is None:
        return (None, None, None), None
    negatives, curvature, load_step = inertia
    negative = sum(negatives)
    direction = None
    if curvature != 0.0 and np.all(np.isfinite(load_step)):
        direction = _Direction(load_step / curvature, 1.0 / curvature)
    return (negative == 0, negative + int(curvature > 0.0) == 1, negatives), direction


@dataclass(frozen=True)
class _Direction:
    """The path's direction at an equilibrium."""

    values_per_m3: FloatArray
    """``du/dV`` of the system's unknowns."""
    pressure_per_m3: float
    """``dp/dV`` [Pa/m3]."""


class PathError(RuntimeError):
    """The path solver could not find the next equilibrium, even with its smallest step."""

    def __init__(self, message: str, points: Iterable[PathPoint] = ()) -> None:
        super().__init__(message)
        self.points = list(points)
        """The equilibria found before the solver stopped."""


def trace_path(sheet: Sheet, volume_step_m3: float, stop: Callable[[PathPoint], bool],
               max_steps: int = 400, tolerance: float = 1e-8,
               min_step_fraction: float = 1.0 / 64.0, max_iterations: int = 40,
               start: Optional[npt.ArrayLike] = None,
               system: Optional['EquilibriumSystem'] = None) -> list[PathPoint]:
    """Follow the sheet's equilibrium from flat under rising cushion volume.

    Each step starts Newton's method along the path's tangent at the last equilibrium (from
    the factor its stability is read with), and if that fails along the line through the
    last two; from an equilibrium that is stable with the air held, a step whose energy
    balance says it jumped to another branch (:func:`jumped`) is refused and made shorter,
    down to the smallest: there the path is let jump, as the panel would.

    Parameters
    ----------
    sheet : Sheet
    volume_step_m3 : float
        Nominal volume increment per step [m3]; halved when Newton fails (down to
        ``min_step_fraction`` of it) and restored after easy steps.
    stop : callable
        ``stop(point) -> bool``; the path ends after the first point for which it is True.
    tolerance : float
        Newton stops when its last correction moved no unknown by more than ``tolerance``
        times the sheet's extent (coordinates in m, edge rotations in rad) and the pressure
        by no more than ``tolerance`` of itself [-]; 1e-8 is 10 nm on a 1 m panel.
    start : ndarray, optional
        Free unknowns of an unloaded equilibrium to start from (a moulded shape), those of
        ``system``; default the flat reference.
    system : SheetSystem or MirroredSystem, optional
        The equations to solve, default ``SheetSystem(sheet)``; a
        :class:`~.symmetry.MirroredSystem` of the sheet follows its symmetric path on one
        symmetry cell's unknowns (the points' ``unknowns`` and positions are the whole
        sheet's).

    Returns
    -------
    list of PathPoint
        The start (pressure 0) and every converged step. Each point says whether it is stable
        under pressure control and under volume control (from the inertia of its tangent), so
        a pressure maximum (a limit point: snap-through at a set pressure) and a loss of
        stability at a set volume (a bifurcation) show in the path.
    """
    system = SheetSystem(sheet) if system is None else system
    values = (system.rest_values() if start is None
              else np.asarray(start, dtype=np.float64).copy())
    positions = system.positions(values)
    volume = system.volume_m3(values)
    membrane, bending = system.energies_j(values)
    stability, direction = _stability(system, values, 0.0)
    points = [PathPoint(0.0, volume, positions, membrane, bending, 0, 0.0,
                        system.sheet_unknowns(values), *stability,
                        None if direction is None else direction.pressure_per_m3)]
    pressure = 0.0
    step = volume_step_m3
    previous = None
    while len(points) <= max_steps:
        target = volume + step
        smallest = step / 2.0 < volume_step_m3 * min_step_fraction
        stable = points[-1].stable_at_volume is True
        result, found = None, ((None, None, None), None)
        for guess_values, guess_pressure in _predictions(values, pressure, step, direction,
                                                         previous):
            result = _newton(system, guess_values, guess_pressure, target, tolerance,
                             max_iterations, step)
            if result is None:
                continue
            found = _stability(system, result[0], result[1])
            if (stable and not smallest and jumped(
                    step, pressure, result[1], sum(system.energies_j(result[0]))
                    - points[-1].membrane_energy_j - points[-1].bending_energy_j,
                    points[-1].pressure_per_m3,
                    None if found[1] is None else found[1].pressure_per_m3)):
                # From an equilibrium that is stable with the air held the path goes on
                # smoothly: Newton found another branch. Down to the smallest step (where
                # the path is let jump: StructuralPath.jumps reports it) a shorter one.
                result = None
                continue
            break
        if result is None:
            step /= 2.0
            if step < volume_step_m3 * min_step_fraction:
                raise PathError(f'no equilibrium found beyond {volume * 1e3:.4g} L at '
                                f'{pressure:.4g} Pa, even with a step of {step * 1e3:.3g} L',
                                points)
            continue
        new_values, new_pressure, iterations, residual = result
        previous = (values, pressure, step)
        values, pressure, volume = new_values, new_pressure, target
        positions = system.positions(values)
        membrane, bending = system.energies_j(values)
        stability, direction = found
        point = PathPoint(pressure, volume, positions, membrane, bending, iterations, residual,
                          system.sheet_unknowns(values), *stability,
                          None if direction is None else direction.pressure_per_m3)
        points.append(point)
        if stop(point):
            break
        if iterations <= 8 and step < volume_step_m3:
            step = min(2.0 * step, volume_step_m3)
    return points


def jumped(air_m3: npt.ArrayLike, pressure_before_pa: npt.ArrayLike,
           pressure_after_pa: npt.ArrayLike, stored_j: npt.ArrayLike,
           slope_before_pa_per_m3: 'npt.ArrayLike | None' = None,
           slope_after_pa_per_m3: 'npt.ArrayLike | None' = None) -> np.ndarray:
    """Whether steps of a path under rising volume ended on another branch (a jump).

    Over a step of smoothly changing shape the strain energy stored equals the cushion's
    work ``W``, between the lower and the higher of the step's two pressures times its air.
    Outside those bounds (by more than :data:`JUMP_TOLERANCE` of the larger) Newton's method
    has found an equilibrium on another branch: the panel snapped within the step, and the
    energy difference would go into motion and damping. Where the path's ``dp/dV`` is known
    at both ends (finite), the work is also known closely, by the Hermite rule
    ``W = h (p0 + p1) / 2 + h^2 (p0' - p1') / 12`` (error of order ``h^5``), and a step whose
    stored energy misses it by more than :data:`HERMITE_JUMP_TOLERANCE` of it jumped too.
    """
    air = np.asarray(air_m3, dtype=np.float64)
    before = np.asarray(pressure_before_pa, dtype=np.float64)
    after = np.asarray(pressure_after_pa, dtype=np.float64)
    least = np.minimum(before, after) * air
    most = np.maximum(before, after) * air
    slack = JUMP_TOLERANCE * np.maximum(np.abs(least), np.abs(most))
    stored = np.asarray(stored_j, dtype=np.float64)
    outside = (stored < least - slack) | (stored > most + slack)
    if slope_before_pa_per_m3 is None or slope_after_pa_per_m3 is None:
        return outside
    with np.errstate(invalid='ignore'):
        work = (0.5 * air * (before + after) + air**2 / 12.0
                * (np.asarray(slope_before_pa_per_m3, dtype=np.float64)
                   - np.asarray(slope_after_pa_per_m3, dtype=np.float64)))
        missed = np.abs(stored - work) > HERMITE_JUMP_TOLERANCE * np.abs(work)
    return outside | (np.isfinite(work) & missed)


def _predictions(values: FloatArray, pressure: float, step: float,
                 direction: Optional['_Direction'],
                 previous: Optional[tuple[FloatArray, float, float]]
                 ) -> list[tuple[FloatArray, float]]:
    """Newton's starts for the next equilibrium, ``step`` [m3] of air on, the first first.

    Along the path's tangent at the last equilibrium (:func:`_stability`), then along the
    straight line through the last two equilibria; the last equilibrium itself where neither
    is known.
    """
    starts = []
    if direction is not None:
        starts.append((values + step * direction.values_per_m3,
                       pressure + step * direction.pressure_per_m3))
    if previous is not None:
        ratio = step / previous[2]
        starts.append((values + ratio * (values - previous[0]),
                       pressure + ratio * (pressure - previous[1])))
    return starts or [(values, pressure)]


def _newton(system: 'EquilibriumSystem', values: FloatArray, pressure: float, target: float,
            tolerance: float, max_iterations: int,
            step: float) -> Optional[tuple[FloatArray, float, int, float]]:
    """Newton's method on the bordered system; None when it does not converge.

    The tangent is factorised at the first iteration and kept while each iteration cuts the
    out-of-balance force to at most :data:`REFACTOR_CONTRACTION` of the one before (the chord
    method: the element Hessians cost ten times a gradient); otherwise it is refactorised at
    the current point, which is Newton's method.
    """
    extent = system.extent_m
    factor, last_left = None, np.inf
    for iteration in range(1, max_iterations + 1):
        energy_gradient, volume_gradient = system.gradients(values)
        residual = energy_gradient - pressure * volume_gradient
        volume_error = system.volume_m3(values) - target
        if not np.all(np.isfinite(residual)):
            return None
        left = np.max(np.abs(residual))
        if factor is None or left > REFACTOR_CONTRACTION * last_left:
            try:
                factor = factorise(system.hessians(values, pressure))
            except RuntimeError:
                return None
        # Block elimination of the bordered system: du = a + dp b, g_V . du = -volume_error.
        free_step = factor.solve(-residual)
        load_step = factor.solve(volume_gradient)
        denominator = float(volume_gradient @ load_step)
        if not np.isfinite(denominator) or denominator == 0.0:
            return None
        pressure_step = float(-volume_error - volume_gradient @ free_step) / denominator
        step_values = free_step + pressure_step * load_step
        if not np.all(np.isfinite(step_values)):
            return None
        values = values + step_values
        pressure = pressure + pressure_step
        moved = np.max(np.abs(step_values))
        if (moved <= tolerance * extent
                and abs(pressure_step) <= tolerance * max(abs(pressure), 1e-6)):
            energy_gradient, volume_gradient = system.gradients(values)
            left = np.max(np.abs(energy_gradient - pressure * volume_gradient))
            return values, pressure, iteration, float(left)
        last_left = left
    return None


@dataclass(frozen=True)
class PrescribedEquilibrium:
    """An equilibrium with some coordinates held at given values and no cushion load."""

    positions_m: np.ndarray
    """Node positions ``(n, 3)`` [m]."""
    reactions_n: np.ndarray
    """Forces ``(n, 3)`` the supports put on the nodes [N]; zero at free coordinates."""
    membrane_energy_j: float
    """Membrane strain energy [J]."""
    bending_energy_j: float
    """Bending strain energy [J]."""
    iterations: int
    """Newton iterations."""
    curvatures_per_m: np.ndarray
    """Principal curvatures of every face ``(m, 2)`` [1/m]."""
    unknowns: Optional[np.ndarray] = None
    """The free unknowns (coordinates and edge rotations) of this equilibrium."""
    tilt_sine: Optional[np.ndarray] = None
    """Sines of every face's director tilts ``(m, 3)``: the rest tilts of a sheet moulded in
    this shape."""


def solve_prescribed(sheet: Sheet, held_positions_m: npt.ArrayLike,
                     guess_positions_m: npt.ArrayLike, tolerance: float = 1e-10,
                     max_iterations: int = 50,
                     guess_unknowns: Optional[npt.ArrayLike] = None,
                     system: Optional[EquilibriumSystem] = None) -> PrescribedEquilibrium:
    """Find the equilibrium with the sheet's held coordinates at ``held_positions_m``.

    Parameters
    ----------
    sheet : Sheet
    held_positions_m : ndarray, shape (n, 3)
        Values of the held coordinates (``sheet.fixed``) [m]; the others are ignored.
    guess_positions_m : ndarray, shape (n, 3)
        Start of Newton's method [m]; it picks the branch of a buckled sheet.
    guess_unknowns : ndarray, optional
        A start with the edge rotations too (the ``unknowns`` of an earlier equilibrium);
        it takes the place of ``guess_positions_m``.
    system : SheetSystem or MirroredSystem, optional
        The equations of ``sheet`` to solve, e.g. a symmetric sheet's even unknowns
        (:mod:`.symmetry`); the held values must then be the reference's, and the start is
        taken to its nearest shape in the system's unknowns.

    Raises
    ------
    PathError
        When Newton's method does not converge.
    """
    whole = SheetSystem(sheet)
    held = np.asarray(held_positions_m, dtype=np.float64).ravel()
    position_dofs = 3 * sheet.node_count
    fixed = np.asarray(sheet.fixed).ravel()
    if system is not None and not np.array_equal(
            held[fixed], whole.reference[:position_dofs][fixed]):
        raise ValueError('a mirrored system holds its coordinates at the reference')
    whole.reference[:position_dofs] = np.where(fixed, held, whole.reference[:position_dofs])
    start = whole.reference.copy()
    start[:position_dofs] = np.asarray(guess_positions_m, dtype=np.float64).ravel()
    values = (start[whole.free] if guess_unknowns is None
              else np.asarray(guess_unknowns, dtype=np.float64).copy())
    solver: EquilibriumSystem = whole
    if system is not None:
        solver, values = system, system.restrict_sheet(values)
    values, iterations = _minimise(solver, values, tolerance, max_iterations)
    values = solver.sheet_unknowns(values)
    unknowns = whole.full(values)
    full_gradient = np.zeros(whole.size_all)
    for group in whole._groups[:2]:
        local = group.function(unknowns[group.dofs])
        full_gradient += np.bincount(group.dofs.ravel(), weights=local.ravel(),
                                     minlength=whole.size_all)
    reactions = np.where(fixed, full_gradient[:position_dofs], 0.0)
    membrane, bending = whole.energies_j(values)
    return PrescribedEquilibrium(whole.positions(values), reactions.reshape(-1, 3), membrane,
                                 bending, iterations, whole.curvatures_per_m(values),
                                 values, whole.tilt_sine(values))


def _minimise(system: 'EquilibriumSystem', values: FloatArray, tolerance: float,
              max_iterations: int) -> tuple[FloatArray, int]:
    """Least strain energy from ``values`` by the modified Newton method with backtracking."""
    energy = sum(system.energies_j(values))
    for iteration in range(1, max_iterations + 1):
        gradient, _ = system.gradients(values)
        step = positive_definite_factor(system.hessians(values, 0.0)).solve(-gradient)
        # Backtracking on the strain energy, which the equilibrium minimises: a full Newton
        # step from a guess far off (a held coordinate moved) can overshoot into another well.
        for _ in range(LINE_SEARCH_HALVINGS):
            trial = sum(system.energies_j(values + step))
            if trial <= energy + 1e-12 * max(abs(energy), 1.0):
                break
            step = 0.5 * step
        else:
            trial = sum(system.energies_j(values + step))
        energy = trial
        values = values + step
        moves = step[system.moves_positions]
        # With every coordinate held only the edge rotations [rad] move.
        if (np.max(np.abs(moves)) <= tolerance * system.extent_m if moves.size
                else np.max(np.abs(step)) <= tolerance):
            break
    else:
        raise PathError(f'no equilibrium found in {max_iterations} Newton iterations')
    return values, iteration
