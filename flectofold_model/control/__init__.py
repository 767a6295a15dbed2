"""Control of the panels: the pressure loop, setpoint guard, valve interface and shared loops.

- :mod:`.pressure_loop`: closure setpoint -> valve openings, with fault detection
  (:class:`PressureController`);
- :mod:`.setpoint_guard`: setpoint validation and the watchdog (:class:`SetpointGuards`);
- :mod:`.hardware`: the valve/sensor interface the loop drives (:class:`CushionDriver`) and its
  simulation;
- :mod:`.regulator`: pressure setpoints for channels that a proportional pressure regulator
  drives (:class:`RegulatorSetpoints`);
- :mod:`.panel_loops`: the loops of the panels one process hosts (:class:`PanelLoops`);
- :mod:`.loop_kernel`, :mod:`.simulation_kernel`: the compiled loop (its one implementation)
  and the compiled simulation of many periods of loops and plant;
- :mod:`.decimation`: which states to publish (:class:`PublishDecimator`);
- :mod:`.loop_simulation`: a closed loop against the plant, and step metrics.
"""

from flectofold_model.control.decimation import PublishDecimator
from flectofold_model.control.hardware import CushionDriver, SimulatedCushions
from flectofold_model.control.loop_simulation import LoopTrace, simulate, step_metrics, StepMetrics
from flectofold_model.control.panel_loops import (compile_kernels, facade_loops, LoopAdvance,
                                                  panel_indices, PanelLoops)
from flectofold_model.control.pressure_loop import (ControllerParameters, Fault,
                                                    PressureController, SafeAction, ValveCommand)
from flectofold_model.control.regulator import RegulatorSetpoints
from flectofold_model.control.setpoint_guard import (
    SafeBehaviour, SetpointGuard, SetpointGuards, SetpointState)

__all__ = [
    'ControllerParameters', 'CushionDriver', 'Fault', 'LoopAdvance', 'LoopTrace', 'PanelLoops',
    'PressureController', 'PublishDecimator', 'RegulatorSetpoints', 'SafeAction', 'SafeBehaviour',
    'SetpointGuard', 'SetpointGuards', 'SetpointState', 'SimulatedCushions', 'StepMetrics',
    'ValveCommand',
    'compile_kernels', 'facade_loops', 'panel_indices', 'simulate', 'step_metrics',
]
