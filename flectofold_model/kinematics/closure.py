"""Closure <-> apex fold angle <-> mid-rib elastica <-> support displacement, per panel.

Closure is what operators command: 0 is open (the unactuated panel, holding only its pre-fold)
and 1 is closed. It is linear in the apex fold angle::

    closure = (rho0 - rho_prefold) / (rho_closed - rho_prefold)

and the apex fold angle grows strictly with the support displacement, so every map here is
monotone and invertible. The closed fold angle ``rho_closed`` is the smaller of

* the collision limit: the flap corners at the supports swing toward the symmetry plane
  ``y = 0``; with ``y_e`` the fold line's distance from it there, they stay
  ``closed_clearance_m / 2`` away while
  ``cos(rho0) >= (clearance / 2 - y_e) / (W / 2 - y_e)``, and no other flap point comes nearer;
* the elastica limit: mid-rib end rotation :data:`~.elastica.MAX_END_ROTATION_RAD`.

The support displacement is counted from the unactuated state: the chord B'C' is
``L - Delta_prefold - support_displacement_m``, each support moving half of it.
"""

from dataclasses import dataclass
from typing import Optional

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import FloatArray, FloatOrArray, in_range
from flectofold_model.kinematics import elastica
from flectofold_model.kinematics.closure_map import LinearClosureMap
from flectofold_model.kinematics.mesh import DEFAULT_TOPOLOGY, fold_mesh, FoldMesh, MeshTopology
from flectofold_model.kinematics.panel import PanelBatch
from flectofold_model.kinematics.reflection import (apex_fold_angle, crease_mismatch_m, flap_tip,
                                                    sag_for_apex_fold_angle)


@dataclass(frozen=True)
class FoldState:
    """Kinematic state of every panel of a batch; each field has shape ``(N,)``."""

    closure: np.ndarray
    """0 open ... 1 closed."""
    support_displacement_m: np.ndarray
    """Shortening of the support chord B'C' since the unactuated state [m]."""
    elastica_k: np.ndarray
    """Elliptic modulus of the mid-rib elastica."""
    midrib_sag_m: np.ndarray
    """Mid-span sag of the mid-rib over its pins [m]."""
    midrib_end_rotation_rad: np.ndarray
    """Rotation of the mid-rib at the supports [rad]."""
    midrib_peak_curvature_per_m: np.ndarray
    """Mid-rib curvature at mid-span [1/m]."""
    apex_fold_angle_rad: np.ndarray
    """Fold angle (deviation from flat) at the crease apex [rad]."""
    tip_travel_m: np.ndarray
    """Distance flap tip A moved from the unactuated state (D moves the same) [m]."""
    amplification: np.ndarray
    """``tip_travel_m / support_displacement_m``; NaN at zero displacement."""

    @property
    def shape_parameter(self) -> FloatArray:
        """The one number that fixes the shape: the elastica modulus."""
        return self.elastica_k


class FoldModel(LinearClosureMap):
    """The closure map of a :class:`~.panel.PanelBatch`, vectorised over panels.

    Construction computes each panel's open (pre-fold) and closed states once. It raises
    ``ValueError`` for a pre-fold at or beyond the closed limit, and for a hinge zone narrower
    than the gap between the reflected crease and the drawn fold line (the model's geometric
    error, which the real hinge has to take up).
    """

    crease_name = 'reflected crease'
    hinge_remedy = 'widen the hinge zone or use a larger fold radius'
    batch: PanelBatch

    def __init__(self, batch: PanelBatch) -> None:
        if not isinstance(batch, PanelBatch):
            raise TypeError(f'FoldModel needs a PanelBatch, got {type(batch).__name__}')
        self.batch = batch
        self.open_fold_angle_rad = batch.prefold_rad
        self.closed_fold_angle_rad = np.minimum(self._collision_limit(), self._elastica_limit())
        too_folded = self.open_fold_angle_rad >= self.closed_fold_angle_rad
        if np.any(too_folded):
            index = int(np.flatnonzero(too_folded)[0])
            raise ValueError(
                f'panel {index}: prefold_rad={self.open_fold_angle_rad[index]:g} rad is at or '
                f'beyond the closed limit {self.closed_fold_angle_rad[index]:.4g} rad')
        self.open_k = self._k_for_fold_angle(self.open_fold_angle_rad)
        self._open_shortening_m = elastica.shortening_from_k(self.open_k, batch.length_m)
        self.closed_k = self._k_for_fold_angle(self.closed_fold_angle_rad)
        self.max_support_displacement_m = self.displacement_from_k(self.closed_k)
        self._open_tip = flap_tip(batch, elastica.sag_from_k(self.open_k, batch.length_m), +1)
        self.crease_mismatch_m = np.maximum(crease_mismatch_m(batch, self.open_k),
                                            crease_mismatch_m(batch, self.closed_k))
        self._check_hinges()

    @property
    def open_shape(self) -> FloatArray:
        """Shape parameter (elastica modulus) of the open state, (N,)."""
        return self.open_k

    @property
    def closed_shape(self) -> FloatArray:
        """Shape parameter (elastica modulus) of the closed state, (N,)."""
        return self.closed_k

    def shape_from_fold_angle(self, fold_angle_rad: npt.ArrayLike) -> FloatArray:
        """Elastica modulus for apex fold angles [rad] between the open and closed limits."""
        self.closure_from_fold_angle(fold_angle_rad)
        return self._k_for_fold_angle(self._per_panel('fold_angle_rad', fold_angle_rad))

    def mesh(self, shape: npt.ArrayLike, topology: Optional[MeshTopology] = None,
             dtype: npt.DTypeLike = np.float64, out: Optional[FoldMesh] = None) -> FoldMesh:
        """Folded meshes at shape parameters (elastica moduli) ``shape`` (N,)."""
        return fold_mesh(self.batch, shape, topology or DEFAULT_TOPOLOGY, dtype, out)

    def _collision_limit(self) -> FloatArray:
        batch = self.batch
        cosine = ((batch.closed_clearance_m / 2 - batch.end_y_m)
                  / (batch.width_m / 2 - batch.end_y_m))
        return np.arccos(np.clip(cosine, -1.0, 1.0))

    def _elastica_limit(self) -> FloatArray:
        return apex_fold_angle(self.batch, elastica.sag_from_k(elastica.K_MAX,
                                                               self.batch.length_m))

    def _k_for_fold_angle(self, fold_angle_rad: FloatArray) -> FloatArray:
        sag = sag_for_apex_fold_angle(self.batch, fold_angle_rad)
        limit = elastica.sag_from_k(elastica.K_MAX, self.batch.length_m)
        return elastica.k_from_sag(np.minimum(sag, limit), self.batch.length_m)

    def displacement_from_k(self, k: FloatOrArray) -> FloatArray:
        """Support displacement [m] since the open state for elastica moduli ``k``."""
        shortening = elastica.shortening_from_k(k, self.batch.length_m)
        return np.maximum(shortening - self._open_shortening_m, 0.0)

    def k_from_displacement(self, support_displacement_m: npt.ArrayLike) -> FloatArray:
        """Elastica modulus for support displacements [m] in ``[0, max]``."""
        displacement = self._per_panel('support_displacement_m', support_displacement_m)
        in_range('support_displacement_m / its closed value',
                 displacement / self.max_support_displacement_m, 0.0, 1.0)
        return elastica.k_from_shortening(
            np.minimum(displacement + self._open_shortening_m,
                       elastica.shortening_from_k(self.closed_k, self.batch.length_m)),
            self.batch.length_m)

    def state_from_closure(self, closure: npt.ArrayLike) -> FoldState:
        """Full :class:`FoldState` for closure in [0, 1] (scalar or one per panel)."""
        fold_angle = self.fold_angle_from_closure(closure)
        return self._state(self._k_for_fold_angle(fold_angle))

    def state_from_displacement(self, support_displacement_m: npt.ArrayLike) -> FoldState:
        """Full :class:`FoldState` for support displacements [m] (scalar or one per panel)."""
        k = self.k_from_displacement(support_displacement_m)
        return self._state(k, self._per_panel('support_displacement_m', support_displacement_m))

    def state_from_k(self, k: npt.ArrayLike) -> FoldState:
        """Full :class:`FoldState` for elastica moduli between the open and closed states."""
        k = self._per_panel('elastica_k', k)
        in_range('elastica_k', k - self.open_k, 0.0, np.inf)
        in_range('elastica_k', k - self.closed_k, -np.inf, 0.0)
        return self._state(k)

    state_from_shape = state_from_k

    def _state(self, k: FloatArray, displacement: Optional[FloatArray] = None) -> FoldState:
        length = self.batch.length_m
        sag = elastica.sag_from_k(k, length)
        fold_angle = apex_fold_angle(self.batch, sag)
        closure = ((fold_angle - self.open_fold_angle_rad)
                   / (self.closed_fold_angle_rad - self.open_fold_angle_rad))
        if displacement is None:
            displacement = self.displacement_from_k(k)
        travel = np.linalg.norm(flap_tip(self.batch, sag, +1) - self._open_tip, axis=-1)
        with np.errstate(divide='ignore', invalid='ignore'):
            amplification = np.where(displacement > 0, travel / displacement, np.nan)
        return FoldState(
            closure=np.clip(closure, 0.0, 1.0),
            support_displacement_m=displacement,
            elastica_k=k,
            midrib_sag_m=sag,
            midrib_end_rotation_rad=elastica.end_rotation_from_k(k),
            midrib_peak_curvature_per_m=elastica.peak_curvature_from_k(k, length),
            apex_fold_angle_rad=fold_angle,
            tip_travel_m=travel,
            amplification=amplification,
        )
