"""Kinematics of a Flectofold panel: its description, the mid-rib elastica, the reflected flaps.

- :mod:`.panel`: validated panel descriptions, one panel or a batch of many, and the presets;
- :mod:`.elastica`: the mid-rib as a pinned Euler elastica, in closed form;
- :mod:`.reflection`: fold planes, the crease and fold angles (the reflection method);
- :mod:`.closure`: closure <-> fold angle <-> elastica <-> support displacement;
- :mod:`.mesh`: folded triangle meshes of many panels at once;
- hexagonal panels with three fold lines around a triangle (Koerner et al. 2018), each part
  beside its quad counterpart with the prefix ``hexagon_``, as everywhere in the model:
  :mod:`.hexagon_panel` (validated panels, one or a batch, and the module preset),
  :mod:`.hexagon_fold_lines` (the drawn fold lines as quadratic B-splines),
  :mod:`.hexagon_cone` (the actuated central part, a developable cone over the raised centre
  point), :mod:`.hexagon_reflection` (fold planes, crease, fold angles and flap tips),
  :mod:`.hexagon_closure` (closure <-> apex fold angle <-> centre rise) and
  :mod:`.hexagon_mesh` (folded triangle meshes);
- :mod:`.kinds`: both panel kinds behind one interface.
"""

from flectofold_model.kinematics.closure import FoldModel, FoldState
from flectofold_model.kinematics.hexagon_closure import HexagonFoldModel
from flectofold_model.kinematics.hexagon_panel import HEXAGON_MODULE, HexagonBatch, HexagonPanel
from flectofold_model.kinematics.kinds import batch_of, fold_model_of, panel_kind
from flectofold_model.kinematics.mesh import DEFAULT_TOPOLOGY, fold_mesh, FoldMesh, MeshTopology
from flectofold_model.kinematics.panel import (DEMONSTRATOR_MODULE, PanelBatch, PanelGeometry,
                                               PROTOTYPE)

__all__ = [
    'DEFAULT_TOPOLOGY', 'DEMONSTRATOR_MODULE', 'FoldMesh', 'FoldModel', 'FoldState',
    'HEXAGON_MODULE', 'HexagonBatch', 'HexagonFoldModel', 'HexagonPanel', 'MeshTopology',
    'PROTOTYPE', 'PanelBatch', 'PanelGeometry', 'batch_of', 'fold_mesh', 'fold_model_of',
    'panel_kind',
]
