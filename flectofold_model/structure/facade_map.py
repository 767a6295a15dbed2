"""A facade's cushion map as its description chooses: energy statics or the structure.

``actuation: {cushion_map: structural}`` in a quad facade's description makes the plant, the
pressure loops and the scheduler's air per move take the pressure, air and compliance of each
panel from the structural model (:mod:`.cushion_tables`) instead of the energy statics. The
structure is traced for one panel, the facade's median panel by footprint area
(:func:`~flectofold_model.facade.footprint.representative_panel`, as the shading table), and
its map drives every panel of the facade: one path costs about 15 s of CPU, and the panels
of one facade differ by millimetres in size and tenths of a degree in pre-fold.
``structural_per_panel`` traces every panel's own design instead (one path per distinct
design, each cached): what the median's map leaves out is measured in
``msg_docs/structure.md``. Only cached maps are read where a process must start in seconds;
the ``facade`` bringup and ``structure_cache`` compute them.
The energy choice (the default) keeps each panel's own statics.
"""

from typing import cast, Optional, TYPE_CHECKING


from flectofold_model._validate import FloatArray
from flectofold_model.actuation import actuated_like, ATMOSPHERIC_PRESSURE_PA
from flectofold_model.actuation.cushion_map import CushionMap
from flectofold_model.actuation.static_model import StaticActuationModel
from flectofold_model.actuation.statics import ActuatedPanel
from flectofold_model.facade.footprint import representative_index
from flectofold_model.structure.cushion_tables import NotCached, structural_cushion_map
from flectofold_model.structure.panel import Progress

if TYPE_CHECKING:  # a facade's description loads where a facade is read
    from flectofold_model.facade.description import Facade

#: What to do when a structural map is not cached: the command that computes it.
WARM_UP = 'structure_cache --facade FILE'


def facade_cushion_map(facade: 'Facade', model: StaticActuationModel, trace: bool = True,
                       progress: Optional[Progress] = None) -> CushionMap:
    """Return the :class:`CushionMap` of ``model``'s panels (N) as ``facade`` chooses.

    Parameters
    ----------
    facade : Facade
        Its ``cushion_map``: ``'energy'``, ``'structural'`` or ``'structural_per_panel'``.
    model : StaticActuationModel
        The energy statics of the panels the map is for (N panels of ``facade``, actuated
        as :func:`~flectofold_model.actuation.kinds.actuated_like` makes them).
    trace : bool
        Structural only: trace the median panel's path (or each panel's) when the cache does
        not have it (about 15 s of CPU each). False raises
        :class:`~.cushion_tables.NotCached` naming the command that computes it.
    progress : callable, optional
        Structural only: passed to the path tracer.
    """
    if facade.cushion_map == 'energy':
        return CushionMap(model)
    if facade.cushion_map == 'structural_per_panel':
        return panels_structural_map(facade, cast(list[ActuatedPanel], model.panels), trace,
                                     progress)
    return median_structural_map(facade, len(model), trace, progress)


def panels_structural_map(facade: 'Facade', panels: list[ActuatedPanel], trace: bool = True,
                          progress: Optional[Progress] = None) -> CushionMap:
    """Return the structural map of ``panels`` (N quad panels of ``facade``), each its own.

    One path per distinct design; ``trace`` and ``progress`` as for
    :func:`facade_cushion_map`.
    """
    try:
        return structural_cushion_map(panels, trace=trace, progress=progress)
    except NotCached as error:
        raise NotCached(f'facade {facade.name} takes the cushion map of each panel from the '
                        f'structure (actuation.cushion_map: structural_per_panel): {error}; '
                        f'compute them once with `{WARM_UP}` (about 15 s of CPU per panel '
                        f'design; `facade` does it before it starts its panels)') from None


def facade_structural_panels(facade: 'Facade') -> list[ActuatedPanel]:
    """Every panel of a quad ``facade`` actuated as its processes actuate it."""
    return [cast(ActuatedPanel, actuated_like(panel)) for panel in facade.panels]


def median_structural_map(facade: 'Facade', count: int = 1, trace: bool = True,
                          progress: Optional[Progress] = None) -> CushionMap:
    """Return the structural map of ``facade``'s median panel for ``count`` panels.

    ``trace`` and ``progress`` as for :func:`facade_cushion_map`.
    """
    median = representative_index(facade)
    # a quad panel: a facade's description takes the structural map for quad panels only
    panel = cast(ActuatedPanel, actuated_like(facade.panels[median]))
    try:
        return structural_cushion_map([panel] * count, trace=trace, progress=progress)
    except NotCached as error:
        raise NotCached(f'facade {facade.name} takes its cushion map from the structure '
                        f'(actuation.cushion_map: structural), traced for its median panel '
                        f'{facade.panel_ids[median]}: {error}; compute it once with '
                        f'`{WARM_UP}` (about 15 s of CPU; `facade` does it before it starts '
                        f'its panels)') from None


def structural_close_air_nl(facade: 'Facade', dead_volume_m3: float) -> FloatArray:
    """Free air [NL] (N,) that closes each panel from open, by the facade's structural map.

    ``(p_closed V_closed - p_atm V_open) / p_atm`` with absolute pressures and the tubing's
    dead volume ``dead_volume_m3`` [m3], at the map's closures 1 and 0: the median panel's
    for every panel, or each panel's own (``structural_per_panel``). Reads the cached maps
    only (:class:`~.cushion_tables.NotCached` names the command that computes them).
    """
    if facade.cushion_map == 'structural_per_panel':
        cushion_map = panels_structural_map(facade, facade_structural_panels(facade),
                                            trace=False)
    else:
        cushion_map = median_structural_map(facade, len(facade), trace=False)
    pressure, volume, _, row = cushion_map.tables()
    pressure, volume = pressure[row], volume[row]
    closed = (ATMOSPHERIC_PRESSURE_PA + pressure[:, -1]) * (volume[:, -1] + dead_volume_m3)
    opened = ATMOSPHERIC_PRESSURE_PA * (volume[:, 0] + dead_volume_m3)
    return (closed - opened) / ATMOSPHERIC_PRESSURE_PA * 1e3
