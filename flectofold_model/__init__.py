"""Kinematic and physical model of Flectofold panels: pure numpy/scipy, no ROS.

Modules: :mod:`~flectofold_model.panel` (validated panel descriptions),
:mod:`~flectofold_model.elastica` (the mid-rib), :mod:`~flectofold_model.reflection` (fold
planes and fold angles), :mod:`~flectofold_model.closure` (closure <-> fold angle <->
displacement) and :mod:`~flectofold_model.mesh` (folded triangle meshes); actuation in
:mod:`~flectofold_model.actuation` (pressure <-> closure), :mod:`~flectofold_model.pneumatics`
(the plant), :mod:`~flectofold_model.pressure_control` (the loop and its faults) and
:mod:`~flectofold_model.loop_simulation`; the facade in :mod:`~flectofold_model.facade`
(YAML descriptions) and :mod:`~flectofold_model.surfaces` (tessellation); the sun, shading and
schedule in :mod:`~flectofold_model.sun`, :mod:`~flectofold_model.shading`,
:mod:`~flectofold_model.shading_table`, :mod:`~flectofold_model.scheduler`,
:mod:`~flectofold_model.facade_schedule` (sun vector -> closures) and
:mod:`~flectofold_model.day_report`; what the ROS nodes run: :mod:`~flectofold_model.hardware`
(the valve/sensor interface and its simulation), :mod:`~flectofold_model.panel_loop` (the
panels' loops against a driver), :mod:`~flectofold_model.setpoint_guard` (setpoint validation
and watchdog) and :mod:`~flectofold_model.sim_clock` (a sped-up day).
"""

from flectofold_model.closure import FoldModel, FoldState
from flectofold_model.mesh import DEFAULT_TOPOLOGY, fold_mesh, FoldMesh, MeshTopology
from flectofold_model.panel import DEMONSTRATOR_MODULE, PanelBatch, PanelGeometry, PROTOTYPE

__all__ = [
    'DEFAULT_TOPOLOGY', 'DEMONSTRATOR_MODULE', 'FoldMesh', 'FoldModel', 'FoldState',
    'MeshTopology', 'PROTOTYPE', 'PanelBatch', 'PanelGeometry', 'fold_mesh',
]
