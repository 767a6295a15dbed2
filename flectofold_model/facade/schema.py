"""What the facade descriptions of both panel kinds share: the schema, its checks, the error.

:mod:`.description` (quad panels, and the document as a whole) and
:mod:`.hexagon_description` (hexagonal panels) both check their sections against these
tables and build the parametric surface with these helpers; every refusal is a
:class:`FacadeError` naming the key path (``grid.rows``) and the reason.
"""

import math
from typing import Any, Callable, Mapping, TypeVar

from flectofold_model._validate import IntArray
from flectofold_model.facade import surfaces
from flectofold_model.safe_yaml import short_repr


class FacadeError(ValueError):
    """A facade description that cannot be built; the message names the key and the reason."""


_T = TypeVar('_T')
#: What building a facade's panels gives, for either kind: panels, their ids, the indices of
#: the patches or cells kept, surface and moulded pre-folds [rad], ``(panel id, reason)`` of
#: those left out.
BuiltPanels = tuple[list[Any], list[str], IntArray, list[float], list[float],
                    list[tuple[str, str]]]

SCHEMA: dict[str, Any] = {
    'name': str,
    'site': {'latitude_deg': float, 'longitude_deg': float, 'elevation_m': float,
             'utc_offset_h': float},
    'facade': {'azimuth_deg': float},
    'surface': {'type': str, 'width_m': float, 'height_m': float, 'radius_m': float,
                'semi_axis_u_m': float, 'semi_axis_v_m': float, 'depth_m': float,
                'curvature_u_per_m': float, 'curvature_v_per_m': float, 'path': str},
    'grid': {'rows': int, 'columns': int, 'gap_m': float, 'midrib_along': str},
    'panel': {'type': str, 'fold_radius_m': float, 'midrib_end_width_m': float,
              'hinge_width_m': float, 'min_prefold_rad': float,
              'max_moulded_prefold_rad': float, 'closed_clearance_m': float,
              'circumradius_m': float, 'fold_line_sag_m': float},
    'overrides': dict,
    'control': dict,
    'actuation': {'cushion_map': str},
}
#: The panel keys of each panel kind (``panel.type``); a facade is all one kind.
PANEL_KEYS = {
    'quad': ('fold_radius_m', 'midrib_end_width_m', 'hinge_width_m', 'min_prefold_rad',
             'max_moulded_prefold_rad', 'closed_clearance_m'),
    'hexagon': ('circumradius_m', 'fold_line_sag_m', 'hinge_width_m', 'min_prefold_rad',
                'max_moulded_prefold_rad', 'closed_clearance_m'),
}
SURFACE_KEYS = {'plane': (), 'cylinder': ('radius_m',),
                'dome': ('semi_axis_u_m', 'semi_axis_v_m', 'depth_m'),
                'saddle': ('curvature_u_per_m', 'curvature_v_per_m'), 'obj': ('path',)}
PANEL_DEFAULTS = {'min_prefold_rad': math.radians(5.0),
                  'max_moulded_prefold_rad': math.radians(15.0), 'closed_clearance_m': 0.02}


def shown_key(key: object) -> str:
    """Return a key as a message shows it: a short string as is, anything else quoted."""
    if isinstance(key, str) and len(key) <= 40 and key.isprintable():
        return key
    return short_repr(key)


def check(document: Mapping[Any, Any], schema: Mapping[str, Any], prefix: str) -> None:
    for key, value in document.items():
        where = f'{prefix}{shown_key(key)}'
        if key not in schema:
            known = ', '.join(sorted(schema))
            raise FacadeError(f'{where}: unknown key (known here: {known})')
        expected = schema[key]
        if isinstance(expected, dict):
            if not isinstance(value, dict):
                raise FacadeError(f'{where}: must be a mapping, got {type(value).__name__}')
            check(value, expected, f'{where}.')
        else:
            check_type(where, value, expected)


def check_type(where: str, value: object, expected: type) -> None:
    if expected is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise FacadeError(f'{where}: must be a number, got {short_repr(value)}')
        try:
            finite = math.isfinite(value)
        except OverflowError:  # an integer beyond any float
            finite = False
        if not finite:
            raise FacadeError(f'{where}: must be finite, got {short_repr(value)}')
    elif expected is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise FacadeError(f'{where}: must be a whole number, got {short_repr(value)}')
    elif not isinstance(value, expected):
        raise FacadeError(f'{where}: must be a {expected.__name__}, got {short_repr(value)}')


def check_mix(settings: Mapping[Any, Any], where: str) -> None:
    if 'type' in settings:
        raise FacadeError(f'{where}.type: a facade is all quad or all hexagon panels; set '
                          f'panel.type once for the whole facade')


def need(section: Mapping[Any, Any], name: str, key: str) -> Any:
    if key not in section:
        raise FacadeError(f'{name}.{key}: missing')
    return section[key]


def build(where: str, make: Callable[[], _T]) -> _T:
    try:
        return make()
    except (TypeError, ValueError) as error:
        reason = ' '.join(str(error).split())
        reason = reason if len(reason) <= 300 else f'{reason[:297]}...'
        raise FacadeError(f'{where}: {reason}') from None


def surface_kind(surface: Mapping[Any, Any]) -> str:
    """Check ``surface.type`` and that every key belongs to it; return the type."""
    kind = need(surface, 'surface', 'type')
    if kind not in SURFACE_KEYS:
        raise FacadeError(f'surface.type: must be one of {", ".join(SURFACE_KEYS)}, '
                          f'got {short_repr(kind)}')
    allowed = {'type', 'width_m', 'height_m', *SURFACE_KEYS[kind]}
    for key in surface:
        if key not in allowed:
            raise FacadeError(f'surface.{shown_key(key)}: not used by a {kind} surface')
    return kind


def parametric(surface: Mapping[Any, Any], kind: str) -> surfaces.ParametricSurface:
    """Build the parametric surface of a checked ``surface`` section."""
    width, height = (need(surface, 'surface', key) for key in ('width_m', 'height_m'))
    for key, value in (('width_m', width), ('height_m', height)):
        if value <= 0:
            raise FacadeError(f'surface.{key}: must be positive, got {value:g} m')
    arguments = [need(surface, 'surface', key) for key in SURFACE_KEYS[kind]]
    maker = getattr(surfaces, kind)
    return build('surface', lambda: maker(width, height, *arguments))
