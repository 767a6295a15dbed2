"""Direct-sun shading and view of folded panels, by ray casting against their meshes.

Geometry, in the panel frame of :mod:`~flectofold_model.kinematics` (x along the mid-rib,
y across, z out of the facade) [m]: the flat panel is the cell ``|x| <= L/2, |y| <= W/2``
of the facade plane ``z = 0``, and its **footprint** is the same rectangle on the window or
wall behind it, at ``z = -standoff_m``. ``s`` is the unit vector toward the sun [-]; the
panel is *sunlit*, and direct sun reaches the footprint, if ``s_z > SUNLIT_MIN_SZ`` (1e-9).

A footprint point ``p`` is **blocked** if its ray ``p + t s``, ``t > 0``, hits a folded
sheet (mid-rib or flap). The **blocked fraction** [-] is the blocked share of the
footprint's area, which on a sunlit panel is the share of its direct sun that the sheets
intercept. It is measured along ``3 samples`` parallel scan lines (:mod:`.scan_lines`), the
midlines of equal strips, tilted away from the directions of straight shadow edges. For a
triangle ``v0, v0 + e1, v0 + e2`` with ``det = e1 . (s x e2)``, the barycentric coordinates
of the ray from ``o`` by the Moller-Trumbore algorithm [1]_,
``u = (o - v0) . (s x e2) / det``, ``v = (o - v0) . (e1 x s) / det`` and ``w = 1 - u - v``,
are affine in ``o``; along a scan line the ray hits the triangle on one interval, where
``u, v, w >= -1e-4`` (the slack closes shared edges). Then::

    blocked_fraction = sum of the lines' blocked lengths / sum of their chord lengths,

with a line's blocked length the exact length of the union of its intervals. Triangles seen
edge-on (``|det| <= 1e-12 |e1| |e2|``) cast no shadow; ``t > 0`` needs no check, since every
mesh point lies at ``z >= 0``. The error is the midpoint rule's across the lines: none where
a shadow's outline crosses them, up to half a strip's share per edge that runs along them.

**Neighbours.** With ``tessellated=True`` each panel sits in an unbounded array of identical
panels in its own fold state (``L x W`` cells, or the hexagonal lattice of
:mod:`.hexagon_tiling`), and each ray is tested against the copies of the mesh in every cell
it crosses within the meshes' height range, up to ``max_cells`` cells (along x plus along y;
across-flats widths for hexagons), beyond which blocked fractions are lower bounds. A flat
tessellated facade blocks all direct sun at any ``s_z > 0``. ``tessellated=False`` tests the
panel's own mesh only: a lone panel, whose footprint takes oblique sun past its edges.

**Hexagonal panels.** Every public function takes a batch (or fold model) of either kind.
For a hexagonal panel the shape parameter is the centre rise [m], the footprint is the
hexagon itself and the scan lines cross it at 15 deg to its sides, so fractions are shares
of the hexagon's area.

Results do not depend on how panels are batched (intervals are merged on a grid of
``2**-30`` of the line parameter). Accuracy, CPU cost and the choice of the defaults
(:data:`SHADING_TOPOLOGY`, :data:`HEXAGON_SHADING_TOPOLOGY`, :data:`DEFAULT_SAMPLES`,
:data:`DEFAULT_MAX_CELLS`): msg_docs/scheduling.md, sections "Ray runs, resolution and
cost" and "Accuracy of the blocked fraction"; msg_docs/hexagon_shading.md, sections
"Mesh topology: convergence" and "CPU cost".

References
----------
.. [1] Moller, T. and Trumbore, B., "Fast, minimum storage ray-triangle intersection",
   Journal of Graphics Tools 2(1) (1997) 21-28.
"""

from dataclasses import dataclass
from typing import Callable, Optional, Union

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import (BoolArray, FloatArray, FloatOrArray, in_range, IntArray,
                                        real_array, real_scalar)
from flectofold_model.kinematics import elastica
from flectofold_model.kinematics.closure import FoldModel
from flectofold_model.kinematics.hexagon_closure import HexagonFoldModel, MAX_SPOKE_TILT_RAD
from flectofold_model.kinematics.hexagon_mesh import hexagon_mesh, HexagonTopology
from flectofold_model.kinematics.hexagon_panel import HexagonBatch
from flectofold_model.kinematics.kinds import AnyFoldModel, Batch, is_topology_for
from flectofold_model.kinematics.mesh import fold_mesh, FoldMesh, MeshTopology
from flectofold_model.kinematics.panel import PanelBatch
from flectofold_model.shading import hexagon_tiling, scan_lines
from flectofold_model.shading.scan_lines import ScanLines

#: A mesh resolution of either panel kind.
Topology = Union[MeshTopology, HexagonTopology]

#: Mesh resolution for shading: 11 stations x (3 + 2 x 7) columns, 280 triangles per panel.
SHADING_TOPOLOGY = MeshTopology(stations=11, midrib_columns=3, flap_columns=7)
#: Mesh resolution for shading hexagonal panels, chosen by the convergence check of
#: msg_docs/hexagon_shading.md.
HEXAGON_SHADING_TOPOLOGY = HexagonTopology(rulings_per_sector=6, rings=2, flap_columns=4)
#: Default resolution across the footprint: 3 x 24 = 72 scan lines per panel.
DEFAULT_SAMPLES = 24
#: Default gap between the sheet and the window or wall behind it [m].
DEFAULT_STANDOFF_M = 0.05
#: Default limit on the cells a ray is followed across (see the module docstring).
DEFAULT_MAX_CELLS = 32
#: Default candidate closures of :func:`closure_for_shading` (read-only).
DEFAULT_CLOSURES = np.linspace(0.0, 1.0, 21)
DEFAULT_CLOSURES.setflags(write=False)

#: Smallest ``s_z`` of a sunlit panel: a sun nearer the facade plane counts as parallel to it.
SUNLIT_MIN_SZ = 1e-9
#: Largest accepted deviation of a sun vector's length from 1.
_UNIT_TOLERANCE = 1e-6
#: Slack on the barycentric coordinates: a ray on an edge shared by two triangles hits (the
#: intervals of the two overlap by about 1e-4 of the triangles' size).
_BARYCENTRIC_SLACK = 1e-4
#: Triangles with ``|det| <= _EDGE_ON |e1| |e2|`` are parallel to the ray.
_EDGE_ON = 1e-12
#: Panels whose meshes are built at once, and (line, triangle) tests per block of pairs.
_PANEL_CHUNK = 256
_ELEMENT_BUDGET = 1 << 19


@dataclass(frozen=True)
class Shading:
    """Direct-sun shading of the footprints of N panels; each field has shape ``(N,)``."""

    blocked_fraction: np.ndarray
    """Share of the footprint whose ray toward the sun hits a sheet, in [0, 1]; 0 if not sunlit."""
    sunlit: np.ndarray
    """``True`` where the sun is in front of the facade (``s_z > 1e-9``): direct sun arrives."""


@dataclass(frozen=True)
class ShadingChoice:
    """Closures chosen by :func:`closure_for_shading`; each field has shape ``(N,)``."""

    closure: np.ndarray
    """Chosen closure, one of the candidates (0 open ... 1 closed)."""
    blocked_fraction: np.ndarray
    """Blocked fraction of the direct sun at the chosen closure (0 if not sunlit)."""
    view_fraction: np.ndarray
    """View fraction (openness along the facade normal) at the chosen closure."""
    sunlit: np.ndarray
    """``True`` where the sun is in front of the facade."""
    meets_target: np.ndarray
    """``blocked_fraction >= target``; always ``True`` where not sunlit (nothing to block)."""


def blocked_fraction(batch: Batch, shape_parameter: npt.ArrayLike, sun_panel: npt.ArrayLike,
                     topology: Optional[Topology] = None, samples: int = DEFAULT_SAMPLES,
                     standoff_m: float = DEFAULT_STANDOFF_M, tessellated: bool = True,
                     max_cells: int = DEFAULT_MAX_CELLS) -> Shading:
    """Share of each panel's footprint that the folded sheets keep out of the direct sun.

    Vectorised over panels: the scan lines of a chunk of panels are tested against all their
    triangles in batched array operations; there is no loop over single panels.

    Parameters
    ----------
    batch : PanelBatch or HexagonBatch
        The N panels, all of one kind.
    shape_parameter : float or array-like
        The fold state of each panel (``state_from_closure(closure).shape_parameter`` of its
        fold model), a scalar or shape ``(N,)``: for a quad panel the elliptic modulus of the
        mid-rib elastica ``k`` in ``[0, elastica.K_MAX]`` [-]; for a hexagonal panel the
        centre rise ``centre_rise_m`` in ``[0, R sin(MAX_SPOKE_TILT_RAD)]`` [m].
    sun_panel : array-like
        Unit vector(s) toward the sun in the panel frame, shape ``(3,)`` (all panels) or
        ``(N, 3)`` [-]. Lengths may deviate from 1 by at most ``1e-6``; they are normalised.
    topology : MeshTopology or HexagonTopology, optional
        Mesh resolution of the sheets, of the batch's kind; default :data:`SHADING_TOPOLOGY`
        for quad panels, :data:`HEXAGON_SHADING_TOPOLOGY` for hexagonal ones.
    samples : int, default 24
        Resolution across the footprint: ``3 samples`` scan lines (the midlines of equal
        strips), along each of which the blocked length is measured exactly.
    standoff_m : float, default 0.05
        Distance of the footprint (window or wall) behind the flat sheet [m], ``>= 0``.
    tessellated : bool, default True
        Surround each panel by copies of itself in the same fold state (an unbounded facade
        of ``L x W`` cells, or of hexagons edge to edge); ``False`` for a lone panel.
    max_cells : int, default 32
        Most cells a ray is followed across within the meshes' height range (only a sun
        within about a degree of the facade plane reaches it).

    Returns
    -------
    Shading
        ``blocked_fraction`` in ``[0, 1]`` (exactly 1 where the sheets leave no gap on any
        line; 0 where not sunlit) and the ``sunlit`` mask, each of shape ``(N,)``.

    Raises
    ------
    TypeError
        If ``batch`` is neither a :class:`PanelBatch` nor a :class:`HexagonBatch`,
        ``topology`` not the topology of its kind, ``tessellated`` not a bool, or a numeric
        input is not made of real numbers.
    ValueError
        If a value is NaN or infinite, the shape parameter is outside its range, a sun vector
        is not of unit length (a zero vector included), a shape does not match N, or
        ``samples``, ``standoff_m`` or ``max_cells`` is out of range.
    """
    batch, shape, sun = _check_panels(batch, shape_parameter, sun_panel)
    options = _check_options(batch, topology, samples, standoff_m, tessellated, max_cells)
    return _shading(batch, shape, sun, *options)


def view_fraction(batch: Batch, shape_parameter: npt.ArrayLike,
                  topology: Optional[Topology] = None,
                  samples: int = DEFAULT_SAMPLES) -> FloatArray:
    """Share of each panel's footprint that is open to view along the facade normal.

    ``1 - blocked_fraction`` for a sun on the facade normal, ``s = (0, 0, 1)``: the rays run
    straight out of the facade, so the result is the share of the footprint not under the
    sheets' projection onto the facade plane, and depends neither on the standoff nor on the
    neighbours (every mesh stays inside its own cell's column). 0 for a flat panel, growing
    as the flaps stand up. For a hexagonal panel it is a share of the hexagon's area.

    Parameters
    ----------
    batch : PanelBatch or HexagonBatch
        The N panels, all of one kind.
    shape_parameter : float or array-like
        The fold state of each panel, a scalar or shape ``(N,)``, as :func:`blocked_fraction`.
    topology : MeshTopology or HexagonTopology, optional
        Mesh resolution of the sheets, as :func:`blocked_fraction`.
    samples : int, default 24
        Resolution across the footprint, as :func:`blocked_fraction`.

    Returns
    -------
    numpy.ndarray
        View fraction in ``[0, 1]``, shape ``(N,)`` (1 = fully open to view).

    Raises
    ------
    TypeError, ValueError
        As :func:`blocked_fraction`.
    """
    batch, shape, sun = _check_panels(batch, shape_parameter, (0.0, 0.0, 1.0))
    options = _check_options(batch, topology, samples, DEFAULT_STANDOFF_M, False,
                             DEFAULT_MAX_CELLS)
    return 1.0 - _shading(batch, shape, sun, *options).blocked_fraction


def closure_for_shading(fold_model: AnyFoldModel, sun_panel: npt.ArrayLike,
                        target_blocked: npt.ArrayLike,
                        closures: npt.ArrayLike = DEFAULT_CLOSURES,
                        topology: Optional[Topology] = None, samples: int = DEFAULT_SAMPLES,
                        standoff_m: float = DEFAULT_STANDOFF_M, tessellated: bool = True,
                        max_cells: int = DEFAULT_MAX_CELLS) -> ShadingChoice:
    """Choose, per panel, the candidate closure with the most view that blocks enough sun.

    Decision rule, per panel, over the candidate closures ``c`` with blocked fraction
    ``b(c)`` (for the panel's sun, :func:`blocked_fraction`) and view fraction ``v(c)``
    (:func:`view_fraction`):

    1. a sunlit panel takes, among the candidates with ``b(c) >= target``, the one with the
       largest ``v(c)``;
    2. a panel that is not sunlit (no direct sun, ``b = 0``) takes the largest ``v(c)`` of all
       candidates, as if its target were 0;
    3. if no candidate reaches the target, the panel takes the largest ``b(c)``, the nearest
       it can come.

    Ties (candidates that block all the sun, or none, or nearly flat states that block the
    same) go in turn to the larger ``b(c)`` (rules 1 and 2) or the larger ``v(c)`` (rule 3),
    then to the smaller closure: it needs less actuation, and near the open state it is the
    one that blocks more at normal incidence (the sheets' projection shrinks as the panel
    closes). So a target of 1 at normal incidence gives closure 0, the flattest sheet (which
    meets it only without a pre-fold: a pre-folded sheet leaves slivers open).

    All N x C candidates are evaluated at once as one batch of N x C panel states.

    Parameters
    ----------
    fold_model : FoldModel or HexagonFoldModel
        The closure map of the N panels.
    sun_panel : array-like
        Unit vector(s) toward the sun in the panel frame, shape ``(3,)`` or ``(N, 3)`` [-].
    target_blocked : float or array-like
        Wanted blocked fraction of the direct sun, a scalar or shape ``(N,)``, in ``[0, 1]``.
    closures : array-like, default numpy.linspace(0, 1, 21)
        Candidate closures, a non-empty 1-D array with values in ``[0, 1]``.
    topology, samples, standoff_m, tessellated, max_cells
        As :func:`blocked_fraction`.

    Returns
    -------
    ShadingChoice
        The chosen closure, the blocked and view fractions there, the sunlit mask and whether
        the target is met, each of shape ``(N,)``.

    Raises
    ------
    TypeError
        If ``fold_model`` is neither a :class:`FoldModel` nor a :class:`HexagonFoldModel`, or
        as :func:`blocked_fraction`.
    ValueError
        If ``target_blocked`` or a closure is NaN or outside ``[0, 1]``, a shape does not
        match, or as :func:`blocked_fraction`.
    """
    if not isinstance(fold_model, (FoldModel, HexagonFoldModel)):
        raise TypeError(f'fold_model must be a FoldModel or a HexagonFoldModel, got '
                        f'{type(fold_model).__name__}')
    count = len(fold_model)
    sun = _unit_vectors('sun_panel', sun_panel, count)
    target = in_range('target_blocked',
                      _per_panel('target_blocked', target_blocked, count), 0.0, 1.0)
    candidates = real_array('closures', closures)
    if candidates.ndim != 1 or candidates.size == 0:
        raise ValueError(f'closures must be a non-empty 1-D array, got shape {candidates.shape}')
    in_range('closures', candidates, 0.0, 1.0)
    topology, samples, standoff, tessellated, max_cells = _check_options(
        fold_model.batch, topology, samples, standoff_m, tessellated, max_cells)

    # Row n * C + c of the candidate batch is panel n at closure c.
    size = candidates.size
    shape = np.stack([fold_model.state_from_closure(c).shape_parameter for c in candidates],
                     axis=-1).reshape(-1)
    batch = fold_model.batch.take(np.repeat(np.arange(count), size))
    blocked = _shading(batch, shape, np.repeat(sun, size, axis=0), topology, samples, standoff,
                       tessellated, max_cells).blocked_fraction.reshape(count, size)
    normal = np.tile([0.0, 0.0, 1.0], (count * size, 1))
    views = 1.0 - _shading(batch, shape, normal, topology, samples, standoff, False,
                           max_cells).blocked_fraction.reshape(count, size)

    sunlit = sun[:, 2] > SUNLIT_MIN_SZ
    best = choose_candidate(candidates, blocked, views, sunlit, target)
    rows = np.arange(count)
    chosen_blocked = blocked[rows, best]
    return ShadingChoice(closure=candidates[best], blocked_fraction=chosen_blocked,
                         view_fraction=views[rows, best], sunlit=sunlit,
                         meets_target=chosen_blocked >= np.where(sunlit, target, 0.0))


def choose_candidate(closures: npt.ArrayLike, blocked: FloatArray, views: FloatArray,
                     sunlit: BoolArray, target: FloatOrArray) -> IntArray:
    """Index (N,) of the candidate each panel takes by the rule of :func:`closure_for_shading`.

    Shared by every caller, so the rule lives in one place. A candidate counts as meeting
    the target if its blocked fraction is at least ``target - 1e-9``.

    Parameters
    ----------
    closures : array-like
        The C candidate closures, shape ``(C,)`` [-] (0 open ... 1 closed).
    blocked : numpy.ndarray
        Blocked fraction of each panel at each candidate, shape ``(N, C)`` [-]; for a
        look-ahead window, each candidate's worst blocked fraction over the window.
    views : numpy.ndarray
        View fraction of each panel at each candidate, shape ``(N, C)`` [-].
    sunlit : numpy.ndarray
        ``True`` where the panel gets direct sun, shape ``(N,)``.
    target : float or numpy.ndarray
        Wanted blocked fraction, a scalar or shape ``(N,)`` [-]; ignored where not sunlit.

    Returns
    -------
    numpy.ndarray
        Index into ``closures`` of each panel's choice, shape ``(N,)``.
    """
    count, size = blocked.shape
    wanted = np.where(sunlit, target, 0.0)[:, None]
    # Interpolated fractions may miss a target they meet by a rounding error.
    feasible = blocked >= wanted - 1e-9
    reachable = np.any(feasible, axis=1, keepdims=True)
    first = np.where(reachable, views, blocked)
    second = np.where(reachable, blocked, views)
    smaller = np.broadcast_to(-np.asarray(closures), (count, size))
    # lexsort sorts by its last key first; the best candidate ends up last.
    return np.lexsort((smaller, second, first, feasible), axis=-1)[:, -1]


def _check_panels(batch: Batch, shape_parameter: npt.ArrayLike,
                  sun_panel: npt.ArrayLike) -> tuple[Batch, FloatArray, FloatArray]:
    if isinstance(batch, PanelBatch):
        count = len(batch)
        shape = in_range('k', _per_panel('k', shape_parameter, count), 0.0, elastica.K_MAX)
    elif isinstance(batch, HexagonBatch):
        count = len(batch)
        shape = in_range('centre_rise_m', _per_panel('centre_rise_m', shape_parameter, count),
                         0.0, np.inf, ' m')
        highest = batch.circumradius_m * np.sin(MAX_SPOKE_TILT_RAD)
        above = shape > highest
        if np.any(above):
            index = int(np.flatnonzero(above)[0])
            raise ValueError(f'centre_rise_m of panel {index} is {shape[index]:g} m, above '
                             f'the highest rise of the model, R sin(MAX_SPOKE_TILT_RAD) = '
                             f'{highest[index]:.4g} m')
    else:
        raise TypeError(f'batch must be a PanelBatch or a HexagonBatch, got '
                        f'{type(batch).__name__}')
    return batch, shape, _unit_vectors('sun_panel', sun_panel, count)


def _check_options(batch: Batch, topology: Optional[Topology], samples: int, standoff_m: float,
                   tessellated: bool, max_cells: int) -> tuple[Topology, int, float, bool, int]:
    if topology is None:
        topology = (HEXAGON_SHADING_TOPOLOGY if isinstance(batch, HexagonBatch)
                    else SHADING_TOPOLOGY)
    if not is_topology_for(batch, topology):
        wanted = 'HexagonTopology' if isinstance(batch, HexagonBatch) else 'MeshTopology'
        raise TypeError(f'topology must be a {wanted} for a {type(batch).__name__}, got '
                        f'{type(topology).__name__}')
    for name, value in (('samples', samples), ('max_cells', max_cells)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
            raise ValueError(f'{name} must be a positive integer, got {value!r}')
    standoff = real_scalar('standoff_m', standoff_m)
    if standoff < 0.0:
        raise ValueError(f'standoff_m must not be negative, got {standoff:g} m')
    if not isinstance(tessellated, (bool, np.bool_)):
        raise TypeError(f'tessellated must be a bool, got {tessellated!r}')
    return topology, int(samples), standoff, bool(tessellated), int(max_cells)


def _per_panel(name: str, value: npt.ArrayLike, count: int) -> FloatArray:
    array = real_array(name, value)
    try:
        return np.broadcast_to(array, (count,))
    except ValueError:
        raise ValueError(f'{name} has shape {array.shape}; expected a scalar or ({count},) '
                         f'for {count} panels') from None


def _unit_vectors(name: str, value: npt.ArrayLike, count: int) -> FloatArray:
    array = real_array(name, value)
    if array.shape not in ((3,), (count, 3)):
        raise ValueError(f'{name} has shape {array.shape}; expected (3,) or ({count}, 3) for '
                         f'{count} panels')
    array = np.broadcast_to(array, (count, 3))
    norm = np.linalg.norm(array, axis=-1)
    bad = np.abs(norm - 1.0) > _UNIT_TOLERANCE
    if np.any(bad):
        index = int(np.flatnonzero(bad)[0])
        raise ValueError(f'{name} must hold unit vectors toward the sun; vector {index} has '
                         f'length {norm[index]:.9g}')
    return array / norm[:, None]


def _shading(batch: Batch, shape: FloatArray, sun: FloatArray, topology: Topology, samples: int,
             standoff: float, tessellated: bool, max_cells: int) -> Shading:
    """Blocked fractions of validated inputs; the panels are meshed a chunk at a time."""
    sunlit = sun[:, 2] > SUNLIT_MIN_SZ
    blocked = np.zeros(len(batch))
    lit = np.flatnonzero(sunlit)
    hexagonal = isinstance(batch, HexagonBatch)
    lines = (scan_lines.hexagon_lines(samples, hexagon_tiling.SIDE_NORMALS) if hexagonal
             else scan_lines.quad_lines(samples))
    chord = scan_lines.chord_length(lines)
    # The mesher and the caster of the batch's kind (its topology's too: _check_options).
    kind: tuple[Callable[..., FoldMesh], Callable[..., FloatArray]] = (
        (hexagon_mesh, _cast_hexagon) if hexagonal else (fold_mesh, _cast))
    mesh, cast = kind
    for start in range(0, lit.size, _PANEL_CHUNK):
        index = lit[start:start + _PANEL_CHUNK]
        chunk = batch.take(index)
        vertices = mesh(chunk, shape[index], topology).vertices
        covered = cast(chunk, vertices, topology.faces, sun[index], lines, standoff,
                       tessellated, max_cells)
        blocked[index] = covered / chord
    return Shading(blocked_fraction=blocked, sunlit=sunlit)


def _cast(batch: PanelBatch, vertices: FloatArray, faces: IntArray, sun: FloatArray,
          lines: ScanLines, standoff: float, tessellated: bool, max_cells: int) -> FloatArray:
    """(n,) blocked length of the scan lines of n sunlit panels under their (copied) meshes.

    Every ray is started where it enters the meshes' height range, at ``z0``: the mesh lies
    above. Its start is ``p + a``, ``p`` the footprint point and ``a`` the horizontal run from
    the footprint to ``z0``. The whole cells ``G`` of ``a`` are taken out so the numbers stay
    small, and the ray is tested against the home mesh from each start ``p + a - G - h`` for
    the cells ``h`` it can cross (the mesh copy in cell ``G + h`` seen from the home cell).
    """
    cell = np.stack([batch.length_m, batch.width_m], axis=-1)
    z = vertices[..., 2]
    bottom = np.maximum(z.min(axis=1), -standoff)
    height = np.maximum(z.max(axis=1) - bottom, 0.0)
    run = sun[:, :2] / sun[:, 2:3]
    with np.errstate(over='ignore', invalid='ignore'):
        start = (bottom + standoff)[:, None] * run / cell
        whole = np.where(np.isfinite(start), np.round(start), 0.0)
        start = np.where(np.isfinite(start), start - whole, 0.0)
    span = height[:, None] * run / cell
    # A lone panel's own cell is only ever near the start of the run, so the limit on the
    # run is exact for it.
    length = np.abs(span).sum(axis=-1)
    span = span * np.minimum(1.0, max_cells / np.maximum(length, 1e-300))[:, None]
    panel, shift = _cells_crossed(start, span)
    if not tessellated:
        home = np.all(shift + whole[panel] == 0.0, axis=-1)
        panel, shift = panel[home], shift[home]
    # Shadows of the triangles on the plane z = z0 of the ray starts, for culling.
    shadow = vertices[..., :2] - (z - bottom[:, None])[..., None] * run[:, None, :]
    corners = shadow[:, faces]
    rows = _Rows(owner=panel, origin=(start[panel] - shift) * cell[panel],
                 origin_z=bottom[panel], cell=cell[panel])
    return _covered(_triangle_factors(vertices, faces, sun), corners, corners.min(axis=2),
                    corners.max(axis=2), rows, lines, len(batch))


def _cast_hexagon(batch: HexagonBatch, vertices: FloatArray, faces: IntArray, sun: FloatArray,
                  lines: ScanLines, standoff: float, tessellated: bool,
                  max_cells: int) -> FloatArray:
    """(n,) blocked length of the scan lines of n sunlit hexagonal panels under their meshes.

    As :func:`_cast`, on the hexagonal lattice of :mod:`.hexagon_tiling`: the rays start at
    ``z0`` at ``p + a``, the lattice point nearest ``a`` is taken out (``G``), and the home
    mesh is tested from ``p + a - G - c`` for every lattice point ``c`` whose mesh copy the
    rays can reach (within the footprint's radius plus the mesh's of the run). The run is cut
    to ``max_cells`` across-flats widths.
    """
    box = hexagon_tiling.bounding_box_m(batch.circumradius_m)
    basis = hexagon_tiling.lattice_basis(batch.circumradius_m)
    z = vertices[..., 2]
    bottom = np.maximum(z.min(axis=1), -standoff)
    height = np.maximum(z.max(axis=1) - bottom, 0.0)
    run = sun[:, :2] / sun[:, 2:3]
    with np.errstate(over='ignore', invalid='ignore'):
        start = (bottom + standoff)[:, None] * run
        whole = np.round(np.einsum('nij,nj->ni', np.linalg.inv(basis), start))
        finite = np.all(np.isfinite(start), axis=-1) & np.all(np.isfinite(whole), axis=-1)
        whole = np.where(finite[:, None], whole, 0.0)
        start = np.where(finite[:, None], start - np.einsum('nij,nj->ni', basis, whole), 0.0)
    span = height[:, None] * run
    length = np.linalg.norm(span, axis=-1)
    limit = max_cells * box[:, 0]
    span = span * np.minimum(1.0, limit / np.maximum(length, 1e-300))[:, None]
    mesh_radius = np.hypot(vertices[..., 0], vertices[..., 1]).max(axis=1)
    panel, cells = hexagon_tiling.cells_crossed(start, span, basis,
                                                batch.circumradius_m + mesh_radius)
    if not tessellated:
        home = np.all(cells + whole[panel] == 0.0, axis=-1)
        panel, cells = panel[home], cells[home]
    shadow = vertices[..., :2] - (z - bottom[:, None])[..., None] * run[:, None, :]
    # The hexagon is the intersection of three slabs across its pairs of opposite sides.
    axes = hexagon_tiling.SIDE_NORMALS
    corners_xy = shadow[:, faces]
    corners = corners_xy @ axes.T
    origin = start[panel] - np.einsum('kij,kj->ki', basis[panel], cells)
    rows = _Rows(owner=panel, origin=origin, origin_z=bottom[panel], cell=box[panel])
    half = np.repeat(box[panel, :1] / 2, len(axes), axis=1)
    return _covered(_triangle_factors(vertices, faces, sun), corners_xy, corners.min(axis=2),
                    corners.max(axis=2), rows, lines, len(batch), slabs=(axes, half))


def _cells_crossed(start: FloatArray, span: FloatArray) -> tuple[IntArray, FloatArray]:
    """Cells (in cell units, relative to the home cell) each panel's rays can pass through.

    The rays of a panel start anywhere in the home cell shifted by ``start`` and run by
    ``tau span``, ``0 <= tau <= 1``, across the height range. Cell ``h`` is crossed if
    ``|h - start - tau span| < 1`` in x and y for some ``tau``: the shifted cell overlaps it.
    Returns the panel index and the cell of every (panel, cell) pair, grouped by panel.
    """
    reach = 1.0 - 1e-9
    low = np.ceil(np.minimum(start, start + span) - reach).astype(np.int64)
    high = np.floor(np.maximum(start, start + span) + reach).astype(np.int64)
    extent = high - low + 1
    counts = extent[:, 0] * extent[:, 1]
    panel = np.repeat(np.arange(start.shape[0]), counts)
    local = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    cells = low[panel] + np.stack([local // extent[panel, 1], local % extent[panel, 1]], axis=-1)
    offset = cells - start[panel]
    direction = span[panel]
    moving = np.abs(direction) > 1e-12
    with np.errstate(divide='ignore', invalid='ignore'):
        first = (offset - reach) / direction
        last = (offset + reach) / direction
    inside = np.abs(offset) < reach
    enter = np.where(moving, np.minimum(first, last), np.where(inside, -np.inf, np.inf))
    leave = np.where(moving, np.maximum(first, last), np.where(inside, np.inf, -np.inf))
    crossed = (np.maximum(enter.max(axis=-1), 0.0) <= np.minimum(leave.min(axis=-1), 1.0))
    return panel[crossed], cells[crossed].astype(np.float64)


def _triangle_factors(vertices: FloatArray, faces: IntArray,
                      sun: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Per panel and triangle, Moller-Trumbore's barycentric coordinates as affine maps.

    Returns ``(gradient, constant)`` with ``gradient`` (n, 3, 3F) and ``constant`` (n, 3F):
    ``u = o . gradient + constant`` for the F triangles' ``u = (o - v0) . (s x e2) / det``,
    then their ``v = (o - v0) . (e1 x s) / det``, then ``w = 1 - u - v``, for ray origins
    ``o``. Edge-on triangles get ``u = -1`` everywhere, so no ray hits them.
    """
    triangles = vertices[:, faces]
    v0 = triangles[:, :, 0]
    e1 = triangles[:, :, 1] - v0
    e2 = triangles[:, :, 2] - v0
    direction = np.broadcast_to(sun[:, None, :], e1.shape)
    p_vector = np.cross(direction, e2)
    det = np.einsum('nfi,nfi->nf', e1, p_vector)
    facing = np.abs(det) > _EDGE_ON * np.linalg.norm(e1, axis=-1) * np.linalg.norm(e2, axis=-1)
    scale = np.where(facing, 1.0 / np.where(facing, det, 1.0), 0.0)[..., None]
    u_gradient = p_vector * scale
    v_gradient = np.cross(e1, direction) * scale
    u_constant = np.where(facing, -np.einsum('nfi,nfi->nf', v0, u_gradient), -1.0)
    v_constant = -np.einsum('nfi,nfi->nf', v0, v_gradient)
    gradient = np.concatenate([u_gradient, v_gradient, -u_gradient - v_gradient], axis=1)
    constant = np.concatenate([u_constant, v_constant, 1.0 - u_constant - v_constant], axis=1)
    return np.swapaxes(gradient, 1, 2), constant


@dataclass(frozen=True)
class _Rows:
    """Ray batches, one per (panel, cell crossed); each field has R rows."""

    owner: np.ndarray
    """Panel of each row, ``(R,)``."""
    origin: np.ndarray
    """Ray start of the footprint centre ``(ox, oy)`` in the home frame, ``(R, 2)`` [m]."""
    origin_z: np.ndarray
    """Height of the ray starts, ``(R,)`` [m]."""
    cell: np.ndarray
    """Cell size ``(L, W)`` of the row's panel (a hexagon's bounding box), ``(R, 2)`` [m]."""


def _covered(factors: tuple[FloatArray, FloatArray], corners: FloatArray, shadow_low: FloatArray,
             shadow_high: FloatArray, rows: '_Rows', lines: ScanLines, count: int,
             slabs: Optional[tuple[FloatArray, FloatArray]] = None) -> FloatArray:
    """Blocked length (count,) of each panel's scan lines: the union of all rows' intervals.

    The ray of the point ``(xi, eta)`` in row r starts at ``(xi L + ox, eta W + oy, z0)``, so
    the barycentric coordinates of every triangle are ``(xi, eta, 1) @ M_r``, and along a scan
    line ``origin + t direction`` they are affine in ``t``: each triangle blocks one interval
    of the line. Only triangles whose shadow's bounding box (``shadow_low``, ``shadow_high``:
    (n, F, 2), on the start plane) reaches the footprint are tested, each on the lines that
    its shadow (``corners``, (n, F, 3, 2) [m]) spans. With ``slabs = (axes, half)`` the
    footprint is the intersection of the slabs ``|a . (p - o)| <= half`` (axes (A, 2), half
    (R, A)) and ``shadow_low``, ``shadow_high`` (n, F, A) are the extents of the triangles'
    shadows along the same axes.
    """
    triangles = shadow_low.shape[1]
    relevant = np.empty((rows.owner.size, triangles), dtype=bool)
    for begin in range(0, rows.owner.size, 4096):
        part = slice(begin, begin + 4096)
        owner = rows.owner[part]
        if slabs is None:
            half = rows.cell[part, None, :] / 2 * (1 + 1e-6)
            origin = rows.origin[part, None, :]
        else:
            half = slabs[1][part, None, :] * (1 + 1e-6)
            origin = (rows.origin[part] @ slabs[0].T)[:, None, :]
        relevant[part] = np.all((shadow_low[owner] - origin <= half)
                                & (shadow_high[owner] - origin >= -half), axis=-1)
    row, triangle = np.nonzero(relevant)
    pieces = []
    block = max(1, _ELEMENT_BUDGET // (4 * lines.start.size))
    for begin in range(0, row.size, block):
        part = slice(begin, begin + block)
        pieces.append(_block_intervals(factors, corners, rows, row[part], triangle[part],
                                       lines))
    if not pieces:
        return np.zeros(count)
    owner, line, start, end = (np.concatenate(part) for part in zip(*pieces))
    return scan_lines.covered_length(owner, line, start, end, count, lines.start.size)


def _block_intervals(factors: tuple[FloatArray, FloatArray], corners: FloatArray, rows: '_Rows',
                     row: IntArray, triangle: IntArray, lines: ScanLines
                     ) -> tuple[IntArray, IntArray, npt.NDArray[np.float32],
                                npt.NDArray[np.float32]]:
    """Intervals of the scan lines that the (row, triangle) pairs (P,) block.

    Returns the panel, the line and the ends ``t`` of every non-empty interval (K,): the part
    of the line's chord where all three barycentric coordinates of the pair's triangle are at
    least ``-_BARYCENTRIC_SLACK``, on every line that the triangle's shadow spans.

    The lines' origins lie on one line through the footprint's centre, ``offset o`` with ``o``
    the origin of unit offset, so along line l a coordinate is ``alpha + offset_l beta +
    t gamma``, with ``alpha``, ``beta`` and ``gamma`` per pair.
    """
    gradient, constant = factors
    count = constant.shape[1] // 3
    owner = rows.owner[row]
    columns = triangle[:, None] + count * np.arange(3)
    g = gradient[owner[:, None], :, columns]
    # (P, 3) per coordinate (u, v, w): its gradient in (xi, eta) and value at (0, 0) in the row.
    d_xi = g[..., 0] * rows.cell[row, 0:1]
    d_eta = g[..., 1] * rows.cell[row, 1:2]
    alpha = (constant[owner[:, None], columns] + g[..., 0] * rows.origin[row, 0:1]
             + g[..., 1] * rows.origin[row, 1:2] + g[..., 2] * rows.origin_z[row, None])
    beta = d_xi * lines.unit_origin[0] + d_eta * lines.unit_origin[1]
    gamma = d_xi * lines.direction[0] + d_eta * lines.direction[1]
    # Along line l a coordinate is at least -slack for t >= a + offset_l b where it rises
    # (gamma > 0), for t <= a + offset_l b where it falls. One constant along the lines (an
    # edge-on triangle's u = -1, or an edge exactly along them) counts as rising by a tiny
    # amount: it keeps a whole line or none of it.
    rising = gamma >= 0.0
    inverse = 1.0 / np.where(gamma == 0.0, 1e-30, gamma)
    a = (-_BARYCENTRIC_SLACK - alpha) * inverse
    b = -beta * inverse
    # (12, P) in float32 (t to about 1e-7 of the footprint): per coordinate the lower
    # bound's a and b, then the upper bound's.
    coefficients = np.concatenate([np.where(rising, a, -np.inf), np.where(rising, b, 0.0),
                                   np.where(rising, np.inf, a), np.where(rising, 0.0, b)],
                                  axis=1).T.astype(np.float32)
    # The lines the triangle's shadow spans, from its corners' offsets across the lines.
    offsets = ((corners[owner, triangle] - rows.origin[row, None, :])
               / rows.cell[row, None, :]) @ lines.across
    first, last = lines.index_range(offsets.min(axis=1), offsets.max(axis=1))
    spans = np.maximum(last - first + 1, 0)
    line = np.repeat(first - np.cumsum(spans) + spans, spans) + np.arange(spans.sum())
    offset = lines.offset32[line]
    c = np.repeat(coefficients, spans, axis=1)
    low = lines.start32[line]
    high = lines.end32[line]
    for k in range(3):
        np.maximum(low, c[k] + offset * c[3 + k], out=low)
        np.minimum(high, c[6 + k] + offset * c[9 + k], out=high)
    blocked = high > low
    return np.repeat(owner, spans)[blocked], line[blocked], low[blocked], high[blocked]
