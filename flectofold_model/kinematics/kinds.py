"""The two panel kinds behind one interface: quad panels and hexagonal panels.

Both fold models offer ``batch``, ``open_fold_angle_rad``, ``closed_fold_angle_rad``,
``open_shape``, ``closed_shape``, ``state_from_closure`` (a state with ``closure``,
``apex_fold_angle_rad`` and ``shape_parameter``), ``state_from_shape``,
``shape_from_fold_angle`` and ``mesh(shape, topology)``. The shape parameter is the one number
that fixes a panel's shape: the mid-rib's elastica modulus for a quad panel, the centre rise
[m] for a hexagonal one. Code that only needs those works for both kinds.
"""

from typing import Any, Callable, Iterable, Union

from flectofold_model.kinematics.closure import FoldModel
from flectofold_model.kinematics.hexagon_closure import HexagonFoldModel
from flectofold_model.kinematics.hexagon_mesh import HexagonTopology
from flectofold_model.kinematics.hexagon_panel import HexagonBatch, HexagonPanel
from flectofold_model.kinematics.mesh import MeshTopology
from flectofold_model.kinematics.panel import PanelBatch, PanelGeometry

#: A panel of either kind, a batch of either kind, and the fold model of either kind.
Panel = Union[PanelGeometry, HexagonPanel]
Batch = Union[PanelBatch, HexagonBatch]
AnyFoldModel = Union[FoldModel, HexagonFoldModel]

#: Panel kind name -> (panel class, batch class, fold model class).
KINDS: dict[str, tuple[type[Panel], type[Batch], Callable[[Any], AnyFoldModel]]] = {
    'quad': (PanelGeometry, PanelBatch, FoldModel),
    'hexagon': (HexagonPanel, HexagonBatch, HexagonFoldModel),
}


def panel_kind(panel: object) -> str:
    """``'quad'`` or ``'hexagon'`` for a panel or a batch; ``TypeError`` for anything else."""
    for name, (panel_class, batch_class, _) in KINDS.items():
        if isinstance(panel, (panel_class, batch_class)):
            return name
    raise TypeError(f'{type(panel).__name__} is not a panel of a known kind '
                    f'({", ".join(KINDS)})')


def batch_of(panels: Iterable[Panel]) -> Batch:
    """Stack panels of one kind into that kind's batch; mixed kinds raise ``ValueError``."""
    panels = list(panels)
    if not panels:
        raise ValueError('a panel batch needs at least one panel')
    kinds = {panel_kind(panel) for panel in panels}
    if len(kinds) > 1:
        raise ValueError(f'panels of different kinds ({", ".join(sorted(kinds))}) cannot share '
                         f'one batch; split them by kind')
    return KINDS[kinds.pop()][1].from_panels(panels)


def fold_model_of(panels: Union[Batch, Iterable[Panel]]) -> AnyFoldModel:
    """Build the fold model of a batch, or of an iterable of panels of one kind."""
    if isinstance(panels, (PanelBatch, HexagonBatch)):
        batch = panels
    else:
        batch = batch_of(panels)
    return KINDS[panel_kind(batch)][2](batch)


def is_topology_for(batch: object, topology: object) -> bool:
    """Whether ``topology`` fits the kind of ``batch``."""
    wanted = HexagonTopology if isinstance(batch, HexagonBatch) else MeshTopology
    return isinstance(topology, wanted)
