"""Static actuation of hexagonal panels: cushion pressure <-> centre rise <-> closure.

The reduced-order energy model of :mod:`.statics`, on the hexagonal panel's one degree of
freedom, the centre rise ``d`` (:mod:`flectofold_model.kinematics.hexagon_cone`). Raising the
centre to ``d`` stores elastic energy ``U(d)``:

* the central cone: at flat polar coordinates ``(r, phi)`` a cone bends across its rulings
  with curvature ``kappa_g(phi) / r``, ``kappa_g = det(g, g', g'')`` the geodesic curvature of
  the ruling directions ``g(phi)`` on the unit sphere (taken from the kinematic model's
  rulings; ``g''`` by a central difference of their rate). Over a sector that is
  ``1/2 D_c integral (kappa_g - kappa_g,open)**2 ln(r_crease(phi) / r_core) d phi``: the
  curvature diverges at the apex, where a real sheet stretches instead of bending in a small
  core (the developable cone of Cerda & Mahadevan, PRL 80, 1998), so the bending energy is
  integrated from the core radius ``core_radius_m`` out;
* the three flaps: each flap is the mirror image of the cone beyond its crease, so it bends
  with the same ``kappa_g(phi) / r`` from the crease out to the hexagon's edge:
  ``1/2 D_f integral dkappa_g**2 ln(r_edge(phi) / r_crease(phi)) d phi``;
* the three hinge zones: a zone of width ``b`` folded by ``rho`` is a rotational spring
  ``D_h / b`` per unit length: ``1/2 (D_h / b) integral (rho - rho_open)**2 dl`` along the
  crease, ``rho(phi)`` the fold angle along it.

The material lines (crease, core, edge) are those of the open state; the open state is
stress-free (the pre-fold is moulded in), so the panel springs back open when vented. The
round cushion (:mod:`.round_cushion`) of volume ``V(d)`` behind the central part pushes with
gauge pressure ``p``; by virtual work ``p(d) = U'(d) / V'(d)``, stable where it rises with
``d``. Every integral runs over the six half-sectors between a triangle vertex and a flap tip
(the panel is three-fold symmetric and each sector mirror-symmetric), by Gauss-Legendre.

Limits, stated rather than hidden: the central part keeps the kinematic model's cone instead
of the shape a distributed cushion load would give (the cushion acts on the one degree of
freedom only); the core, membrane strains in the hinge zones, friction, gravity and the
cushion's own stiffness are left out; the hinge fold is uniform across the hinge width.
"""

from dataclasses import dataclass
import math
from typing import Iterable

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import FloatArray, IntArray, real_scalar
from flectofold_model.actuation.laminate import Laminate
from flectofold_model.actuation.round_cushion import RoundCushion, wedge_volume_m3
from flectofold_model.actuation.static_model import StaticActuationModel
from flectofold_model.kinematics import hexagon_cone as cone
from flectofold_model.kinematics.hexagon_closure import HexagonFoldModel
from flectofold_model.kinematics.hexagon_fold_lines import drawn_radius_m
from flectofold_model.kinematics.hexagon_panel import (HEXAGON_MODULE, hexagon_radius_m,
                                                       HexagonBatch, HexagonPanel)
from flectofold_model.kinematics.hexagon_reflection import SectorGeometry

#: Step in the centre rise of the central differences of the static maps [m].
RISE_STEP_M = 1e-6
#: Step in the sector angle of the central difference that gives ``g''`` [rad].
SECTOR_ANGLE_STEP_RAD = 1e-4
#: Sector angle from a triangle vertex to the neighbouring flap tip [rad].
HALF_SECTOR_RAD = math.pi / 3
_BISECTIONS = 60


def inner_radius_m(geometry: HexagonPanel) -> float:
    """Radius of the largest disc about the centre inside the central part [m].

    The drawn fold lines' nearest approach to the centre, less half the hinge zone (which
    straddles the fold line).
    """
    batch = HexagonBatch.from_panels([geometry])
    phi = np.linspace(0.0, 2 * math.pi / 3, 241)
    return float(np.min(drawn_radius_m(batch, phi))) - geometry.hinge_width_m / 2


def d_cone_core_radius_m(thickness_m: float, circumradius_m: float) -> float:
    """Core radius ``t**(1/3) R**(2/3)`` of a developable cone of a sheet [m] (estimate).

    The scaling of the core of a d-cone (Cerda, Chaieb, Melo & Mahadevan, Nature 401, 1999);
    its order-one prefactor is taken as 1, which is an estimate for this load.
    """
    return thickness_m ** (1.0 / 3.0) * circumradius_m ** (2.0 / 3.0)


@dataclass(frozen=True)
class HexagonActuatedPanel:
    """A hexagonal panel with its laminates, cushion and cone core: what the statics need."""

    geometry: HexagonPanel
    midrib: Laminate
    """Laminate of the central part (the quad's mid-rib: the part the cushion drives)."""
    flap: Laminate
    hinge: Laminate
    cushion: RoundCushion
    core_radius_m: float
    """Radius of the cone's core about the centre point, inside which bending is not counted
    [m]; see :func:`d_cone_core_radius_m`."""

    def __post_init__(self) -> None:
        for name, kind in (('geometry', HexagonPanel), ('midrib', Laminate), ('flap', Laminate),
                           ('hinge', Laminate), ('cushion', RoundCushion)):
            if not isinstance(getattr(self, name), kind):
                raise TypeError(f'{name} must be a {kind.__name__}, got '
                                f'{type(getattr(self, name)).__name__}')
        core = real_scalar('core_radius_m', self.core_radius_m)
        object.__setattr__(self, 'core_radius_m', core)
        inner = inner_radius_m(self.geometry)
        if self.cushion.flat_radius_m > inner:
            raise ValueError(f'cushion flat_radius_m={self.cushion.flat_radius_m:g} m is larger '
                             f'than the central part (a {inner:.4g} m disc fits inside its fold '
                             f'lines and hinge zones)')
        if not 0.0 < core < inner:
            raise ValueError(f'core_radius_m must lie in (0, {inner:.4g}) m, inside the '
                             f'central part, got {core:g} m')


class HexagonActuationModel(StaticActuationModel):
    """The static pressure map of many actuated hexagonal panels, vectorised over panels.

    The shape parameter is the centre rise [m]; the public surface is that of
    :class:`~.statics.ActuationModel` (``pressure_from_shape``/``pressure_from_rise``,
    ``shape_from_pressure``/``rise_from_pressure``, the closure maps, ``reachable_closure``).
    """

    shape_name = 'centre_rise_m'
    derivative_step = RISE_STEP_M
    stiffness_step = 1e-4
    panels: list[HexagonActuatedPanel]
    fold: HexagonFoldModel
    batch: HexagonBatch  # the base's property: the fold model's batch, for the type checker

    def __init__(self, panels: Iterable[HexagonActuatedPanel],
                 quadrature_points: int = 24) -> None:
        panels = self._checked_panels(panels, HexagonActuatedPanel)
        if isinstance(quadrature_points, bool) or not isinstance(quadrature_points, int) \
                or quadrature_points < 4:
            raise ValueError(f'quadrature_points must be an integer of at least 4, got '
                             f'{quadrature_points!r}')
        self.panels = panels
        self.quadrature_points = quadrature_points
        self.fold = HexagonFoldModel(HexagonBatch.from_panels(p.geometry for p in panels))
        self._all = np.arange(len(panels))
        self._set_quadrature(panels, quadrature_points)
        self._check_cushion_stroke()
        self.closed_pressure_pa = self.pressure_from_shape(self.fold.closed_shape)
        self.actuation_energy_j = (self.elastic_energy_j(self.fold.closed_shape)
                                   - self.elastic_energy_j(self.fold.open_shape))

    def _set_quadrature(self, panels: list[HexagonActuatedPanel], count: int) -> None:
        """Gauss-Legendre nodes on one half-sector; six half-sectors make the panel."""
        nodes, weights = np.polynomial.legendre.leggauss(count)
        self._phi = (nodes + 1.0) * HALF_SECTOR_RAD / 2.0
        weight = 6.0 * weights * HALF_SECTOR_RAD / 2.0
        batch = self.batch
        opened = SectorGeometry(batch, self.fold.open_shape)
        crease = opened.crease_radius_m(self._phi)
        core = np.array([p.core_radius_m for p in panels])[:, None]
        edge = hexagon_radius_m(batch.circumradius_m[:, None], self._phi)
        central, flap, hinge = (np.array([getattr(p, name).plate_stiffness_nm for p in panels])
                                for name in ('midrib', 'flap', 'hinge'))
        plate = (central[:, None] * np.log(crease / core)
                 + flap[:, None] * np.log(edge / crease))
        self._plate_weights = 0.5 * plate * weight
        self._hinge_weights = (0.5 * (hinge / batch.hinge_width_m)[:, None]
                               * _crease_speed_m(opened, self._phi) * weight)
        self._cushion_radius = np.array([p.cushion.flat_radius_m for p in panels])
        self._cushion_gap = np.array([p.cushion.mount_gap_m for p in panels])
        self._cushion_max_gap = np.array([p.cushion.max_gap_m for p in panels])
        self._volume_weights = weight
        self._open_curvature = geodesic_curvature(opened, self._phi)
        self._open_fold = opened.fold_angle_rad(self._phi)
        self._open_sine = opened.directions(self._phi)[..., 2]

    def _geometry(self, rise: FloatArray, index: IntArray) -> SectorGeometry:
        return SectorGeometry(self.batch.take(index), rise)

    def _check_cushion_stroke(self) -> None:
        centre_gap = self._cushion_gap + self.fold.closed_shape - self.fold.open_shape
        short = centre_gap >= self._cushion_max_gap
        if np.any(short):
            index = int(np.flatnonzero(short)[0])
            raise ValueError(
                f'panel {index}: the cushion (flat radius {self._cushion_radius[index]:g} m) '
                f'ends its stroke at a {self._cushion_max_gap[index] * 1e3:.1f} mm centre gap, '
                f'but closing needs {centre_gap[index] * 1e3:.1f} mm; use a larger cushion')

    def _energy_of(self, geometry: SectorGeometry, index: IntArray) -> FloatArray:
        curvature = geodesic_curvature(geometry, self._phi)
        fold = geometry.fold_angle_rad(self._phi)
        plates = self._plate_weights[index] * np.square(curvature - self._open_curvature[index])
        hinges = self._hinge_weights[index] * np.square(fold - self._open_fold[index])
        return np.sum(plates + hinges, axis=-1)

    def _volume_of(self, geometry: SectorGeometry, rise: FloatArray,
                   index: IntArray) -> FloatArray:
        centre_gap = (self._cushion_gap[index] + rise - self.fold.open_shape[index])[:, None]
        steepening = self._open_sine[index] - geometry.directions(self._phi)[..., 2]
        wedge = wedge_volume_m3(self._cushion_radius[index, None], centre_gap, steepening)
        return np.sum(wedge * self._volume_weights, axis=-1)

    def energy(self, rise: FloatArray, index: IntArray) -> FloatArray:
        return self._energy_of(self._geometry(rise, index), index)

    def volume(self, rise: FloatArray, index: IntArray) -> FloatArray:
        return self._volume_of(self._geometry(rise, index), rise, index)

    def pressure(self, rise: FloatArray, index: IntArray) -> FloatArray:
        step = self.derivative_step
        above, below = self._geometry(rise + step, index), self._geometry(rise - step, index)
        energy = self._energy_of(above, index) - self._energy_of(below, index)
        volume = (self._volume_of(above, rise + step, index)
                  - self._volume_of(below, rise - step, index))
        return energy / volume

    pressure_from_rise = StaticActuationModel.pressure_from_shape
    rise_from_pressure = StaticActuationModel.shape_from_pressure

    def cushion_contact_area_m2(self, rise: npt.ArrayLike) -> FloatArray:
        """Area over which the cushion touches the central part at centre rises [m2]."""
        rise = self._shape_array(rise)
        geometry = self._geometry(rise, self._all)
        centre_gap = (self._cushion_gap + rise - self.fold.open_shape)[:, None]
        steepening = self._open_sine - geometry.directions(self._phi)[..., 2]
        radius = np.clip((self._cushion_radius[:, None] - math.pi * centre_gap / 4.0)
                         / (1.0 - math.pi * steepening / 4.0), 0.0, None)
        return np.sum(radius ** 2 / 2.0 * self._volume_weights, axis=-1)

    def shape_table(self, closures: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Centre rises [m] and apex fold angles [rad] (N, S) at closure samples (S,).

        All ``N S`` states are found at once, by bisection of the apex fold angle (which grows
        strictly with the rise) between each panel's open and closed rises.
        """
        closures = np.asarray(closures, dtype=np.float64)
        fold = self.fold
        wanted = (fold.open_fold_angle_rad[:, None] + closures
                  * (fold.closed_fold_angle_rad - fold.open_fold_angle_rad)[:, None])
        index = np.repeat(self._all, closures.size)
        batch = self.batch.take(index)
        low = np.repeat(fold.open_shape, closures.size)
        high = np.repeat(fold.closed_shape, closures.size)
        for _ in range(_BISECTIONS):
            middle = (low + high) / 2.0
            short = SectorGeometry(batch, middle).apex_fold_angle_rad < wanted.ravel()
            low, high = np.where(short, middle, low), np.where(short, high, middle)
        rise = ((low + high) / 2.0).reshape(wanted.shape)
        rise[:, closures <= 0.0] = fold.open_shape[:, None]
        rise[:, closures >= 1.0] = fold.closed_shape[:, None]
        return rise, wanted


def geodesic_curvature(geometry: SectorGeometry, phi: FloatArray) -> FloatArray:
    """``det(g, g', g'')`` (N, P) of the cone's ruling directions at sector angles ``phi``.

    The cone's curvature across its rulings at flat distance ``r`` from the apex is this over
    ``r`` [1/m]. ``g'`` is the model's ruling rate; ``g''`` its central difference.
    """
    tilt, amplitude = geometry.tilt_rad, geometry.amplitude_rad
    step = SECTOR_ANGLE_STEP_RAD
    rate = cone.ruling_direction_rate(tilt, amplitude, phi)
    second = (cone.ruling_direction_rate(tilt, amplitude, phi + step)
              - cone.ruling_direction_rate(tilt, amplitude, phi - step)) / (2.0 * step)
    normal = np.cross(geometry.directions(phi), rate)
    return np.einsum('npi,npi->np', normal, second)


def _crease_speed_m(geometry: SectorGeometry, phi: FloatArray) -> FloatArray:
    """``dl / dphi`` (N, P) [m/rad] of the crease in the flat sheet, ``sqrt(r**2 + r'**2)``."""
    step = SECTOR_ANGLE_STEP_RAD
    radius = geometry.crease_radius_m(phi)
    rate = (geometry.crease_radius_m(phi + step) - geometry.crease_radius_m(phi - step)) / (
        2.0 * step)
    return np.hypot(radius, rate)


def hexagon_actuated_like(geometry: HexagonPanel, template: object = None) -> HexagonActuatedPanel:
    """Build a :class:`HexagonActuatedPanel` of ``geometry`` like ``template``.

    ``template`` defaults to :data:`HEXAGON_ACTUATED`; its laminates, cushion and core radius
    are kept.
    """
    template = HEXAGON_ACTUATED if template is None else template
    if not isinstance(template, HexagonActuatedPanel):
        raise TypeError(f'template must be a HexagonActuatedPanel, got '
                        f'{type(template).__name__}')
    return HexagonActuatedPanel(geometry=geometry, midrib=template.midrib, flap=template.flap,
                                hinge=template.hinge, cushion=template.cushion,
                                core_radius_m=template.core_radius_m)


_PRESET_MIDRIB = Laminate(thickness_m=0.003)

#: The hexagonal module (about 1 m2) built like the quad demonstrator. Laminates [estimate]:
#: a 3 mm GFRP central part, 2 mm flaps and the demonstrator's 1.2 mm glass/elastomer hinge
#: (2 GPa effective); a round cushion of 290 mm flat radius [estimate]; the cone's core from
#: the d-cone scaling with prefactor 1 [estimate]. Chosen so that the module closes at 8.4 kPa,
#: beside the quad demonstrator's 8.6 kPa and well within the demonstrator plant's reach.
HEXAGON_ACTUATED = HexagonActuatedPanel(
    geometry=HEXAGON_MODULE,
    midrib=_PRESET_MIDRIB,
    flap=Laminate(thickness_m=0.002),
    hinge=Laminate(thickness_m=0.0012, youngs_modulus_pa=2e9),
    cushion=RoundCushion(flat_radius_m=0.29, mount_gap_m=0.005),
    core_radius_m=d_cone_core_radius_m(_PRESET_MIDRIB.thickness_m,
                                       HEXAGON_MODULE.circumradius_m),
)
