"""Hexagonal facades: ``panel: {type: hexagon, ...}`` to cells, pre-folds and HexagonPanels.

Called by :mod:`flectofold_model.facade.description` once the document's sections have been
type-checked; the schema is in ``msg_docs/hexagon_facade.md``. A hexagonal facade has no
rows or columns to set: the surface's size and ``panel.circumradius_m`` fix the lattice
(:mod:`.hexagon_cells`); ``grid`` is optional and may hold only ``gap_m``, the joint between
the parallel edges of neighbouring panels (each lattice cell has circumradius
``circumradius_m + gap_m / sqrt 3``, so a panel on a plane has exactly ``circumradius_m``).
The pre-fold a patch supplies follows :mod:`.hexagon_prefold`; moulding and exclusion follow
the quad rule.
"""

import math
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from flectofold_model._validate import FloatArray
from flectofold_model.facade import hexagon_cells, surfaces
from flectofold_model.facade.hexagon_prefold import (centre_rise_m, flap_tilt_rad,
                                                     reflection_fold_rad)
from flectofold_model.facade.schema import (build, BuiltPanels, check, check_mix, FacadeError,
                                            need, PANEL_DEFAULTS, PANEL_KEYS, parametric, SCHEMA,
                                            shown_key, surface_kind)
from flectofold_model.kinematics.hexagon_closure import HexagonFoldModel, MAX_SPOKE_TILT_RAD
from flectofold_model.kinematics.hexagon_panel import HexagonBatch, HexagonPanel
from flectofold_model.safe_yaml import short_repr

_SQRT3 = math.sqrt(3.0)
#: Keys an override may set for one hexagonal panel (the lattice fixes every cell's size).
_OVERRIDE = {key: SCHEMA['panel'][key] for key in PANEL_KEYS['hexagon']
             if key != 'circumradius_m'}


def cells(document: Mapping[str, Any], base_directory: Path) -> hexagon_cells.HexagonCells:
    """Validate ``surface``, ``grid`` and the lattice size; return the surface's cells."""
    template, grid = document['panel'], document.get('grid', {})
    for key in grid:
        if key != 'gap_m':
            raise FacadeError(f'grid.{shown_key(key)}: not used by a hexagon facade (the surface '
                              f'and panel.circumradius_m fix the lattice; only gap_m is set)')
    radius = need(template, 'panel', 'circumradius_m')
    if radius <= 0:
        raise FacadeError(f'panel.circumradius_m: must be positive, got {radius:g} m')
    gap = grid.get('gap_m', 0.0)
    if not 0 <= gap <= radius:
        raise FacadeError(f'grid.gap_m: must lie in [0, panel.circumradius_m = {radius:g} m], '
                          f'got {gap:g} m')
    surface = document['surface']
    kind = surface_kind(surface)
    if kind == 'obj':
        path = base_directory / need(surface, 'surface', 'path')
        vertices, faces, lines = build('surface.path',
                                       lambda: surfaces.read_obj_faces(path, 6))
        return build('surface.path', lambda: hexagon_cells.obj_hexagon_cells(
            vertices, faces, lines, path))
    shape = parametric(surface, kind)
    return build('surface', lambda: hexagon_cells.tessellate(shape, radius + gap / _SQRT3))


def panels(cells: hexagon_cells.HexagonCells, document: Mapping[str, Any]) -> BuiltPanels:
    """Panels, ids, kept cell indices, surface and moulded pre-folds, exclusions."""
    template = {k: v for k, v in document['panel'].items() if k != 'type'}
    gap = document.get('grid', {}).get('gap_m', 0.0)
    ids = [f'r{r:02d}c{c:02d}' for r, c in zip(cells.row, cells.column)]
    overrides = _overrides(document.get('overrides', {}), ids)
    settings = [{**PANEL_DEFAULTS, **template, **overrides.get(i, {})} for i in ids]
    for panel_id, values in zip(ids, settings):
        _check_settings(values, f'overrides.{panel_id}' if panel_id in overrides else 'panel')
    radius = cells.circumradius_m - gap / _SQRT3
    sag = np.array([values['fold_line_sag_m'] for values in settings])
    supplied = _supplied(cells, radius, sag, ids)
    built, kept, surface_prefold, moulded, excluded = [], [], [], [], []
    for index, panel_id in enumerate(ids):
        values = settings[index]
        mould = min(max(values['min_prefold_rad'] - supplied[index], 0.0),
                    values['max_moulded_prefold_rad'])
        prefold = supplied[index] + mould
        if prefold < values['min_prefold_rad'] - 1e-12:
            excluded.append((panel_id, f'the surface folds it '
                                       f'{math.degrees(supplied[index]):+.1f} deg and the '
                                       f'mould can add only {math.degrees(mould):.1f} deg'))
            continue
        where = f'overrides.{panel_id}' if panel_id in overrides else 'panel'
        built.append(build(f'{where} ({panel_id})', lambda: HexagonPanel(
            circumradius_m=radius[index], fold_line_sag_m=values['fold_line_sag_m'],
            hinge_width_m=values['hinge_width_m'], prefold_rad=prefold,
            closed_clearance_m=values['closed_clearance_m'])))
        kept.append(index)
        surface_prefold.append(supplied[index])
        moulded.append(mould)
    if built:
        _check_fold_models(built, [ids[i] for i in kept])
    return built, [ids[i] for i in kept], np.array(kept, dtype=int), surface_prefold, \
        moulded, excluded


def _overrides(overrides: Mapping[Any, Any], ids: list[str]) -> Mapping[Any, Any]:
    known = set(ids)
    for panel_id, values in overrides.items():
        if panel_id not in known:
            raise FacadeError(f'overrides.{shown_key(panel_id)}: no such panel '
                              f'(ids look like r00c03)')
        if not isinstance(values, dict):
            raise FacadeError(f'overrides.{panel_id}: must be a mapping, '
                              f'got {short_repr(values)}')
        check_mix(values, f'overrides.{panel_id}')
        if 'circumradius_m' in values:
            raise FacadeError(f'overrides.{panel_id}.circumradius_m: the lattice sets every '
                              f'cell of a hexagon facade to one size; set panel.circumradius_m')
        check(values, _OVERRIDE, f'overrides.{panel_id}.')
    return overrides


def _check_settings(values: Mapping[str, Any], where: str) -> None:
    for key in ('fold_line_sag_m', 'hinge_width_m'):
        if key not in values:
            raise FacadeError(f'panel.{key}: missing')
    low = values['min_prefold_rad']
    if not 0 < low < math.pi / 2:
        raise FacadeError(f'{where}.min_prefold_rad: must lie in (0, pi/2) rad (a hexagonal '
                          f'panel needs some pre-fold to fold the right way), got {low:g}')
    most = values['max_moulded_prefold_rad']
    if not 0 <= most < math.pi / 2:
        raise FacadeError(f'{where}.max_moulded_prefold_rad: must lie in [0, pi/2) rad, '
                          f'got {most:g}')


def _supplied(cells: hexagon_cells.HexagonCells, radius: FloatArray, sag: FloatArray,
              ids: list[str]) -> FloatArray:
    """Pre-fold (N,) each cell's patch supplies; refuse patches too curved for the panel."""
    if np.any(radius <= 0):
        raise FacadeError('grid.gap_m: leaves no panel in a cell')
    rise = centre_rise_m(radius, cells.curvature_flap_per_m)
    limit = radius * math.sin(MAX_SPOKE_TILT_RAD)
    too_curved = np.flatnonzero(~(np.abs(rise) < limit))
    if too_curved.size:
        index = int(too_curved[0])
        raise FacadeError(f'surface: the patch of {ids[index]} moves the panel centre '
                          f"{rise[index]:+.3f} m out of its vertices' plane, more than a "
                          f'panel of circumradius {radius[index]:.3f} m can take '
                          f'({limit[index]:.3f} m): the surface is too curved for it')
    tilt = flap_tilt_rad(radius, sag, cells.curvature_flap_per_m)
    return reflection_fold_rad(radius, sag, rise) + tilt.min(axis=-1)


def _check_fold_models(panels: list[HexagonPanel], ids: list[str]) -> None:
    """Refuse panels the fold model cannot close (hinge too narrow, pre-fold past closed)."""
    try:
        HexagonFoldModel(HexagonBatch.from_panels(panels))
        return
    except ValueError as error:
        failure = error
    for panel, panel_id in zip(panels, ids):
        build(f'panel ({panel_id})', lambda: HexagonFoldModel(HexagonBatch.from_panels([panel])))
    raise FacadeError(f'panel: {failure}')
