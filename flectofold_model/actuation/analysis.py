"""What a circuit can do, found by simulating or solving it: fill times and holding pressure."""

import math

from scipy.optimize import brentq

from flectofold_model._validate import real_scalar
from flectofold_model.actuation.circuit import PlantParameters
from flectofold_model.actuation.flow import ATMOSPHERIC_PRESSURE_PA, mass_flow
from flectofold_model.actuation.plant import CushionMapFunction, PneumaticPlant


def physical_fill_time_s(parameters: PlantParameters, cushion_map: CushionMapFunction,
                         target_gauge_pa: float, start_gauge_pa: float = 0.0,
                         dt_s: float = 1e-3, limit_s: float = 600.0) -> float:
    """Time for one cushion to fill from ``start_gauge_pa`` to ``target_gauge_pa`` [s].

    Simulates a single :class:`PneumaticPlant` with the fill valve fully open and the vent
    closed, and returns the first time the true gauge pressure reaches the target, linearly
    interpolated within the ``dt_s`` sample where it crosses.

    Parameters
    ----------
    parameters : PlantParameters
        The circuit.
    cushion_map : callable
        The cushion map; see :class:`PneumaticPlant`.
    target_gauge_pa : float
        Gauge pressure to reach [Pa]; above ``start_gauge_pa`` and below the pressure at
        which the supply balances the leak and the relief valve.
    start_gauge_pa : float, default 0.0
        Initial gauge pressure [Pa], ``>= 0``.
    dt_s : float, default 1e-3
        Sampling interval of the crossing search [s]; the integration itself uses sub-steps
        no longer than ``parameters.max_step_s``.
    limit_s : float, default 600.0
        Longest time simulated before giving up [s].

    Returns
    -------
    float
        Fill time [s].

    Raises
    ------
    ValueError
        If the target cannot be reached from the supply, or is not reached within
        ``limit_s``.
    """
    if not isinstance(parameters, PlantParameters):
        raise TypeError(f'parameters must be a PlantParameters, got {type(parameters).__name__}')
    target = real_scalar('target_gauge_pa', target_gauge_pa)
    start = real_scalar('start_gauge_pa', start_gauge_pa)
    dt_s = real_scalar('dt_s', dt_s)
    limit_s = real_scalar('limit_s', limit_s)
    for name, value in (('dt_s', dt_s), ('limit_s', limit_s)):
        if value <= 0.0:
            raise ValueError(f'{name} must be positive, got {value:g} s')
    if start < 0.0:
        raise ValueError(f'start_gauge_pa must not be negative, got {start:g} Pa')
    if target <= start:
        raise ValueError(
            f'target_gauge_pa={target:g} Pa must be above start_gauge_pa={start:g} Pa')
    reachable = holding_gauge_pa(parameters)
    if target >= reachable:
        raise ValueError(
            f'target_gauge_pa={target:g} Pa is at or above the {reachable:.6g} Pa gauge that the '
            f'supply of {parameters.supply_pressure_pa:g} Pa can hold against the leak and the '
            f'relief valve: it cannot be reached')
    plant = PneumaticPlant(parameters, cushion_map, 1, initial_gauge_pa=start)
    previous = start
    for index in range(math.ceil(limit_s / dt_s)):
        plant.step(dt_s, 1.0, 0.0)
        current = float(plant.gauge_pressure_pa[0])
        if current >= target:
            return (index + (target - previous) / (current - previous)) * dt_s
        previous = current
    raise ValueError(
        f'target_gauge_pa={target:g} Pa was not reached within limit_s={limit_s:g} s '
        f'(the cushion got to {previous:.6g} Pa)')


def holding_gauge_pa(parameters: PlantParameters) -> float:
    """Gauge pressure at which the open fill valve balances the leak and the relief [Pa].

    The highest pressure a cushion reaches with the fill valve held open and the vent closed:
    the supply gauge pressure when nothing leaks and the relief valve cracks above it.
    """
    if not isinstance(parameters, PlantParameters):
        raise TypeError(f'parameters must be a PlantParameters, got {type(parameters).__name__}')
    b = parameters.critical_ratio
    temperature_k = parameters.temperature_k
    supply = parameters.supply_pressure_pa
    span = parameters.relief_full_open_pa - parameters.relief_cracking_pa

    def net_mass_flow(pressure_pa: float) -> float:
        opening = min(max((pressure_pa - ATMOSPHERIC_PRESSURE_PA
                           - parameters.relief_cracking_pa) / span, 0.0), 1.0)
        exhaust = (parameters.leak_conductance_m3_s_pa
                   + opening * parameters.relief_conductance_m3_s_pa)
        return float(
            mass_flow(supply, pressure_pa, parameters.fill_conductance_m3_s_pa, b, temperature_k)
            - mass_flow(pressure_pa, ATMOSPHERIC_PRESSURE_PA, exhaust, b, temperature_k))

    if net_mass_flow(supply) >= 0.0:
        return supply - ATMOSPHERIC_PRESSURE_PA
    balance = brentq(net_mass_flow, ATMOSPHERIC_PRESSURE_PA, supply, xtol=1e-9, rtol=1e-15)
    return balance - ATMOSPHERIC_PRESSURE_PA
