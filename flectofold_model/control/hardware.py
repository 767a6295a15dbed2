"""The valve/sensor interface a panel's pressure loop drives, and its simulated implementation.

A :class:`CushionDriver` is a valve island: ``N`` cushion channels, each with a fill valve, a
vent valve, a cushion pressure sensor and a supply pressure sensor. The pressure loop only
reads sensors and writes valve openings through it, so a driver for real hardware (a fieldbus
valve terminal, say) replaces :class:`SimulatedCushions` without touching the loop or the ROS
nodes. A driver may have a proportional pressure regulator on some channels in place of the
two valves (:attr:`CushionDriver.regulated`): the loop then gives those a pressure setpoint
(:meth:`CushionDriver.write_outputs`). A real driver's time passes by itself; a simulated
one is advanced by the loop in fixed control periods (:attr:`CushionDriver.simulated`), which
keeps the simulation exact whatever the ROS clock does.
"""

import abc

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import BoolArray, FloatArray, in_range, real_array
from flectofold_model.actuation import PlantParameters, PneumaticPlant


class CushionDriver(abc.ABC):
    """Sensors and valves of ``count`` cushion circuits."""

    simulated = False
    """True for a driver whose time only passes in :meth:`advance` (a simulation)."""

    @property
    def comms_lost(self) -> bool:
        """Whether the last exchange with the valves failed (a fieldbus driver).

        While True the readings are NaN and :meth:`write_valves` writes nothing: the loop
        latches :attr:`~.pressure_loop.Fault.COMMS_LOST` on every channel. A driver with no
        link to lose (a simulation) is never lost.
        """
        return False

    @property
    @abc.abstractmethod
    def count(self) -> int:
        """Number of channels ``N``."""

    @property
    @abc.abstractmethod
    def circuit(self) -> PlantParameters:
        """Valves and tubing as :class:`~.pneumatics.PlantParameters`, for the loop's model."""

    @abc.abstractmethod
    def read_pressure_pa(self) -> FloatArray:
        """Absolute cushion pressures (N,) [Pa]; NaN where a sensor gives no reading."""

    @abc.abstractmethod
    def read_supply_pa(self) -> FloatArray:
        """Absolute supply pressures (N,) [Pa]; NaN where a sensor gives no reading."""

    @abc.abstractmethod
    def write_valves(self, fill_opening: npt.ArrayLike, vent_opening: npt.ArrayLike) -> None:
        """Set the fill and vent valve openings (N,), each in [0, 1]."""

    @property
    def regulated(self) -> BoolArray:
        """Which channels (N,) a proportional pressure regulator drives; none by default.

        A regulated channel has no fill and vent valves of its own to command: its regulator,
        fed from the supply and exhausting to the atmosphere, holds the gauge pressure it is
        set to with its own loop. :class:`~.panel_loops.PanelLoops` sets it through
        :meth:`write_outputs`.
        """
        return np.zeros(self.count, dtype=bool)

    def write_outputs(self, fill_opening: npt.ArrayLike, vent_opening: npt.ArrayLike,
                      regulator_gauge_pa: npt.ArrayLike) -> None:
        """Set valve openings and regulator setpoints (N,) together, as one write.

        For drivers with :attr:`regulated` channels, which take ``regulator_gauge_pa``
        [Pa gauge, >= 0] there and the openings elsewhere; the loop calls it in place of
        :meth:`write_valves`.
        """
        raise NotImplementedError(f'{type(self).__name__} has no pressure regulators')

    def advance(self, dt_s: float) -> None:
        """Let ``dt_s`` seconds pass (simulated drivers only)."""
        raise NotImplementedError(f'{type(self).__name__} runs in real time')

    def close(self) -> None:
        """Shut every valve: what a driver does when its owner stops."""
        self.write_valves(np.zeros(self.count), np.zeros(self.count))


class SimulatedCushions(CushionDriver):
    """:class:`CushionDriver` over a :class:`~flectofold_model.actuation.plant.PneumaticPlant`.

    The valves hold their last written openings while :meth:`advance` integrates the plant.
    """

    simulated = True

    def __init__(self, plant: PneumaticPlant) -> None:
        if not isinstance(plant, PneumaticPlant):
            raise TypeError(f'plant must be a PneumaticPlant, got {type(plant).__name__}')
        self.plant = plant
        self._fill = np.zeros(plant.count)
        self._vent = np.zeros(plant.count)

    @property
    def count(self) -> int:
        return self.plant.count

    @property
    def circuit(self) -> PlantParameters:
        return self.plant.parameters

    def read_pressure_pa(self) -> FloatArray:
        return self.plant.read_sensor()

    def read_supply_pa(self) -> FloatArray:
        return self.plant.read_supply_sensor()

    def write_valves(self, fill_opening: npt.ArrayLike, vent_opening: npt.ArrayLike) -> None:
        fill = openings('fill_opening', fill_opening, self.count)
        vent = openings('vent_opening', vent_opening, self.count)
        self._fill, self._vent = fill, vent

    def advance(self, dt_s: float) -> None:
        self.plant.step(dt_s, self._fill, self._vent)

    def valve_openings(self, copy: bool = True) -> tuple[FloatArray, FloatArray]:
        """Return the fill and vent openings (N,) in force.

        ``copy=False``: the live arrays, which a compiled simulation that writes the valves
        itself updates in place.
        """
        return (self._fill.copy(), self._vent.copy()) if copy else (self._fill, self._vent)

    @property
    def free_air_used_m3(self) -> FloatArray:
        """Air each channel drew from the supply, at ANR conditions (N,) [m^3]."""
        return self.plant.free_air_used_m3


def openings(name: str, value: npt.ArrayLike, count: int) -> FloatArray:
    array = np.broadcast_to(real_array(name, value), (count,)).astype(np.float64)
    return in_range(name, array, 0.0, 1.0)
