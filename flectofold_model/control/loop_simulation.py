"""Closed-loop simulation of pressure controllers against the pneumatic plant, and step metrics.

The controller runs at a fixed control period, as it would on hardware: it reads the sensors,
computes valve openings, and the plant then integrates over one period with those openings.
"""

from dataclasses import dataclass
from typing import Any, Callable, Iterable, Union

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import real_scalar
from flectofold_model.actuation import ATMOSPHERIC_PRESSURE_PA, PneumaticPlant
from flectofold_model.control.pressure_loop import PressureController

#: A closure setpoint (scalar or (N,)), or a function of the time [s] that returns one.
Setpoint = Union[npt.ArrayLike, Callable[[float], npt.ArrayLike]]
#: A fault injected at a time [s]: the function is called with the plant and the controller.
Event = tuple[float, Callable[[PneumaticPlant, PressureController], object]]


@dataclass(frozen=True)
class LoopTrace:
    """Time series of a closed-loop run; every array but ``time_s`` has shape (T, N)."""

    time_s: np.ndarray
    setpoint: np.ndarray
    target_gauge_pa: np.ndarray
    reference_gauge_pa: np.ndarray
    gauge_pa: np.ndarray
    """True cushion pressure [Pa gauge]."""
    measured_gauge_pa: np.ndarray
    fill_opening: np.ndarray
    vent_opening: np.ndarray
    closure: np.ndarray
    """Closure the static map gives for the true pressure."""
    fault: np.ndarray
    """Fault value strings, see :class:`~flectofold_model.control.pressure_loop.Fault`."""


def simulate(controller: PressureController, plant: PneumaticPlant, setpoint: Setpoint,
             duration_s: float, control_period_s: float = 0.01,
             events: Iterable[Event] = ()) -> LoopTrace:
    """Run ``controller`` on ``plant`` for ``duration_s``.

    ``setpoint`` is a closure (scalar or (N,)) or a function of time returning one.
    ``events`` are ``(time_s, function)`` pairs; each function is called once with the plant
    and the controller when the simulation time first reaches its time (fault injection).
    """
    duration_s = real_scalar('duration_s', duration_s)
    period = real_scalar('control_period_s', control_period_s)
    if duration_s <= 0 or period <= 0:
        raise ValueError('duration_s and control_period_s must be positive')
    steps = int(round(duration_s / period))
    pending = sorted(events, key=lambda event: event[0])
    columns: dict[str, list[npt.NDArray[Any]]] = {
        name: [] for name in LoopTrace.__dataclass_fields__ if name != 'time_s'}
    times = []
    for step in range(steps + 1):
        now = step * period
        while pending and pending[0][0] <= now + 1e-12:
            pending.pop(0)[1](plant, controller)
        wanted = setpoint(now) if callable(setpoint) else setpoint
        measured = plant.read_sensor()
        command = controller.step(period, wanted, measured, plant.read_supply_sensor())
        gauge = plant.gauge_pressure_pa
        _record(columns, setpoint=np.broadcast_to(wanted, gauge.shape),
                target_gauge_pa=controller.target_gauge_pa,
                reference_gauge_pa=controller.reference_gauge_pa, gauge_pa=gauge,
                measured_gauge_pa=measured - ATMOSPHERIC_PRESSURE_PA,
                fill_opening=command.fill_opening, vent_opening=command.vent_opening,
                closure=controller.map.closure(gauge),
                fault=np.array([fault.value for fault in controller.fault]))
        times.append(now)
        if step < steps:
            plant.step(period, command.fill_opening, command.vent_opening)
    return LoopTrace(time_s=np.array(times),
                     **{name: np.array(values) for name, values in columns.items()})


def _record(columns: dict[str, list[npt.NDArray[Any]]], **values: npt.ArrayLike) -> None:
    for name, value in values.items():
        columns[name].append(np.array(value, copy=True))


@dataclass(frozen=True)
class StepMetrics:
    """Response of one panel to a step of its target, measured on the true pressure."""

    settling_time_s: float
    """Time after the step from which the pressure stays within the band of the target."""
    overshoot_fraction: float
    """Largest excursion beyond the target, as a fraction of the step."""
    steady_error_fraction: float
    """Mean absolute error over the last ``steady_window_s``, as a fraction of the step."""


def step_metrics(trace: LoopTrace, panel: int, step_time_s: float, band_fraction: float = 0.02,
                 steady_window_s: float = 5.0) -> StepMetrics:
    """Settling time, overshoot and steady error of ``panel`` for the step at ``step_time_s``."""
    after = trace.time_s >= step_time_s
    time = trace.time_s[after] - step_time_s
    pressure = trace.gauge_pa[after, panel]
    target = trace.target_gauge_pa[after, panel][-1]
    start = trace.gauge_pa[trace.time_s < step_time_s, panel]
    start = start[-1] if start.size else pressure[0]
    size = abs(target - start)
    if size == 0:
        raise ValueError('the target does not step')
    direction = np.sign(target - start)
    outside = np.abs(pressure - target) > band_fraction * size
    settled_from = np.flatnonzero(outside)[-1] + 1 if np.any(outside) else 0
    settling = time[settled_from] if settled_from < time.size else np.inf
    overshoot = max(0.0, float(np.max(direction * (pressure - target))) / size)
    steady = time >= time[-1] - steady_window_s
    error = float(np.mean(np.abs(pressure[steady] - target))) / size
    return StepMetrics(settling_time_s=float(settling), overshoot_fraction=overshoot,
                       steady_error_fraction=error)
