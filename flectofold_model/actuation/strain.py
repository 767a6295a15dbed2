"""Peak surface strains of the laminates of actuated panels, from the kinematic fold model.

Nothing in the static model limits how far a zone bends; this module measures it, with the
quantities the energy models of :mod:`.statics` and :mod:`.hexagon_statics` integrate, so that
a strain here and an energy there describe the same bent sheet. Beam theory: a laminate of
thickness ``t`` bent to a curvature ``kappa`` sees ``kappa t / 2`` at its surfaces
(:meth:`~.laminate.Laminate.surface_strain`). Per zone:

* **hinge**: a zone of width ``b`` folded by ``rho`` bends uniformly at ``rho / b``, so its
  surfaces see ``rho t_h / (2 b)``; the peak is the largest along the crease;
* **mid-rib** (the hexagon's central part) and **flaps**: the plates' curvature change, times
  half their thickness.

Every strain is counted from the open state, which is stress-free: the pre-fold is moulded
into the laminates, so the hinge sees ``rho(s) - rho_open(s)`` and the plates
``kappa(s) - kappa_open(s)``, not the full fold or curvature. Closure 0 is therefore strain
free, and the strain grows with closure.

The laminates' allowable strain (:attr:`~.laminate.Laminate.allowable_strain`, by default the
fatigue estimate :data:`~.laminate.FATIGUE_ALLOWABLE_STRAIN`, 0.7 %) is what the results are
compared with; :func:`hinge_width_for_allowable_m` inverts the hinge rule for the width that
keeps a hinge at its allowable strain. Limits: the strains are those of the model's bending
(membrane strains, stress concentrations at the zone borders and the d-cone core are left
out, as in the energy models), so they are estimates of the order of magnitude.
"""

from dataclasses import dataclass
import math
from typing import Any, cast, Iterable, Optional, Sequence, TypeVar, Union
import warnings

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import FloatArray
from flectofold_model.actuation.hexagon_statics import (geodesic_curvature, HALF_SECTOR_RAD,
                                                        HEXAGON_ACTUATED, HexagonActuatedPanel)
from flectofold_model.actuation.kinds import AnyActuatedPanel
from flectofold_model.actuation.laminate import FATIGUE_ALLOWABLE_STRAIN, Laminate
from flectofold_model.actuation.statics import ActuatedPanel, DEMONSTRATOR_ACTUATED
from flectofold_model.kinematics import elastica
from flectofold_model.kinematics.closure import FoldModel
from flectofold_model.kinematics.hexagon_closure import HexagonFoldModel
from flectofold_model.kinematics.hexagon_panel import HexagonBatch, HexagonPanel
from flectofold_model.kinematics.hexagon_reflection import MID_SECTOR_RAD, SectorGeometry
from flectofold_model.kinematics.kinds import Panel
from flectofold_model.kinematics.panel import PanelBatch
from flectofold_model.kinematics.reflection import fold_angle_along_crease

#: Crease stations per half span (quad) or half-sector (hexagon), both ends included.
STATIONS = 241
#: Step in the sector angle of the central difference of the hexagon's crease radius [rad].
_PHI_STEP_RAD = 1e-4

__all__ = ['hinge_width_for_allowable_m', 'hexagon_panel_strain', 'panel_strain', 'PanelStrain',
           'quad_panel_strain', 'STATIONS', 'strain_exceedance', 'StrainLimitWarning',
           'warn_if_over_allowable']


class StrainLimitWarning(UserWarning):
    """Panels whose laminates exceed their allowable strain at their largest closure."""


@dataclass(frozen=True)
class PanelStrain:
    """Peak surface strains of every panel of a batch (dimensionless); each field is ``(N,)``.

    Strains are counted from the stress-free open state (the pre-fold is moulded in).
    """

    closure: FloatArray
    """Closure at which the strains hold, 0 open ... 1 closed."""
    hinge_strain: FloatArray
    """Peak of ``(rho - rho_open) t_h / (2 b)`` along the crease."""
    midrib_strain: FloatArray
    """Peak of ``|kappa - kappa_open| t_m / 2`` over the mid-rib (hexagon: the central part)."""
    flap_strain: FloatArray
    """Peak of ``|kappa - kappa_open| t_f / 2`` over the flaps."""
    hinge_peak_arc_m: FloatArray
    """Where the hinge peak sits: distance from the crease apex along the drawn fold line in
    the flat sheet [m] (quad: ``R asin(|s| / R)`` of the mid-rib station ``s``; hexagon: the
    open crease's length from its apex ``M`` toward a triangle vertex)."""
    hinge_fold_change_rad: FloatArray
    """Peak fold-angle change ``rho - rho_open`` along the crease [rad]."""
    hinge_allowable_strain: FloatArray
    """Allowable strain of each panel's hinge laminate."""
    midrib_allowable_strain: FloatArray
    """Allowable strain of each panel's mid-rib laminate."""
    flap_allowable_strain: FloatArray
    """Allowable strain of each panel's flap laminate."""

    @property
    def utilisation(self) -> FloatArray:
        """Largest strain / allowable strain over the three zones (N,); above 1 exceeds."""
        return np.maximum.reduce([self.hinge_strain / self.hinge_allowable_strain,
                                  self.midrib_strain / self.midrib_allowable_strain,
                                  self.flap_strain / self.flap_allowable_strain])


def _laminate_arrays(panels: Sequence['_Built']) -> dict[str, FloatArray]:
    return {f'{zone}_{name}': np.array([getattr(getattr(p, zone), attribute) for p in panels])
            for zone in ('hinge', 'midrib', 'flap')
            for name, attribute in (('thickness_m', 'thickness_m'),
                                    ('allowable', 'allowable_strain'))}


@dataclass(frozen=True)
class _Build:
    """What the strains need of an actuated panel: the geometry, laminates and cone core.

    Lets :func:`warn_if_over_allowable` measure a facade's panels without building their
    cushions, which do not enter the strains (and may not fit a panel of another size).
    """

    geometry: object
    midrib: Laminate
    flap: Laminate
    hinge: Laminate
    core_radius_m: float = math.nan


#: What the strains are computed of: actuated panels of either kind, or their builds.
_Built = Union[ActuatedPanel, HexagonActuatedPanel, _Build]
_PanelT = TypeVar('_PanelT')


def _checked(panels: Iterable[Any], kind: type[_PanelT]) -> list[_PanelT]:
    panels = list(panels)
    if not panels:
        raise ValueError('strains need at least one panel')
    for index, panel in enumerate(panels):
        if not isinstance(panel, kind):
            raise TypeError(f'panel {index} is {type(panel).__name__}, not {kind.__name__}')
    return panels


def _is_hexagon(panels: Sequence[_Built]) -> bool:
    return isinstance(panels[0].geometry, HexagonPanel)


def quad_panel_strain(panels: Iterable[ActuatedPanel], closure: npt.ArrayLike = 1.0,
                      stations: int = STATIONS) -> PanelStrain:
    """Compute the peak surface strains of quad panels at closures (the reflection model).

    Parameters
    ----------
    panels : iterable of ActuatedPanel
        The N panels (geometry and laminates).
    closure : float or array-like
        Closure in [0, 1], scalar or one per panel (N,).
    stations : int
        Crease stations from mid-span to a support, both included.

    Returns
    -------
    PanelStrain
        Hinge: ``max_s (rho(s) - rho_open(s)) t_h / (2 b)`` with ``rho(s)`` the model's fold
        angle along the crease (:func:`~flectofold_model.kinematics.reflection.
        fold_angle_along_crease`; it grows from the apex toward the supports). Mid-rib:
        ``max_s |kappa(s) - kappa_open(s)| t_m / 2`` with ``kappa(s)`` the elastica's
        curvature. Flaps: each flap is the mirror image of the bent mid-rib, so it bends with
        the same curvature: the same with ``t_f``. These are the quantities the energy of
        :class:`~.statics.ActuationModel` integrates; strains from the moulded open state.
    """
    return _quad_strain(_checked(panels, ActuatedPanel), closure, stations)


def _quad_strain(panels: Sequence[Union[ActuatedPanel, _Build]], closure: npt.ArrayLike,
                 stations: int) -> PanelStrain:
    fold = FoldModel(PanelBatch.from_panels(p.geometry for p in panels))
    batch = fold.batch
    state = fold.state_from_closure(closure)
    length = batch.length_m
    arc = length[:, None] * np.linspace(0.0, 0.5, stations)

    def bent(k: FloatArray) -> tuple[FloatArray, FloatArray]:
        shape = elastica.elastica_shape(k, length, arc)
        curvature = elastica.peak_curvature_from_k(k, length)[:, None] * shape.normalized_height
        fold_angle = fold_angle_along_crease(batch, k, elastica.sag_from_k(k, length), arc)
        return curvature, fold_angle

    curvature, fold_angle = bent(state.elastica_k)
    open_curvature, open_fold = bent(fold.open_k)
    fold_change = fold_angle - open_fold
    peak = np.argmax(fold_change, axis=-1)
    rows = np.arange(len(panels))
    peak_fold = fold_change[rows, peak]
    curvature_change = np.max(np.abs(curvature - open_curvature), axis=-1)
    radius = batch.fold_radius_m
    peak_arc = radius * np.arcsin(np.clip(arc[rows, peak] / radius, -1.0, 1.0))
    return _result(panels, state.closure, peak_fold, batch.hinge_width_m, curvature_change,
                   curvature_change, peak_arc)


def hexagon_panel_strain(panels: Iterable[HexagonActuatedPanel], closure: npt.ArrayLike = 1.0,
                         stations: int = STATIONS) -> PanelStrain:
    """Compute the peak surface strains of hexagonal panels at closures (reflection model).

    Parameters
    ----------
    panels : iterable of HexagonActuatedPanel
        The N panels (geometry, laminates and cone core).
    closure : float or array-like
        Closure in [0, 1], scalar or one per panel (N,).
    stations : int
        Sector angles from a triangle vertex to a crease apex, both included.

    Returns
    -------
    PanelStrain
        The quantities the energy of :class:`~.hexagon_statics.HexagonActuationModel`
        integrates, along one half-sector (the panel is three-fold and mirror symmetric).
        Hinge: ``max_phi (rho(phi) - rho_open(phi)) t_h / (2 b)`` with ``rho(phi)`` the fold
        angle along the crease (:meth:`~flectofold_model.kinematics.hexagon_reflection.
        SectorGeometry.fold_angle_rad`). Central part: the cone bends across its rulings at
        ``kappa_g(phi) / r``, largest at the core radius where the model's bending starts:
        ``max_phi |kappa_g - kappa_g,open| / r_core t_m / 2``. Flaps: the mirror image of the
        cone beyond the crease, largest at the crease: ``max_phi |kappa_g - kappa_g,open| /
        r_crease(phi) t_f / 2``. Material lines (core, crease) are those of the open state.
    """
    return _hexagon_strain(_checked(panels, HexagonActuatedPanel), closure, stations)


def _hexagon_strain(panels: Sequence[Union[HexagonActuatedPanel, _Build]],
                    closure: npt.ArrayLike, stations: int) -> PanelStrain:
    fold = HexagonFoldModel(HexagonBatch.from_panels(p.geometry for p in panels))
    batch = fold.batch
    state = fold.state_from_closure(closure)
    phi = np.linspace(0.0, HALF_SECTOR_RAD, stations)
    opened = SectorGeometry(batch, fold.open_shape)
    current = SectorGeometry(batch, state.shape_parameter)
    fold_change = current.fold_angle_rad(phi) - opened.fold_angle_rad(phi)
    peak = np.argmax(fold_change, axis=-1)
    rows = np.arange(len(panels))
    cone_change = np.abs(geodesic_curvature(current, phi) - geodesic_curvature(opened, phi))
    core = np.array([p.core_radius_m for p in panels])
    crease = opened.crease_radius_m(phi)
    crease_arc = _hexagon_crease_arc_m(opened, phi)
    return _result(panels, state.closure, fold_change[rows, peak], batch.hinge_width_m,
                   np.max(cone_change, axis=-1) / core, np.max(cone_change / crease, axis=-1),
                   crease_arc[rows, peak])


def _hexagon_crease_arc_m(geometry: SectorGeometry, phi: FloatArray) -> FloatArray:
    """Length (N, P) of the open crease in the flat sheet from its apex to sector angles ``phi``.

    ``phi`` runs from a triangle vertex (0) to the apex (``MID_SECTOR_RAD``); the length is
    the integral of ``sqrt(r**2 + r'**2)`` by the trapezoidal rule.
    """
    radius = geometry.crease_radius_m(phi)
    rate = (geometry.crease_radius_m(phi + _PHI_STEP_RAD)
            - geometry.crease_radius_m(phi - _PHI_STEP_RAD)) / (2.0 * _PHI_STEP_RAD)
    speed = np.hypot(radius, rate)
    steps = (speed[:, 1:] + speed[:, :-1]) / 2.0 * np.diff(phi)
    from_vertex = np.concatenate([np.zeros((len(radius), 1)), np.cumsum(steps, axis=-1)],
                                 axis=-1)
    apex = np.array([np.interp(MID_SECTOR_RAD, phi, row) for row in from_vertex])
    return np.abs(apex[:, None] - from_vertex)


def _result(panels: Sequence[_Built], closure: npt.ArrayLike, fold_change: FloatArray,
            hinge_width_m: FloatArray, midrib_curvature: FloatArray,
            flap_curvature: FloatArray, peak_arc_m: FloatArray) -> PanelStrain:
    laminates = _laminate_arrays(panels)
    return PanelStrain(
        closure=np.asarray(closure, dtype=np.float64),
        hinge_strain=fold_change * laminates['hinge_thickness_m'] / (2.0 * hinge_width_m),
        midrib_strain=midrib_curvature * laminates['midrib_thickness_m'] / 2.0,
        flap_strain=flap_curvature * laminates['flap_thickness_m'] / 2.0,
        hinge_peak_arc_m=peak_arc_m,
        hinge_fold_change_rad=fold_change,
        hinge_allowable_strain=laminates['hinge_allowable'],
        midrib_allowable_strain=laminates['midrib_allowable'],
        flap_allowable_strain=laminates['flap_allowable'])


def panel_strain(panels: Iterable[AnyActuatedPanel], closure: npt.ArrayLike = 1.0) -> PanelStrain:
    """Compute the peak surface strains of actuated panels of one kind (quad or hexagonal).

    Dispatches to :func:`quad_panel_strain` or :func:`hexagon_panel_strain` by the first
    panel's kind; see those for the rules. Returns a :class:`PanelStrain`.
    """
    panels = list(panels)
    if panels and isinstance(panels[0], HexagonActuatedPanel):
        return hexagon_panel_strain(cast(list[HexagonActuatedPanel], panels), closure)
    return quad_panel_strain(cast(list[ActuatedPanel], panels), closure)  # both check the kind


def _strain_of_builds(builds: list[_Build], closure: npt.ArrayLike) -> PanelStrain:
    if _is_hexagon(builds):
        return _hexagon_strain(builds, closure, STATIONS)
    return _quad_strain(builds, closure, STATIONS)


def hinge_width_for_allowable_m(panel: AnyActuatedPanel, closure: float = 1.0) -> float:
    """Return the hinge width [m] that keeps a hinge at its allowable strain at ``closure``.

    Inverts the hinge rule: ``b >= rho_max t_h / (2 eps_allow)``, with ``rho_max`` the peak
    fold-angle change along the crease (which the kinematics fix independently of ``b``) and
    ``eps_allow`` the hinge laminate's allowable strain. For the documentation: it says how
    far a preset is from its allowable strain, it does not re-dimension the panel (a wider
    hinge also leaves less flap, which this does not check).

    Parameters
    ----------
    panel : ActuatedPanel or HexagonActuatedPanel
        The panel.
    closure : float
        Closure in [0, 1]; the default is the closed state.
    """
    strain = panel_strain([panel], closure)
    return float(strain.hinge_fold_change_rad[0] * panel.hinge.thickness_m
                 / (2.0 * panel.hinge.allowable_strain))


def strain_exceedance(panel: AnyActuatedPanel, closure: float = 1.0) -> str:
    """Describe a panel's peak hinge strain at ``closure`` against its allowable strain.

    Names the allowable strain and its source, and whether and by how much the hinge exceeds
    it (with the hinge width it would need), or how much margin it keeps; mid-rib and flaps
    are named where they exceed theirs too.
    """
    strain = panel_strain([panel], closure)
    hinge, allowable = strain.hinge_strain[0], strain.hinge_allowable_strain[0]
    source = ('fatigue, 1e7 cycles' if allowable == FATIGUE_ALLOWABLE_STRAIN
              else 'set on the laminate')
    head = f'hinge {hinge * 100:.2f} % at closure {float(closure):g} '
    if hinge > allowable:
        sentence = (f'{head}exceeds the allowable {allowable * 100:.1f} % ({source}) by '
                    f'{hinge / allowable:.1f}x; a hinge of this lay-up needs to be at least '
                    f'{hinge_width_for_allowable_m(panel, closure) * 1e3:.0f} mm wide')
    else:
        sentence = (f'{head}stays within the allowable {allowable * 100:.1f} % ({source}), '
                    f'at {hinge / allowable:.2f} of it')
    plates = [f'{name} {value * 100:.2f} % (allowable {limit * 100:.1f} %)'
              for name, value, limit in (
                  ('mid-rib', strain.midrib_strain[0], strain.midrib_allowable_strain[0]),
                  ('flaps', strain.flap_strain[0], strain.flap_allowable_strain[0]))
              if value > limit]
    if plates:
        sentence += '; over their allowable too: ' + ', '.join(plates)
    return sentence


def warn_if_over_allowable(geometries: Iterable[Panel], panel_ids: Sequence[str], figure: str,
                           template: Optional[AnyActuatedPanel] = None, closure: float = 1.0,
                           stacklevel: int = 2) -> PanelStrain:
    """Warn once if any panel exceeds an allowable strain at ``closure``; return the strains.

    One :class:`StrainLimitWarning` names the worst panel (its id, the zone and its strain
    against the allowable) and how many of the panels exceed theirs. A warning, not an
    error: the laminates and hinge widths of the presets are estimates, and refusing would
    stop every facade built on them; the operator is told, the facade still runs.

    Parameters
    ----------
    geometries : list of PanelGeometry or HexagonPanel
        The panels' geometries, all of one kind.
    panel_ids : list of str
        One id per panel, for the message.
    figure : str
        What the panels belong to (a facade's name), for the message.
    template : ActuatedPanel or HexagonActuatedPanel, optional
        Whose laminates (and, for a hexagon, cone core) the panels are built with; the
        kind's preset by default, as :func:`~.kinds.actuated_like` builds them. The cushion
        does not enter the strains and is not built.
    closure : float
        The largest closure the panels are commanded to.
    stacklevel : int
        As for :func:`warnings.warn`, counted from the caller of this function.

    Returns
    -------
    PanelStrain
        The strains of every panel at ``closure``.
    """
    geometries = list(geometries)
    if template is None:
        template = (HEXAGON_ACTUATED if geometries and isinstance(geometries[0], HexagonPanel)
                    else DEMONSTRATOR_ACTUATED)
    core = getattr(template, 'core_radius_m', math.nan)
    builds = [_Build(geometry, template.midrib, template.flap, template.hinge, core)
              for geometry in geometries]
    if not builds:
        raise ValueError('strains need at least one panel')
    strain = _strain_of_builds(builds, closure)
    utilisation = strain.utilisation
    over = np.flatnonzero(utilisation > 1.0)
    if over.size:
        worst = int(np.argmax(utilisation))
        zones = (('hinge', strain.hinge_strain, strain.hinge_allowable_strain),
                 ('mid-rib', strain.midrib_strain, strain.midrib_allowable_strain),
                 ('flap', strain.flap_strain, strain.flap_allowable_strain))
        name, value, limit = max(zones, key=lambda zone: zone[1][worst] / zone[2][worst])
        warnings.warn(
            f'strain limit: {figure}: {over.size} of {len(utilisation)} panels exceed their '
            f'allowable strain at closure {float(closure):g}; the worst, panel '
            f'{panel_ids[worst]}, reaches {value[worst] * 100:.2f} % in its {name}, '
            f'{value[worst] / limit[worst]:.1f}x the allowable {limit[worst] * 100:.1f} % '
            f'(an estimate for fatigue; fold_table prints the strains of the presets)',
            StrainLimitWarning, stacklevel=stacklevel + 1)
    return strain
