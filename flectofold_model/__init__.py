"""Kinematic and physical model of Flectofold panels: pure numpy/scipy, no ROS.

Modules: :mod:`~flectofold_model.panel` (validated panel descriptions),
:mod:`~flectofold_model.elastica` (the mid-rib), :mod:`~flectofold_model.reflection` (fold
planes and fold angles), :mod:`~flectofold_model.closure` (closure <-> fold angle <->
displacement) and :mod:`~flectofold_model.mesh` (folded triangle meshes).
"""

from flectofold_model.closure import FoldModel, FoldState
from flectofold_model.mesh import DEFAULT_TOPOLOGY, fold_mesh, FoldMesh, MeshTopology
from flectofold_model.panel import DEMONSTRATOR_MODULE, PanelBatch, PanelGeometry, PROTOTYPE

__all__ = [
    'DEFAULT_TOPOLOGY', 'DEMONSTRATOR_MODULE', 'FoldMesh', 'FoldModel', 'FoldState',
    'MeshTopology', 'PROTOTYPE', 'PanelBatch', 'PanelGeometry', 'fold_mesh',
]
