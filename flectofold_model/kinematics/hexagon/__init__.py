"""Hexagonal Flectofold panels: three curved fold lines around a triangle (Koerner et al. 2018).

- :mod:`.panel`: validated hexagonal panels, one or a batch, and the module preset;
- :mod:`.fold_lines`: the drawn fold lines as quadratic B-splines;
- :mod:`.cone`: the actuated central part, a developable cone over the raised centre point;
- :mod:`.reflection`: fold planes, crease, fold angles and flap tips (the reflection method);
- :mod:`.closure`: closure <-> apex fold angle <-> centre rise;
- :mod:`.mesh`: folded triangle meshes of many panels at once.
"""

from flectofold_model.kinematics.hexagon.closure import HexagonFoldModel, HexagonFoldState
from flectofold_model.kinematics.hexagon.mesh import (DEFAULT_HEXAGON_TOPOLOGY, hexagon_mesh,
                                                      HexagonTopology)
from flectofold_model.kinematics.hexagon.panel import HEXAGON_MODULE, HexagonBatch, HexagonPanel

__all__ = [
    'DEFAULT_HEXAGON_TOPOLOGY', 'HEXAGON_MODULE', 'HexagonBatch', 'HexagonFoldModel',
    'HexagonFoldState', 'HexagonPanel', 'HexagonTopology', 'hexagon_mesh',
]
