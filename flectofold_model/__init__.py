"""Kinematic and physical model of Flectofold panels and facades: pure numpy/scipy, no ROS.

Vectorised over many panels, in sub-packages by concept:

================  ===============================================================================
``kinematics``    quad and hexagonal panels, the bent centre, reflected flaps, closure, meshes
``actuation``     laminates and cushion, pressure <-> closure, the pneumatic plant
``control``       the pressure loop, setpoint guard, valve interface, the loops nodes share
``facade``        facade descriptions (YAML), surfaces and their tessellation
``environment``   the sun (NREL SPA) and a simulated clock
``shading``       direct-sun shading and view by ray casting, and its tables
``scheduling``    the scheduler, a facade's schedule and the day report
================  ===============================================================================

The names below are the kinematic core; each sub-package's ``__init__`` names its own.
"""

from flectofold_model.kinematics import (batch_of, DEFAULT_TOPOLOGY, DEMONSTRATOR_MODULE,
                                         fold_mesh, fold_model_of, FoldMesh, FoldModel, FoldState,
                                         HEXAGON_MODULE, HexagonBatch, HexagonFoldModel,
                                         HexagonPanel, MeshTopology, panel_kind, PanelBatch,
                                         PanelGeometry, PROTOTYPE)

__all__ = [
    'DEFAULT_TOPOLOGY', 'DEMONSTRATOR_MODULE', 'FoldMesh', 'FoldModel', 'FoldState',
    'HEXAGON_MODULE', 'HexagonBatch', 'HexagonFoldModel', 'HexagonPanel', 'MeshTopology',
    'PROTOTYPE', 'PanelBatch', 'PanelGeometry', 'batch_of', 'fold_mesh', 'fold_model_of',
    'panel_kind',
]
