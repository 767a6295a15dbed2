"""Pressure setpoints for channels that a proportional pressure regulator drives.

A regulated channel (:attr:`~.hardware.CushionDriver.regulated`) has, in place of a fill and a
vent valve, a regulator that holds the gauge pressure it is set to with its own loop, fed from
the supply and exhausting to the atmosphere (a Festo VPPM-style valve). The panel's
:class:`~.pressure_loop.PressureController` still runs for it, for its target, its rate limit,
its feedback and its fault monitors; what reaches the regulator is its setpoint, which
:class:`RegulatorSetpoints` makes from the loop's state each period:

- **Tracking**: the loop's rate-limited reference
  (:attr:`~.pressure_loop.PressureController.reference_gauge_pa`), clipped to
  ``[0, max_gauge_pa]``: the regulator moves the cushion no faster than valves would be
  asked to, and never toward a target the supply or the maximum rules out.
- **Vent** (a latched fault whose safe action is vent, a fill valve stuck open, an
  over-pressure until a margin below the limit): 0 Pa, and the regulator exhausts the
  cushion. Wherever the loop would open the vent valve on a fault, the setpoint is 0.
- **Hold** (a latched fault whose safe action is hold): the setpoint stays at the last one
  sent before the fault, the pressure the cushion had, not the target the reference goes on
  toward. After a comms loss the terminal's own fail-safe may have exhausted the regulator
  meanwhile, so the held setpoint is lowered to the first pressure read once the link is
  back: as with valves held shut, the cushion is not refilled before ``reset_faults``.
- **No reading** (before the first one, or a dropout not yet latched): the setpoint stays
  where it was (0 before the first), as the loop shuts both valves then.

The loop's PI output is not applied on a regulated channel, so its integral is held at zero
there: it would wind up on the regulator's small lag and keep asking for air that the fault
monitors, comparing the pressure's course with the valve model, would then miss.
"""

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import BoolArray, FloatArray
from flectofold_model.actuation import ATMOSPHERIC_PRESSURE_PA
from flectofold_model.control.pressure_loop import Fault, PressureController, ValveCommand

_NO_FAULT = list(Fault).index(Fault.NONE)
_COMMS_LOST = list(Fault).index(Fault.COMMS_LOST)


class RegulatorSetpoints:
    """The regulator setpoints [Pa gauge] of a :class:`PressureController`'s channels.

    Parameters
    ----------
    controller : PressureController
        The loops of every channel; the setpoints of all are made, the driver uses those of
        its regulated channels.
    regulated : array-like of bool
        Which channels (N,) a regulator drives: their loops' integrals are held at zero.
    """

    def __init__(self, controller: PressureController, regulated: npt.ArrayLike) -> None:
        if not isinstance(controller, PressureController):
            raise TypeError(f'controller must be a PressureController, got '
                            f'{type(controller).__name__}')
        regulated = np.asarray(regulated)
        if regulated.dtype != np.bool_ or regulated.shape != (len(controller),):
            raise ValueError(f'regulated must be a boolean mask of {len(controller)} '
                             f'channels, got {regulated!r}')
        self.controller = controller
        self.regulated = regulated.copy()
        count = len(controller)
        self.gauge_pa = np.zeros(count)
        """The setpoints of the last :meth:`update` (N,) [Pa gauge]."""
        self._held_gauge_pa = np.zeros(count)
        self._awaiting_reading = np.zeros(count, dtype=bool)

    def update(self, command: ValveCommand, measured_pa: npt.ArrayLike) -> FloatArray:
        """Return the setpoints (N,) [Pa gauge] after a loop step.

        ``command``: the :class:`~.pressure_loop.ValveCommand` that step returned;
        ``measured_pa``: the absolute readings (N,) it took, NaN where there were none.
        """
        controller = self.controller
        parameters = controller.parameters
        measured_pa = np.asarray(measured_pa, dtype=np.float64)
        readable = np.isfinite(measured_pa)
        fault = controller.fault_codes
        faulted = fault != _NO_FAULT
        self._lower_hold_after_comms_loss(fault == _COMMS_LOST, readable, measured_pa)
        setpoint = np.where(readable, np.clip(controller.reference_gauge_pa, 0.0,
                                              parameters.max_gauge_pa), self.gauge_pa)
        # On a fault the loop's vent opening is exactly 1 (vent, over-pressure included) or
        # 0 (hold). A reading past the over-pressure limit latches that fault at once.
        setpoint = np.where(faulted, np.where(command.vent_opening > 0.0, 0.0,
                                              self._held_gauge_pa), setpoint)
        self._held_gauge_pa = np.where(faulted, self._held_gauge_pa, setpoint)
        self.gauge_pa = setpoint
        controller.clear_integral(self.regulated)
        return setpoint.copy()

    def _lower_hold_after_comms_loss(self, lost: BoolArray, readable: BoolArray,
                                     measured_pa: FloatArray) -> None:
        """Hold no more than the pressure first read after a comms loss."""
        back = lost & readable & self._awaiting_reading
        self._held_gauge_pa[back] = np.minimum(
            self._held_gauge_pa[back],
            np.maximum(measured_pa[back] - ATMOSPHERIC_PRESSURE_PA, 0.0))
        self._awaiting_reading = lost & (self._awaiting_reading | ~readable) & ~back
