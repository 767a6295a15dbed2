"""Static actuation: cushion pressure <-> mid-rib bending <-> fold angle <-> closure.

A reduced-order energy model on top of the kinematic fold model. The panel has one degree of
freedom, the elastica modulus ``k`` of the mid-rib (equivalently the closure). Bending the
mid-rib to ``k`` stores elastic energy ``U(k)``:

* the mid-rib: ``1/2 D_m w_m(s) (kappa(s) - kappa_open(s))**2`` along it, ``w_m`` the width of
  the lens at arc length ``s``;
* both flaps: each flap is a mirror image of the bent mid-rib surface, so it bends with the
  same curvature over its width ``w_f(s)``: ``2 x 1/2 D_f w_f(s) (kappa - kappa_open)**2``;
* both hinge zones: a zone of width ``b`` folded by ``rho`` bends uniformly at ``rho / b``, a
  rotational stiffness ``D_h / b`` per unit length: ``2 x 1/2 (D_h / b) (rho(s) - rho_open(s))**2``
  along the drawn fold line.

The open state is stress-free (the pre-fold is moulded in), so the panel springs back open when
the cushion is vented. The cushion of volume ``V(k)`` pushes with pressure ``p``; by virtual
work the panel is in equilibrium where ``dU/dk = p dV/dk``, so the gauge pressure that holds a
state is ``p(k) = U'(k) / V'(k)``. Where ``p(k)`` rises with ``k`` that equilibrium is stable
(``U'' - p V'' > 0``) and the map inverts, pressure -> closure, by root finding. The work of
the cushion from open to a state is ``integral p dV = U``: the actuation energy.

Limits, stated rather than hidden: the mid-rib keeps its elastica shape (the kinematic
assumption of Koerner et al.) instead of the shape a distributed cushion load would give;
membrane strains in the hinge zones, friction, gravity and the cushion's own stiffness are left
out; the hinge fold is uniform across the hinge width.
"""

from dataclasses import dataclass
import math
from typing import Iterable, Optional

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import FloatArray, FloatOrArray, IntArray, real_scalar
from flectofold_model.actuation.cushion import contact_width_m, section_area_m2, StripCushion
from flectofold_model.actuation.laminate import Laminate
from flectofold_model.actuation.static_model import (StaticActuationModel,
                                                     UnreachableClosureWarning)
from flectofold_model.kinematics import elastica
from flectofold_model.kinematics.closure import FoldModel
from flectofold_model.kinematics.mesh import fold_mesh, MeshTopology
from flectofold_model.kinematics.panel import DEMONSTRATOR_MODULE, PanelBatch, PanelGeometry
from flectofold_model.kinematics.reflection import flap_tip

#: Step in the elastica modulus of the central differences of the static maps.
DERIVATIVE_STEP = 1e-6

__all__ = ['ActuatedPanel', 'ActuationModel', 'DEMONSTRATOR_ACTUATED', 'DERIVATIVE_STEP',
           'FLECTOLINE_ACTUATED', 'UnreachableClosureWarning', 'WindResponse', 'actuated_like',
           'radius_study']


@dataclass(frozen=True)
class ActuatedPanel:
    """A panel with its laminates and cushion: everything the static model needs."""

    geometry: PanelGeometry
    midrib: Laminate
    flap: Laminate
    hinge: Laminate
    cushion: StripCushion

    def __post_init__(self) -> None:
        for name, kind in (('geometry', PanelGeometry), ('midrib', Laminate), ('flap', Laminate),
                           ('hinge', Laminate), ('cushion', StripCushion)):
            if not isinstance(getattr(self, name), kind):
                raise TypeError(f'{name} must be a {kind.__name__}, got '
                                f'{type(getattr(self, name)).__name__}')
        if self.cushion.length_m > self.geometry.length_m:
            raise ValueError(f'cushion length_m={self.cushion.length_m:g} m is longer than the '
                             f'mid-rib ({self.geometry.length_m:g} m)')
        if self.cushion.flat_width_m > self.geometry.midrib_width_m:
            raise ValueError(f'cushion flat_width_m={self.cushion.flat_width_m:g} m is wider than '
                             f'the mid-rib ({self.geometry.midrib_width_m:g} m)')


@dataclass(frozen=True)
class WindResponse:
    """How far the closed flaps give under a uniform pressure on their inner faces."""

    wind_pressure_pa: float
    """Uniform pressure on each flap's inner face, pushing it open [Pa]."""
    flap_force_n: FloatArray
    """Resultant of that pressure on one flap [N]."""
    tip_deflection_m: FloatArray
    """Resulting travel of flap tip A at constant cushion pressure [m]."""
    stiffness_n_per_m: FloatArray
    """``flap_force_n / tip_deflection_m`` [N/m]: larger is stiffer."""


class ActuationModel(StaticActuationModel):
    """The static pressure map of many actuated panels, vectorised over panels.

    Internally every quantity is evaluated for a set of panel indices, so that scipy's
    elementwise root finder can evaluate just the panels it is still working on. The shape
    parameter is the elastica modulus ``k``; the maps common to both panel kinds come from
    :class:`~.static_model.StaticActuationModel`.
    """

    shape_name = 'elastica_k'
    derivative_step = DERIVATIVE_STEP
    stiffness_step = 1e-5
    panels: list[ActuatedPanel]
    fold: FoldModel
    batch: PanelBatch  # the base's property: the fold model's batch, for the type checker

    def __init__(self, panels: Iterable[ActuatedPanel], quadrature_points: int = 32) -> None:
        panels = self._checked_panels(panels, ActuatedPanel)
        self.panels = panels
        self.quadrature_points = quadrature_points
        self.fold = FoldModel(PanelBatch.from_panels(p.geometry for p in panels))
        self._all = np.arange(len(panels))
        self._set_stiffnesses(panels)
        self._set_quadrature(panels, quadrature_points)
        self._check_cushion_stroke()
        self.closed_pressure_pa = self.pressure_from_k(self.fold.closed_k)
        self.actuation_energy_j = (self.elastic_energy_j(self.fold.closed_k)
                                   - self.elastic_energy_j(self.fold.open_k))

    def _set_stiffnesses(self, panels: list[ActuatedPanel]) -> None:
        self._midrib_stiffness = np.array([p.midrib.plate_stiffness_nm for p in panels])
        self._flap_stiffness = np.array([p.flap.plate_stiffness_nm for p in panels])
        self._hinge_stiffness = np.array([p.hinge.plate_stiffness_nm / p.geometry.hinge_width_m
                                          for p in panels])
        self._cushion_width = np.array([p.cushion.flat_width_m for p in panels])
        self._cushion_gap = np.array([p.cushion.mount_gap_m for p in panels])
        self._cushion_max_gap = np.array([p.cushion.max_gap_m for p in panels])

    def _set_quadrature(self, panels: list[ActuatedPanel], count: int) -> None:
        """Gauss-Legendre nodes on the half span; every integrand is symmetric about s = 0."""
        unit_nodes, unit_weights = np.polynomial.legendre.leggauss(count)
        half, weight = (unit_nodes + 1.0) / 4.0, unit_weights / 2.0
        batch = self.batch
        self._nodes = batch.length_m[:, None] * half
        self._weights = batch.length_m[:, None] * weight
        cushion_length = np.array([p.cushion.length_m for p in panels])
        self._cushion_nodes = cushion_length[:, None] * half
        self._cushion_weights = cushion_length[:, None] * weight
        radius = batch.fold_radius_m[:, None]
        drawn_y = batch.apex_y_m[:, None] - radius + np.sqrt(radius**2 - self._nodes**2)
        plate = (self._midrib_stiffness[:, None] * 2.0 * drawn_y
                 + 2.0 * self._flap_stiffness[:, None] * (batch.width_m[:, None] / 2 - drawn_y))
        self._plate_weights = 0.5 * plate * self._weights
        crease_stretch = radius / np.sqrt(radius**2 - self._nodes**2)
        self._hinge_weights = self._hinge_stiffness[:, None] * crease_stretch * self._weights
        self._open_curvature, self._open_fold = self._curvature_and_fold(self.fold.open_k,
                                                                         self._all)
        self._open_height = self._cushion_height(self.fold.open_k, self._all)

    def _curvature_and_fold(self, k: FloatArray,
                            index: IntArray) -> tuple[FloatArray, FloatArray]:
        length = self.batch.length_m[index]
        shape = elastica.elastica_shape(k, length, self._nodes[index])
        curvature = elastica.peak_curvature_from_k(k, length)[..., None] * \
            shape.normalized_height
        sag = elastica.sag_from_k(k, length)
        half_angle = np.arctan2(sag, self.batch.fold_line_sag_m[index])[..., None]
        fold = 2.0 * np.arccos(np.clip(np.cos(shape.slope_rad) * np.cos(half_angle), -1, 1))
        return curvature, fold

    def _cushion_height(self, k: FloatArray, index: IntArray) -> FloatArray:
        return elastica.elastica_shape(k, self.batch.length_m[index],
                                       self._cushion_nodes[index]).z_m

    def _check_cushion_stroke(self) -> None:
        rise = self._cushion_height(self.fold.closed_k, self._all) - self._open_height
        gap = self._cushion_gap + np.max(rise, axis=-1)
        short = gap >= self._cushion_max_gap
        if np.any(short):
            index = int(np.flatnonzero(short)[0])
            raise ValueError(
                f'panel {index}: the cushion (flat width {self._cushion_width[index]:g} m) ends '
                f'its stroke at a {self._cushion_max_gap[index] * 1e3:.1f} mm gap, but closing '
                f'needs {gap[index] * 1e3:.1f} mm; use a wider cushion')

    def energy(self, k: FloatArray, index: IntArray) -> FloatArray:
        curvature, fold = self._curvature_and_fold(k, index)
        plates = self._plate_weights[index] * np.square(curvature - self._open_curvature[index])
        hinges = self._hinge_weights[index] * np.square(fold - self._open_fold[index])
        return np.sum(plates + hinges, axis=-1)

    def _gap(self, k: FloatArray, index: IntArray) -> FloatArray:
        gap = (self._cushion_gap[index, None] + self._cushion_height(k, index)
               - self._open_height[index])
        return np.clip(gap, 0.0, self._cushion_max_gap[index, None])

    def volume(self, k: FloatArray, index: IntArray) -> FloatArray:
        area = section_area_m2(self._cushion_width[index, None], self._gap(k, index))
        return np.sum(area * self._cushion_weights[index], axis=-1)

    def pressure(self, k: FloatArray, index: IntArray) -> FloatArray:
        step = DERIVATIVE_STEP
        energy = self.energy(k + step, index) - self.energy(k - step, index)
        volume = self.volume(k + step, index) - self.volume(k - step, index)
        return energy / volume

    _k_array = StaticActuationModel._shape_array

    def cushion_force_n(self, k: npt.ArrayLike, gauge_pressure_pa: FloatOrArray) -> FloatArray:
        """Force the cushion puts on the mid-rib at a state and gauge pressure [N]."""
        gap = self._gap(self._k_array(k), self._all)
        contact = np.maximum(contact_width_m(self._cushion_width[:, None], gap), 0.0)
        return gauge_pressure_pa * np.sum(contact * self._cushion_weights, axis=-1)

    pressure_from_k = StaticActuationModel.pressure_from_shape

    stiffness_at_k = StaticActuationModel.stiffness_at_shape
    k_from_pressure = StaticActuationModel.shape_from_pressure

    def wind_response(self, wind_pressure_pa: float = 1000.0,
                      topology: MeshTopology = MeshTopology(21, 5, 11)) -> WindResponse:
        """Tip travel of the closed flaps under a uniform pressure on their inner faces.

        The pressure pushes both flaps open; its generalised force on ``k`` is the virtual work
        of the pressure over the flap triangles, and the panel gives way by that force over
        its stiffness ``U'' - p V''`` at the closed state, with the cushion pressure held.
        """
        pressure = real_scalar('wind_pressure_pa', wind_pressure_pa)
        if pressure <= 0.0:
            raise ValueError(f'wind_pressure_pa must be positive, got {pressure:g} Pa')
        k = self.fold.closed_k
        step = 1e-6
        mesh = fold_mesh(self.batch, k, topology)
        velocity = (fold_mesh(self.batch, k + step, topology).vertices
                    - fold_mesh(self.batch, k - step, topology).vertices) / (2 * step)
        flap_faces = _flap_faces(topology)
        corners = mesh.vertices[:, flap_faces]
        # Half the cross product: area times the unit normal of the front face, which looks
        # inward, toward the other flap, when the panel is closed.
        area_normal = np.cross(corners[:, :, 1] - corners[:, :, 0],
                               corners[:, :, 2] - corners[:, :, 0]) / 2.0
        face_velocity = velocity[:, flap_faces].mean(axis=2)
        generalized_force = -pressure * np.sum(area_normal * face_velocity, axis=(-1, -2))
        stiffness = self.stiffness_at_k(k, self.closed_pressure_pa)
        length = self.batch.length_m
        tip_rate = (flap_tip(self.batch, elastica.sag_from_k(k + step, length), +1)
                    - flap_tip(self.batch, elastica.sag_from_k(k - step, length), +1)) / (2 * step)
        deflection = np.linalg.norm(tip_rate, axis=-1) * np.abs(generalized_force) / stiffness
        flap_force = pressure * np.linalg.norm(area_normal, axis=-1).sum(axis=-1) / 2.0
        return WindResponse(wind_pressure_pa=pressure, flap_force_n=flap_force,
                            tip_deflection_m=deflection,
                            stiffness_n_per_m=flap_force / deflection)


def _flap_faces(topology: MeshTopology) -> IntArray:
    faces = topology.faces
    midrib_end = topology.midrib.stop
    return faces[np.all(faces >= midrib_end, axis=1)]


def actuated_like(geometry: PanelGeometry,
                  template: Optional[ActuatedPanel] = None) -> ActuatedPanel:
    """Build an :class:`ActuatedPanel` of ``geometry`` like ``template`` (laminates, cushion).

    ``template`` defaults to :data:`DEMONSTRATOR_ACTUATED`: a facade description gives each
    panel's outline and fold lines, the build (laminates and cushion) is the demonstrator's.
    """
    template = DEMONSTRATOR_ACTUATED if template is None else template
    return ActuatedPanel(geometry=geometry, midrib=template.midrib, flap=template.flap,
                         hinge=template.hinge, cushion=template.cushion)


def radius_study(radii_m: Iterable[float] = (0.5, 0.75, 1.0)) -> 'ActuationModel':
    """Build the paper's fold-radius study on the 520 x 420 mm prototype outline.

    Only the fold radius changes; the mid-rib keeps a 20 mm tip, so it widens as the radius
    shrinks, and the cushion is 80 % of the mid-rib wide and long. Laminates are those of
    :data:`DEMONSTRATOR_ACTUATED`. Returns the :class:`ActuationModel` of the variants.
    """
    panels = []
    for radius in radii_m:
        geometry = PanelGeometry.with_lens_midrib(
            length_m=0.52, width_m=0.42, fold_radius_m=radius, end_width_m=0.02,
            hinge_width_m=0.015, prefold_rad=DEMONSTRATOR_MODULE.prefold_rad)
        panels.append(ActuatedPanel(
            geometry=geometry, midrib=DEMONSTRATOR_ACTUATED.midrib,
            flap=DEMONSTRATOR_ACTUATED.flap, hinge=DEMONSTRATOR_ACTUATED.hinge,
            cushion=StripCushion(flat_width_m=0.8 * geometry.midrib_width_m,
                                 length_m=0.8 * geometry.length_m, mount_gap_m=0.003)))
    return ActuationModel(panels)


#: A module of the 6 x 6 demonstrator (about 1 m2). Laminates [estimate]: a 4 mm GFRP mid-rib,
#: 2 mm flaps and a 1.2 mm hinge of glass/elastomer (2 GPa effective), thicknesses chosen so
#: that the module closes at 8.6 kPa, inside the published 4-9 kPa working range.
DEMONSTRATOR_ACTUATED = ActuatedPanel(
    geometry=DEMONSTRATOR_MODULE,
    midrib=Laminate(thickness_m=0.004),
    flap=Laminate(thickness_m=0.002),
    hinge=Laminate(thickness_m=0.0012, youngs_modulus_pa=2e9),
    cushion=StripCushion(flat_width_m=0.28, length_m=0.8, mount_gap_m=0.005),
)

#: A FlectoLine-like flap: a smaller, stiffer 600 x 450 mm panel with a narrow cushion that
#: reaches a 90 degree apex fold at about 34 kPa (FlectoLine: 0.3-0.4 bar for up to 90 degrees).
#: Geometry and laminates are estimates; FlectoLine's own are not published.
FLECTOLINE_ACTUATED = ActuatedPanel(
    geometry=PanelGeometry.with_lens_midrib(
        length_m=0.6, width_m=0.45, fold_radius_m=0.8, end_width_m=0.04, hinge_width_m=0.015,
        prefold_rad=math.radians(5.0)),
    midrib=Laminate(thickness_m=0.004),
    flap=Laminate(thickness_m=0.002),
    hinge=Laminate(thickness_m=0.001, youngs_modulus_pa=3.5e9),
    cushion=StripCushion(flat_width_m=0.15, length_m=0.5, mount_gap_m=0.003),
)
