"""Kinematic and physical model of Flectofold panels and facades: pure numpy/scipy, no ROS.

Vectorised over many panels, in sub-packages by concept:

================  ===============================================================================
``kinematics``    the panel, its mid-rib elastica, the reflected flaps, closure, folded meshes
``actuation``     laminates and cushion, pressure <-> closure, the pneumatic plant
``control``       the pressure loop, setpoint guard, valve interface, the loops nodes share
``facade``        facade descriptions (YAML), surfaces and their tessellation
``environment``   the sun (NREL SPA) and a simulated clock
``shading``       direct-sun shading and view by ray casting, and its tables
``scheduling``    the scheduler, a facade's schedule and the day report
================  ===============================================================================

The names below are the kinematic core; each sub-package's ``__init__`` names its own.
"""

from flectofold_model.kinematics import (DEFAULT_TOPOLOGY, DEMONSTRATOR_MODULE, fold_mesh,
                                         FoldMesh, FoldModel, FoldState, MeshTopology, PanelBatch,
                                         PanelGeometry, PROTOTYPE)

__all__ = [
    'DEFAULT_TOPOLOGY', 'DEMONSTRATOR_MODULE', 'FoldMesh', 'FoldModel', 'FoldState',
    'MeshTopology', 'PROTOTYPE', 'PanelBatch', 'PanelGeometry', 'fold_mesh',
]
