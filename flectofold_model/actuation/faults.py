"""Faults injected into N cushion circuits: leaks, a fill valve jammed open, a lost supply.

The sensor faults (stuck, dropout) live with the sensors (:mod:`.sensors`); these are the
faults of the air path, which change what the plant integrates.
"""

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import BoolArray, FloatArray, panel_mask, real_scalar
from flectofold_model.actuation.circuit import PlantParameters
from flectofold_model.actuation.flow import ATMOSPHERIC_PRESSURE_PA


class CircuitFaults:
    """The air-path state of ``count`` circuits that faults change; healthy at construction."""

    # set by clear
    fill_stuck_open: BoolArray
    leak_conductance: FloatArray
    supply_pa: FloatArray

    def __init__(self, parameters: PlantParameters, count: int) -> None:
        self._parameters = parameters
        self._count = count
        self.clear()

    def clear(self) -> None:
        """Remove every injected fault of the air path."""
        self.fill_stuck_open = np.zeros(self._count, dtype=bool)
        """Fill valves jammed wide open, whatever they are commanded (N,)."""
        self.leak_conductance = np.full(self._count, self._parameters.leak_conductance_m3_s_pa)
        """Conductance of each circuit's leak to atmosphere, healthy plus injected (N,)."""
        self.supply_pa = np.full(self._count, self._parameters.supply_pressure_pa)
        """Absolute supply pressure upstream of each fill valve, atmospheric where lost (N,)."""

    def inject_leak(self, panels: npt.ArrayLike, conductance_m3_s_pa: float) -> None:
        """Add a leak to atmosphere of ``conductance_m3_s_pa`` [m^3/(s*Pa)] to ``panels``."""
        conductance = real_scalar('conductance_m3_s_pa', conductance_m3_s_pa)
        if conductance < 0.0:
            raise ValueError(
                f'conductance_m3_s_pa must not be negative, got {conductance:g} m^3/(s*Pa)')
        self.leak_conductance = np.where(panel_mask(panels, self._count),
                                         self.leak_conductance + conductance,
                                         self.leak_conductance)

    def inject_fill_valve_stuck_open(self, panels: npt.ArrayLike) -> None:
        """Jam the fill valve of ``panels`` wide open."""
        self.fill_stuck_open = self.fill_stuck_open | panel_mask(panels, self._count)

    def inject_supply_loss(self, panels: npt.ArrayLike) -> None:
        """Drop the supply of ``panels`` to atmospheric: an open fill valve then vents."""
        self.supply_pa = np.where(panel_mask(panels, self._count), ATMOSPHERIC_PRESSURE_PA,
                                  self.supply_pa)
