"""Facade descriptions: YAML in, validated panels with frames and pre-folds out.

The schema is documented, with an example per surface type, in ``msg_docs/facade.md``. Loading
checks everything before anything starts: unknown keys, wrong types, non-finite numbers and
impossible sizes raise :class:`FacadeError` naming the key path (``grid.rows``) and the reason.
YAML is read with :func:`flectofold_model.safe_yaml.load_yaml`: plain values only, no aliases,
bounded size, node count and depth. A value quoted in a message is cut to a short repr.

Pre-fold. A Flectofold panel folds the right way only if it starts with some fold toward
closing (``min_prefold_rad``). On a curved facade the patch supplies part of it: bending the
mid-rib along a convex direction ``kappa_x`` sags it by ``kappa_x L**2 / 8``, which the curved
crease turns into ``2 atan(kappa_x L**2 / (8 h_c))`` of fold (the reflection law), and a concave
cross-curvature ``kappa_y < 0`` tilts the flaps up by about ``-kappa_y W / 4``. Anticlastic
patches (convex along the mid-rib, concave across) supply both; a plane supplies none; a dome
gives with one hand and takes with the other. Where the surface gives too little, the paper's
adjustment is applied: choose the mid-rib direction that is more convex (``midrib_along: auto``)
and mould the missing pre-fold into the panel, up to ``max_moulded_prefold_rad``. Patches that
would still fold the wrong way are reported and left out of the array.

Panel kinds. ``panel.type`` is ``quad`` (the default, everything above) or ``hexagon``: the
surface is then tessellated into regular hexagonal cells on a hexagonal lattice and each
cell carries a :class:`~flectofold_model.kinematics.hexagon_panel.HexagonPanel`
(:mod:`.hexagon_description`; the pre-fold rule is in :mod:`.hexagon_prefold`). A facade is
all one kind: ``Facade.panel_kind`` says which.
"""

from dataclasses import dataclass, field, fields
import math
from pathlib import Path

import re
from typing import Any, Mapping

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import FloatArray, IntArray, PathLike
from flectofold_model.environment.sun import Site
from flectofold_model.facade import surfaces
from flectofold_model.facade.hexagon_cells import HexagonCells
from flectofold_model.facade.schema import (build, BuiltPanels, check, check_mix, check_type,
                                            FacadeError, need, PANEL_DEFAULTS, PANEL_KEYS,
                                            parametric, SCHEMA, shown_key, surface_kind)
from flectofold_model.kinematics.hexagon_panel import HexagonPanel
from flectofold_model.kinematics.kinds import Panel
from flectofold_model.kinematics.panel import fold_line_sag, PanelGeometry
from flectofold_model.safe_yaml import load_yaml, read_yaml, short_repr, YAMLInputError

#: The embedded facade descriptions, each loadable by its file's stem (``hexagon_6x6``).
DATA_DIRECTORY = Path(__file__).with_name('data')
DEFAULT_FACADE = DATA_DIRECTORY / 'demonstrator_6x6.yaml'

_QUAD_PANEL = {key: SCHEMA['panel'][key] for key in PANEL_KEYS['quad']}
_CONTROL_KEYS = {'period_s', 'shading_target', 'look_ahead_s', 'controller'}
#: Where the plant, the loops and the scheduler take a panel's pressure, air and closure from:
#: the energy statics of each panel, or the structural model of the facade's median panel.
CUSHION_MAPS = ('energy', 'structural', 'structural_per_panel')
#: A facade's name ends up in recording ids and file names: a short plain word.
_NAME = re.compile(r'[A-Za-z0-9][A-Za-z0-9_.-]{0,63}')


@dataclass(frozen=True)
class Facade:
    """A built facade: its site, its panels and where each one sits."""

    name: str
    site: Site
    utc_offset_h: float
    azimuth_deg: float
    panel_ids: list
    """``r<row>c<column>`` per built panel, rows counted up from the bottom."""
    panels: list
    """:class:`~flectofold_model.kinematics.panel.PanelGeometry` per built panel."""
    origin_m: np.ndarray
    """(N, 3) panel origins in the facade frame [m]."""
    rotation: np.ndarray
    """(N, 3, 3) panel frames in the facade frame (columns x, y, z)."""
    surface_prefold_rad: np.ndarray
    """Pre-fold each built patch's curvature supplies [rad]."""
    moulded_prefold_rad: np.ndarray
    """Pre-fold moulded in where the surface supplies too little [rad]."""
    gaussian_sign: np.ndarray
    excluded: list
    """``(panel id, reason)`` of patches that cannot be made to fold the right way."""
    control: dict = field(default_factory=dict)
    panel_kind: str = 'quad'
    """``'quad'`` (:class:`~flectofold_model.kinematics.panel.PanelGeometry` panels) or
    ``'hexagon'`` (:class:`~flectofold_model.kinematics.hexagon_panel.HexagonPanel` panels)."""
    cushion_map: str = 'energy'
    """``actuation.cushion_map``: ``'energy'`` (each panel's energy statics),
    ``'structural'`` (the structural model of the median panel for every panel) or
    ``'structural_per_panel'`` (each panel's own structural model); the structural ones for
    quad facades only (see :func:`~flectofold_model.structure.facade_map.facade_cushion_map`)."""

    def __len__(self) -> int:
        return len(self.panels)

    @property
    def facade_to_enu(self) -> FloatArray:
        """Rotation (3, 3) from the facade frame to the site's ENU frame."""
        azimuth = math.radians(self.azimuth_deg)
        outward = np.array([math.sin(azimuth), math.cos(azimuth), 0.0])
        up = np.array([0.0, 0.0, 1.0])
        return np.stack([np.cross(up, outward), up, outward], axis=-1)

    @property
    def panel_to_enu(self) -> FloatArray:
        """(N, 3, 3) rotations from each panel frame to ENU."""
        return np.einsum('ij,njk->nik', self.facade_to_enu, self.rotation)

    def sun_in_panel_frames(self, sun_enu: npt.ArrayLike) -> FloatArray:
        """Sun directions (..., 3) in ENU expressed in every panel frame: (..., N, 3)."""
        return np.einsum('nji,...j->...ni', self.panel_to_enu, np.asarray(sun_enu, dtype=float))

    def report(self) -> list[str]:
        """Human-readable lines: surface pre-fold, moulded pre-fold and exclusions."""
        lines = [f'{self.name}: {len(self)} {self.panel_kind} panels built, '
                 f'{len(self.excluded)} left out']
        for index, panel_id in enumerate(self.panel_ids):
            lines.append(
                f'  {panel_id}: {_size(self.panels[index])}, '
                f'K sign {self.gaussian_sign[index]:+d}, '
                f'surface pre-fold {math.degrees(self.surface_prefold_rad[index]):+.1f} deg, '
                f'moulded {math.degrees(self.moulded_prefold_rad[index]):.1f} deg')
        lines.extend(f'  {panel_id}: left out: {reason}' for panel_id, reason in self.excluded)
        return lines


def _size(panel: Panel) -> str:
    """Return a panel's size as the report prints it: length x width, or radius and area."""
    if isinstance(panel, HexagonPanel):
        return f'hexagon R {panel.circumradius_m:.3f} m ({panel.area_m2:.3f} m2)'
    return f'{panel.length_m:.3f} x {panel.width_m:.3f} m'


def embedded_facades() -> list[str]:
    """Names of the embedded facade descriptions (the stems of ``data/*.yaml``), sorted."""
    return sorted(path.stem for path in DATA_DIRECTORY.glob('*.yaml'))


def facade_path(name_or_path: PathLike) -> Path:
    """Return the file a facade argument names: an existing file, else an embedded one.

    A value that is no existing file but the name of an embedded description
    (:func:`embedded_facades`, e.g. ``hexagon_6x6``) means that one, wherever the process
    runs; anything else is returned as a path.
    """
    name = str(name_or_path)
    if name in embedded_facades() and not Path(name).exists():  # a known short name only
        return DATA_DIRECTORY / f'{name}.yaml'
    return Path(name_or_path)


def load_facade(path: PathLike = DEFAULT_FACADE) -> Facade:
    """Read, validate and build a facade description from a YAML file or an embedded name.

    ``path`` is a YAML file, or the name of an embedded description (see
    :func:`facade_path`).

    Actuation check: a facade whose panels cannot be actuated like their kind's preset module
    (:func:`~flectofold_model.actuation.kinds.actuated_like`: its cushion does not fit them)
    is refused with :class:`FacadeError`, as every process that runs it would fail.

    Strain check: a facade whose panels, built like the presets
    (:func:`~flectofold_model.actuation.kinds.actuated_like`), exceed their laminates'
    allowable strain at closure 1 gets one
    :class:`~flectofold_model.actuation.strain.StrainLimitWarning` naming the worst panel and
    its strain and how many panels exceed. Closure 1 is the largest closure a facade can
    command: a description sets no closure limit (``control.default_closure``, overrides and
    the scheduler all reach 1). A warning, not a :class:`FacadeError`: the laminates, hinge
    widths and allowable strain are estimates, and refusing would stop every facade built on
    them (the embedded ones included). The check runs here, where a user or a node loads a
    description, and not in :func:`build_facade`, the programmatic build from text.
    """
    path = facade_path(path)
    try:
        document = read_yaml(path)
    except OSError as error:
        embedded = ', '.join(embedded_facades())
        raise FacadeError(f'{path}: cannot read the facade description: '
                          f'{error.strerror or error} (embedded descriptions: '
                          f'{embedded})') from None
    except YAMLInputError as error:
        raise FacadeError(str(error)) from None
    facade = _build_document(document, Path(path).parent)
    _check_actuation(facade, path)
    _warn_about_strain(facade)
    return facade


def _check_actuation(facade: Facade, path: PathLike) -> None:
    """Refuse a facade whose panels cannot be actuated like their kind's preset module.

    The geometry can be valid and the preset's cushion still not fit (longer or wider than a
    small panel's mid-rib, a stroke too short for a large one): every process that runs the
    facade builds that model, and one that found out only then (the coordinator, 29 s into a
    bringup) died with a traceback naming no file. Raises :class:`FacadeError` naming the file,
    the first panel and the reason.
    """
    from flectofold_model.actuation import actuated_like, actuation_model_of
    try:
        actuation_model_of(actuated_like(panel) for panel in facade.panels)
        return
    except ValueError:
        pass
    for panel_id, panel in zip(facade.panel_ids, facade.panels):
        try:
            actuation_model_of([actuated_like(panel)])
        except ValueError as error:
            raise FacadeError(f'{path}: panel {panel_id} cannot be actuated like the '
                              f'{facade.panel_kind} preset module: {error}') from None


def _warn_about_strain(facade: Facade) -> None:
    """Warn (:class:`~.strain.StrainLimitWarning`, once) if panels exceed allowable strains.

    One place for both panel kinds: the strain check picks the kind's preset laminates.
    """
    from flectofold_model.actuation.strain import warn_if_over_allowable
    warn_if_over_allowable(facade.panels, facade.panel_ids, f'facade {facade.name}',
                           closure=1.0, stacklevel=3)


def surface_quads(path: PathLike = DEFAULT_FACADE) -> tuple[FloatArray, IntArray]:
    """Return the quad mesh of a quad facade's surface, one quad per patch, facade frame [m].

    The mesh that ``surface: {type: obj}`` reads back to the same patches: for a parametric
    surface its ``grid`` cells with their corners on the surface
    (:meth:`~.surfaces.ParametricSurface.grid_quads`; on a curved surface the quad's centre,
    the mean of its corners, lies off the surface by the cell's sag); for an OBJ surface the
    file's own quads. Returns vertices (M, 3) and quads (Q, 4) of vertex indices. The
    description is loaded and checked first (:func:`load_facade`); a hexagon facade raises
    :class:`FacadeError` (its cells are not quads).
    """
    path = facade_path(path)
    load_facade(path)
    document = read_yaml(path)
    if _panel_kind(document['panel']) != 'quad':
        raise FacadeError('surface quads: a hexagon facade is tessellated into hexagonal '
                          'cells, not quads')
    surface = document['surface']
    kind = surface_kind(surface)
    if kind == 'obj':
        return build('surface.path', lambda: surfaces.read_obj_quads(
            Path(path).parent / surface['path']))
    grid = document['grid']
    return parametric(surface, kind).grid_quads(grid['rows'], grid['columns'])


def build_facade(text: str, base_directory: PathLike = '.') -> Facade:
    """Validate and build a facade from YAML text (OBJ paths resolve from base_directory)."""
    try:
        document = load_yaml(text, 'facade description')
    except YAMLInputError as error:
        raise FacadeError(str(error)) from None
    return _build_document(document, Path(base_directory))


def _build_document(document: object, base_directory: Path) -> Facade:
    if not isinstance(document, dict):
        raise FacadeError('a facade description is a mapping of sections')
    check(document, SCHEMA, '')
    _check_name(document.get('name', 'facade'))
    for section in ('site', 'facade', 'surface', 'panel'):
        if section not in document:
            raise FacadeError(f'{section}: missing section')
    kind = _panel_kind(document['panel'])
    if kind == 'quad' and 'grid' not in document:
        raise FacadeError('grid: missing section')
    site_doc = document['site']
    site = build('site', lambda: Site(latitude_deg=need(site_doc, 'site', 'latitude_deg'),
                                      longitude_deg=need(site_doc, 'site', 'longitude_deg'),
                                      elevation_m=site_doc.get('elevation_m', 0.0)))
    utc_offset = site_doc.get('utc_offset_h', 0.0)
    if not -12 <= utc_offset <= 14:
        raise FacadeError(f'site.utc_offset_h: must lie in [-12, 14] h, got {utc_offset:g}')
    azimuth = need(document['facade'], 'facade', 'azimuth_deg')
    if not 0 <= azimuth < 360:
        raise FacadeError(f'facade.azimuth_deg: must lie in [0, 360), got {azimuth:g}')
    if kind == 'hexagon':
        built = _hexagon_facade(document, base_directory)
    else:
        built = _quad_facade(document, base_directory)
    cushion_map = _cushion_map(document.get('actuation', {}), kind)
    patches, control, (panels, ids, kept, surface_prefold, moulded, excluded) = built
    if not panels:
        raise FacadeError('no patch can carry a panel that folds the right way: '
                          + '; '.join(f'{i}: {r}' for i, r in excluded[:5]))
    return Facade(name=document.get('name', 'facade'), site=site, utc_offset_h=utc_offset,
                  azimuth_deg=azimuth, panel_ids=ids, panels=panels,
                  origin_m=patches.origin_m[kept], rotation=patches.rotation[kept],
                  surface_prefold_rad=np.array(surface_prefold),
                  moulded_prefold_rad=np.array(moulded),
                  gaussian_sign=patches.gaussian_sign[kept], excluded=excluded, control=control,
                  panel_kind=kind, cushion_map=cushion_map)


def _panel_kind(template: Mapping[Any, Any]) -> str:
    kind = template.get('type', 'quad')
    if kind not in PANEL_KEYS:
        raise FacadeError(f"panel.type: must be 'quad' or 'hexagon', got {short_repr(kind)}")
    for key in template:
        if key != 'type' and key not in PANEL_KEYS[kind]:
            other = next(k for k in PANEL_KEYS if k != kind)
            raise FacadeError(f'panel.{key}: not used by a {kind} panel (a {other} key; a '
                              f'facade is all quad or all hexagon panels, set by panel.type)')
    return kind


def _quad_facade(document: Mapping[str, Any],
                 base_directory: Path) -> tuple[surfaces.Patches, dict[str, Any], BuiltPanels]:
    patches = _patches(document['surface'], document['grid'], base_directory)
    control = _control(document.get('control', {}))
    panels = _panels(patches, document['panel'], document['grid'],
                     document.get('overrides', {}))
    return patches, control, panels


def _hexagon_facade(document: Mapping[str, Any],
                    base_directory: Path) -> tuple[HexagonCells, dict[str, Any], BuiltPanels]:
    from flectofold_model.facade import hexagon_description
    cells = hexagon_description.cells(document, base_directory)
    control = _control(document.get('control', {}))
    return cells, control, hexagon_description.panels(cells, document)


def _check_name(name: object) -> None:
    if not (isinstance(name, str) and _NAME.fullmatch(name)):
        raise FacadeError(f'name: must be 1 to 64 letters, digits, _ . or - (starting with a '
                          f'letter or digit), got {short_repr(name)}')


def _patches(surface: Mapping[Any, Any], grid: Mapping[Any, Any],
             base_directory: Path) -> surfaces.Patches:
    kind = surface_kind(surface)
    midrib = grid.get('midrib_along', 'v')
    if midrib not in ('u', 'v', 'auto'):
        raise FacadeError(f"grid.midrib_along: must be 'u', 'v' or 'auto', "
                          f'got {short_repr(midrib)}')
    if kind == 'obj':
        path = base_directory / need(surface, 'surface', 'path')
        vertices, faces = build('surface.path', lambda: surfaces.read_obj_quads(path))
        return build('surface', lambda: surfaces.obj_patches(vertices, faces, midrib))
    shape = parametric(surface, kind)
    rows, columns = (need(grid, 'grid', key) for key in ('rows', 'columns'))
    for key, value in (('rows', rows), ('columns', columns)):
        if not 1 <= value <= 1000:
            raise FacadeError(f'grid.{key}: must lie in [1, 1000], got {short_repr(value)}')
    return shape.tessellate(rows, columns, midrib)


def _cushion_map(actuation: Mapping[Any, Any], kind: str) -> str:
    choice = actuation.get('cushion_map', 'energy')
    if choice not in CUSHION_MAPS:
        raise FacadeError(f'actuation.cushion_map: must be one of {", ".join(CUSHION_MAPS)}, '
                          f'got {short_repr(choice)}')
    if choice != 'energy' and kind != 'quad':
        raise FacadeError(f'actuation.cushion_map: {choice} needs quad panels; the '
                          'hexagonal module does not close in the structural model '
                          '(msg_docs/structure.md)')
    return choice


def _control(control: Mapping[Any, Any]) -> dict[str, Any]:
    from flectofold_model.scheduling.predictive import CONTROLLERS, PredictiveParameters
    from flectofold_model.scheduling.scheduler import SchedulerParameters
    predictive = {f.name for f in fields(PredictiveParameters)}
    known = _CONTROL_KEYS | predictive | {f.name for f in fields(SchedulerParameters)}
    for key, value in control.items():
        if key not in known:
            raise FacadeError(f'control.{shown_key(key)}: unknown key '
                              f'(known: {", ".join(sorted(known))})')
        if key == 'controller':
            if value not in CONTROLLERS:
                raise FacadeError(f'control.controller: must be one of '
                                  f'{", ".join(CONTROLLERS)}, got {short_repr(value)}')
            continue
        check_type(f'control.{key}', value, float)
    scheduler = {k: v for k, v in control.items()
                 if k not in _CONTROL_KEYS and k not in predictive}
    build('control', lambda: SchedulerParameters(**scheduler))
    build('control', lambda: PredictiveParameters.of(control))
    target = control.get('shading_target', 0.9)
    if not 0 <= target <= 1:
        raise FacadeError(f'control.shading_target: must lie in [0, 1], got {target:g}')
    for key in ('period_s', 'look_ahead_s'):
        if key in control and control[key] <= 0:
            raise FacadeError(f'control.{key}: must be positive, got {control[key]:g} s')
    return dict(control)


def _panels(patches: surfaces.Patches, template: Mapping[Any, Any], grid: Mapping[Any, Any],
            overrides: Mapping[Any, Any]) -> BuiltPanels:
    gap = grid.get('gap_m', 0.0)
    if gap < 0:
        raise FacadeError(f'grid.gap_m: must not be negative, got {gap:g} m')
    ids = [f'r{r:02d}c{c:02d}' for r, c in zip(patches.row, patches.column)]
    for panel_id, settings in overrides.items():
        if panel_id not in ids:
            raise FacadeError(f'overrides.{shown_key(panel_id)}: no such panel '
                              f'(ids look like r00c03)')
        if not isinstance(settings, dict):
            raise FacadeError(f'overrides.{panel_id}: must be a mapping, '
                              f'got {short_repr(settings)}')
        check_mix(settings, f'overrides.{panel_id}')
        check(settings, _QUAD_PANEL, f'overrides.{panel_id}.')
    panels, built_ids, kept, surface_prefold, moulded, excluded = [], [], [], [], [], []
    for index, panel_id in enumerate(ids):
        settings = {**PANEL_DEFAULTS, **template, **overrides.get(panel_id, {})}
        where = f'overrides.{panel_id}' if panel_id in overrides else 'panel'
        for key in ('fold_radius_m', 'midrib_end_width_m', 'hinge_width_m'):
            if key not in settings:
                raise FacadeError(f'panel.{key}: missing')
        length = patches.length_m[index] - gap
        width = patches.width_m[index] - gap
        supplied = _surface_prefold(patches, index, length, width, settings)
        missing = settings['min_prefold_rad'] - supplied
        mould = min(max(missing, 0.0), settings['max_moulded_prefold_rad'])
        prefold = supplied + mould
        if prefold < settings['min_prefold_rad'] - 1e-12:
            excluded.append((panel_id, f'the surface folds it {math.degrees(supplied):+.1f} deg '
                                       f'and the mould can add only '
                                       f'{math.degrees(mould):.1f} deg'))
            continue
        panel = build(f'{where} ({panel_id})', lambda: PanelGeometry.with_lens_midrib(
            length_m=length, width_m=width, fold_radius_m=settings['fold_radius_m'],
            end_width_m=settings['midrib_end_width_m'], hinge_width_m=settings['hinge_width_m'],
            prefold_rad=prefold, closed_clearance_m=settings['closed_clearance_m']))
        panels.append(panel)
        built_ids.append(panel_id)
        kept.append(index)
        surface_prefold.append(supplied)
        moulded.append(mould)
    return panels, built_ids, np.array(kept, dtype=int), surface_prefold, moulded, excluded


def _surface_prefold(patches: surfaces.Patches, index: int, length: float, width: float,
                     settings: Mapping[str, Any]) -> float:
    sag = fold_line_sag(settings['fold_radius_m'], length)
    if not np.isfinite(sag) or sag <= 0:
        raise FacadeError(f'panel.fold_radius_m: {settings["fold_radius_m"]:g} m cannot span a '
                          f'{length:.3f} m mid-rib (it must exceed half the length)')
    midrib_sag = patches.curvature_x_per_m[index] * length**2 / 8
    return 2 * math.atan(midrib_sag / sag) - patches.curvature_y_per_m[index] * width / 4
