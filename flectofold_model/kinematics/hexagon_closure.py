"""Closure <-> apex fold angle <-> centre rise of hexagonal panels, vectorised over panels.

The state of a hexagonal panel is the rise ``d`` of its centre point along the triangle's
normal (the cushion's stroke). Closure is linear in the apex fold angle, as for the quad
panel: ``closure = (rho0 - rho_prefold) / (rho_closed - rho_prefold)``; the apex fold angle
grows strictly with the rise (the model checks it on a grid of states at construction), so
every map here is monotone and invertible. The closed state is the first of

* the flap tips' limit: the three tips close toward the axis over the centre, as a trap does;
  they stay ``closed_clearance_m`` apart (each ``clearance / sqrt 3`` from the axis);
* the neighbours' limit: neighbouring flaps are mirror images across the vertical plane
  through their shared vertex, so a flap must not reach that plane (its boundary is sampled);
* the lean limit: an apex fold angle of :data:`MAX_APEX_FOLD_ANGLE_RAD`. A hexagonal
  panel's flaps are narrower than the central part is wide, so their tips cannot meet over
  the centre; folded further, each flap would lean back over the central part toward lying on
  it. The quad panel's elastica limit plays the same part.

The search for the closed rise stays below a spoke tilt of :data:`MAX_SPOKE_TILT_RAD`.
"""

from dataclasses import dataclass, fields
import math
from typing import Optional

import numpy as np
import numpy.typing as npt
from scipy.optimize.elementwise import find_root

from flectofold_model._validate import BoolArray, FloatArray, in_range, IntArray
from flectofold_model.kinematics import hexagon_cone as cone
from flectofold_model.kinematics.closure_map import LinearClosureMap
from flectofold_model.kinematics.hexagon_mesh import (DEFAULT_HEXAGON_TOPOLOGY, hexagon_mesh,
                                                      HexagonTopology)
from flectofold_model.kinematics.hexagon_panel import (hexagon_radius_m, HexagonBatch,
                                                       SECTOR_RAD)
from flectofold_model.kinematics.hexagon_reflection import SectorGeometry
from flectofold_model.kinematics.mesh import FoldMesh

#: Largest apex fold angle [rad]: the flaps lean 30 degrees past upright over the centre.
MAX_APEX_FOLD_ANGLE_RAD = math.radians(120.0)
#: Largest spoke tilt searched [rad]: a steeper cone is no longer a small rise.
MAX_SPOKE_TILT_RAD = math.radians(25.0)
_BISECTIONS = 52
_ROOT_TOLERANCES = {'xatol': 1e-15, 'xrtol': 4 * np.finfo(float).eps}
_MONOTONE_CHECK_STATES = 33


@dataclass(frozen=True)
class HexagonFoldState:
    """Kinematic state of every hexagonal panel of a batch; each field has shape ``(N,)``."""

    closure: np.ndarray
    """0 open ... 1 closed."""
    centre_rise_m: np.ndarray
    """Rise of the centre point along the triangle's normal [m]."""
    vertex_displacement_m: np.ndarray
    """Inward travel of each triangle vertex, ``R - sqrt(R**2 - d**2)`` [m]."""
    spoke_tilt_rad: np.ndarray
    """Downward tilt of the spokes from the centre to the vertices [rad]."""
    cone_amplitude_rad: np.ndarray
    """Elevation amplitude of the central cone between spokes [rad]."""
    apex_fold_angle_rad: np.ndarray
    """Fold angle (deviation from flat) at each crease apex [rad]."""
    tip_travel_m: np.ndarray
    """Distance each flap tip moved from the unactuated state [m]."""
    amplification: np.ndarray
    """``tip_travel_m`` over the rise travelled since the open state; NaN there."""

    @property
    def shape_parameter(self) -> FloatArray:
        """The one number that fixes the shape: the centre rise [m]."""
        return self.centre_rise_m


#: What construction computes per panel (copied from the distinct panels' model).
_BUILT = ('max_rise_m', 'closed_rise_m', 'closed_fold_angle_rad', 'open_fold_angle_rad',
          'open_rise_m', '_open_tip', 'crease_mismatch_m')


def _distinct_rows(batch: HexagonBatch) -> tuple[IntArray, IntArray]:
    """Index of each distinct panel's first occurrence, and each panel's distinct row (N,)."""
    columns = np.stack([getattr(batch, field.name) for field in fields(batch)], axis=-1)
    _, first, row = np.unique(columns, axis=0, return_index=True, return_inverse=True)
    return first, row.reshape(-1)


def _wedge_margin_m(batch: HexagonBatch, geometry: SectorGeometry) -> FloatArray:
    """Smallest distance of flap 0's boundary from the planes through T_0 and T_1 [m]."""
    phi = np.linspace(0.0, SECTOR_RAD, 49)[1:-1]
    boundary = geometry.flap_points(phi, hexagon_radius_m(batch.circumradius_m[:, None], phi))
    azimuth = np.arctan2(boundary[..., 1], boundary[..., 0])
    radius = np.hypot(boundary[..., 0], boundary[..., 1])
    from_first = np.mod(azimuth - math.pi / 2, 2 * math.pi)
    inside = from_first <= SECTOR_RAD
    to_plane = radius * np.sin(np.minimum(from_first, SECTOR_RAD - from_first))
    return np.min(np.where(inside, to_plane, -radius), axis=-1)


def _rise_for_fold_angle(batch: HexagonBatch, fold_angle_rad: npt.ArrayLike,
                         highest_m: npt.ArrayLike) -> FloatArray:
    """Centre rises (N,) for apex fold angles, by scipy's bracketing root finder."""
    goal = np.broadcast_to(np.asarray(fold_angle_rad, dtype=np.float64), (len(batch),))

    def miss(rise: FloatArray, target: FloatArray, index: IntArray) -> FloatArray:
        return SectorGeometry(batch.take(index), rise).apex_fold_angle_rad - target

    result = find_root(miss, (np.zeros(len(batch)), np.array(highest_m, dtype=np.float64)),
                       args=(goal, np.arange(len(batch))), tolerances=_ROOT_TOLERANCES)
    if not np.all(result.success):
        raise ArithmeticError('the centre rise for a fold angle did not converge')
    return np.clip(result.x, 0.0, highest_m)


class HexagonFoldModel(LinearClosureMap):
    """The closure map of a :class:`~.hexagon_panel.HexagonBatch`, vectorised over panels.

    Construction finds each panel's open (pre-fold) and closed rises. It raises
    ``ValueError`` for a pre-fold at or beyond the closed limit and for a hinge zone narrower
    than the gap between the crease and the drawn fold line.
    """

    crease_name = 'crease'
    hinge_remedy = 'widen the hinge zone or change fold_line_sag_m'
    batch: HexagonBatch
    # What construction computes (_BUILT), per panel.
    max_rise_m: FloatArray
    closed_rise_m: FloatArray
    open_rise_m: FloatArray
    _open_tip: FloatArray

    def __init__(self, batch: HexagonBatch) -> None:
        if not isinstance(batch, HexagonBatch):
            raise TypeError(f'HexagonFoldModel needs a HexagonBatch, got {type(batch).__name__}')
        self.batch = batch
        first, row = _distinct_rows(batch)
        self._distinct_first, self._distinct_row = first, row
        source = self if len(first) == len(batch) else HexagonFoldModel(batch.take(first))
        if source is self:
            self._build()
        else:
            for name in _BUILT:
                setattr(self, name, getattr(source, name)[row])

    def _build(self) -> None:
        """Open and closed states and the construction checks, for distinct panels."""
        batch = self.batch
        self.max_rise_m = batch.circumradius_m * math.sin(MAX_SPOKE_TILT_RAD)
        self.closed_rise_m = self._closed_rise()
        self.closed_fold_angle_rad = SectorGeometry(batch, self.closed_rise_m).apex_fold_angle_rad
        self.open_fold_angle_rad = batch.prefold_rad
        too_folded = self.open_fold_angle_rad >= self.closed_fold_angle_rad
        if np.any(too_folded):
            index = int(np.flatnonzero(too_folded)[0])
            raise ValueError(
                f'panel {index}: prefold_rad={self.open_fold_angle_rad[index]:g} rad is at or '
                f'beyond the closed limit {self.closed_fold_angle_rad[index]:.4g} rad')
        self.open_rise_m = self._rise_for_fold_angle(self.open_fold_angle_rad)
        self._open_tip = SectorGeometry(batch, self.open_rise_m).flap_tip
        self._check_monotone()
        self.crease_mismatch_m = np.maximum(
            SectorGeometry(batch, self.open_rise_m).crease_mismatch_m(),
            SectorGeometry(batch, self.closed_rise_m).crease_mismatch_m())
        self._check_hinges()

    @property
    def open_shape(self) -> FloatArray:
        """Shape parameter (centre rise [m]) of the open state, (N,)."""
        return self.open_rise_m

    @property
    def closed_shape(self) -> FloatArray:
        """Shape parameter (centre rise [m]) of the closed state, (N,)."""
        return self.closed_rise_m

    @staticmethod
    def _within_limits(batch: HexagonBatch, rise_m: FloatArray) -> BoolArray:
        geometry = SectorGeometry(batch, rise_m)
        tip = geometry.flap_tip
        tips_apart = np.hypot(tip[:, 0], tip[:, 1]) * math.sqrt(3.0) >= batch.closed_clearance_m
        return tips_apart & (_wedge_margin_m(batch, geometry) > 0.0)

    def _closed_rise(self) -> FloatArray:
        leaning = self._rise_for_fold_angle(np.full(len(self.batch), MAX_APEX_FOLD_ANGLE_RAD),
                                            self.max_rise_m)
        crowded = np.flatnonzero(~self._within_limits(self.batch, leaning))
        if crowded.size:
            batch = self.batch.take(crowded)
            low, high = np.zeros(crowded.size), leaning[crowded]
            for _ in range(_BISECTIONS):
                middle = (low + high) / 2.0
                ok = self._within_limits(batch, np.maximum(middle, 1e-9))
                low, high = np.where(ok, middle, low), np.where(ok, high, middle)
            leaning = leaning.copy()
            leaning[crowded] = low
        return leaning

    def _rise_for_fold_angle(self, fold_angle_rad: npt.ArrayLike,
                             highest: Optional[npt.ArrayLike] = None) -> FloatArray:
        high = self.closed_rise_m if highest is None else highest
        return _rise_for_fold_angle(self.batch, fold_angle_rad, high)

    def _check_monotone(self) -> None:
        fractions = np.linspace(0.0, 1.0, _MONOTONE_CHECK_STATES)
        rises = self.open_rise_m[:, None] + fractions * (self.closed_rise_m
                                                         - self.open_rise_m)[:, None]
        repeated = self.batch.take(np.repeat(np.arange(len(self)), fractions.size))
        angles = SectorGeometry(repeated, rises.ravel()).apex_fold_angle_rad
        if np.any(np.diff(angles.reshape(rises.shape), axis=-1) <= 0.0):
            raise ValueError('the apex fold angle does not grow with the centre rise: the '
                             'closure map would not invert')

    def shape_from_fold_angle(self, fold_angle_rad: npt.ArrayLike) -> FloatArray:
        """Centre rise [m] for apex fold angles [rad] between the open and closed limits."""
        self.closure_from_fold_angle(fold_angle_rad)
        return self._rise_for_fold_angle(self._per_panel('fold_angle_rad', fold_angle_rad))

    def state_from_closure(self, closure: npt.ArrayLike) -> HexagonFoldState:
        """Full :class:`HexagonFoldState` for closure in [0, 1] (scalar or one per panel)."""
        return self._state(self._rise_for_fold_angle(self.fold_angle_from_closure(closure)))

    def state_from_rise(self, centre_rise_m: npt.ArrayLike) -> HexagonFoldState:
        """Full :class:`HexagonFoldState` for centre rises [m] between open and closed."""
        rise = self._per_panel('centre_rise_m', centre_rise_m)
        in_range('centre_rise_m - its open value', rise - self.open_rise_m, -1e-12, np.inf)
        in_range('centre_rise_m - its closed value', rise - self.closed_rise_m, -np.inf, 1e-12)
        return self._state(np.clip(rise, self.open_rise_m, self.closed_rise_m))

    state_from_shape = state_from_rise

    def shape_table(self, samples: int = 257) -> FloatArray:
        """Centre rises (N, S) [m] at ``samples`` closures evenly spaced over [0, 1].

        Computed in one root-finding pass over the distinct panels, so a caller that needs
        the map many times a second (a viewer) can interpolate in it instead.
        """
        if isinstance(samples, bool) or not isinstance(samples, int) or samples < 2:
            raise ValueError(f'samples must be an integer of at least 2, got {samples!r}')
        closures = np.linspace(0.0, 1.0, samples)
        first = self._distinct_first
        rows = np.repeat(first, samples)
        opened, closed = self.open_fold_angle_rad[rows], self.closed_fold_angle_rad[rows]
        goal = opened + np.tile(closures, first.size) * (closed - opened)
        rises = _rise_for_fold_angle(self.batch.take(rows), goal, self.closed_rise_m[rows])
        return rises.reshape(first.size, samples)[self._distinct_row]

    def _state(self, rise: FloatArray) -> HexagonFoldState:
        geometry = SectorGeometry(self.batch, rise)
        fold_angle = geometry.apex_fold_angle_rad
        closure = ((fold_angle - self.open_fold_angle_rad)
                   / (self.closed_fold_angle_rad - self.open_fold_angle_rad))
        travel = np.linalg.norm(geometry.flap_tip - self._open_tip, axis=-1)
        stroke = rise - self.open_rise_m
        with np.errstate(divide='ignore', invalid='ignore'):
            amplification = np.where(stroke > 0, travel / stroke, np.nan)
        return HexagonFoldState(
            closure=np.clip(closure, 0.0, 1.0), centre_rise_m=rise,
            vertex_displacement_m=cone.vertex_displacement_m(self.batch, rise),
            spoke_tilt_rad=geometry.tilt_rad, cone_amplitude_rad=geometry.amplitude_rad,
            apex_fold_angle_rad=fold_angle, tip_travel_m=travel, amplification=amplification)

    def mesh(self, shape: npt.ArrayLike, topology: Optional[HexagonTopology] = None,
             dtype: npt.DTypeLike = np.float64, out: Optional[FoldMesh] = None) -> FoldMesh:
        """Folded meshes at shape parameters (centre rises [m]) ``shape`` (N,)."""
        return hexagon_mesh(self.batch, shape, topology or DEFAULT_HEXAGON_TOPOLOGY, dtype, out)
