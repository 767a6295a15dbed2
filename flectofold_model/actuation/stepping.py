"""How long the sub-steps of the pneumatic plant's integration may be.

A stepper's :meth:`longest_s` is asked once per :meth:`~.plant.PneumaticPlant.step` (the
valve openings are constant over a call) for the longest sub-step of the coming interval.

:class:`FixedSubstep` gives ``max_step_s`` always: the reference integration.

:class:`AdaptiveSubstep` (``PneumaticPlant(..., integrator='adaptive')``) scales the sub-step
with the conductance that is active. Each call of :meth:`~.plant.PneumaticPlant.step` takes
one sub-step for all panels,

``h = clip(max_step_s / a, max_step_s, min(max_quiet_step_s, dt_s))``, with
``a = max over panels of (u_fill + u_vent + (C_leak + C_relief) / C_ref)``,

the active conductance of each valve over its full-open conductance: ``u`` are the
openings (a fill valve stuck open counts as 1), ``C_ref`` is the larger full-open
conductance of the two valves, the leak includes injected leaks and the relief valve
counts in full only where it is within reach (below). The right-hand side is a sum of
terms linear in their conductances, ``dp/dt = sum_i C_i f_i(p)``, so with one valve
active RK4 with step ``h`` on ``u C f(p)`` computes exactly the pressures it computes with
step ``u h`` on ``C f(p)``: a valve at opening ``u`` stepped ``1/u`` times longer follows
the fixed plant's wide-open trajectory point for point, only slower, with its stability
and its error per pascal travelled. That is why the square-root singularity of the ISO
6358 flow at zero pressure difference needs no guard of its own at tiny openings: its
stiffness ``C |df/dp|`` diverges at the same pressures at every opening, and the scaled
step meets it with the same ``h C`` as the fixed plant meets the wide-open valve
(scaling with ``sqrt(u)`` would shorten quiet steps for nothing). Each valve is
normalised by its own conductance so that a wide-open valve runs exactly the fixed
integration; normalising by ``C_ref`` alone would step the demonstrator's fill valve
(1.0 against a 2.5 dm^3/(s*bar) vent) 2.5 times longer than the fixed plant and triple
its error on a full fill. Where the scaling is not exact, guards:

* *compliance ramps*: the time stretch makes a barely open valve cross a ramp of the
  cushion map the way the fixed plant crosses it wide open, in one or two long sub-steps.
  The demonstrator's :class:`~flectofold_model.actuation.cushion_map.CushionMap` has a capacitance
  of 1.3 L at the open stop and over 100 L 10 Pa above it, so a single 0.1 s sub-step
  of a fill at 0.1 % opening overshoots there by about 2 Pa, where the fixed plant is
  exact to 1e-4 Pa. The sub-step is therefore shortened (not below
  ``max_step_s``) until the pressure the present rate would reach in one sub-step changes
  the capacitance by at most a quarter. This is a prediction from the rate at the start
  (the rate may grow along the step, as toward the closed stop), but it costs one
  cushion-map evaluation per trial and nothing where the capacitance is smooth;
* *the relief valve*, whose conductance depends on the pressure: it counts in full for a
  panel at or above its cracking pressure less the largest rise that its fill valve,
  choked from the supply into the present cushion plus dead volume, could make within
  ``dt_s`` (the cushion map's volume must not shrink as the pressure rises);
* *several valves at once* add up; the step is never shorter than ``max_step_s`` (the
  adaptive plant never takes more sub-steps than the fixed one, and a wide-open or stuck
  valve runs the fixed integration bit for bit) nor longer than ``max_quiet_step_s`` or
  ``dt_s``, which caps what the healthy leak alone does in one sub-step.

The openings are constant over a call, so the sub-step is chosen once per call. The most
active panel sets it for all: the adaptive plant only saves work while every panel's
valves are shut or barely open.
"""

import math
from typing import Optional, Protocol

import numpy as np

from flectofold_model._validate import BoolArray, FloatArray, FloatOrArray
from flectofold_model.actuation.circuit import PlantParameters
from flectofold_model.actuation.faults import CircuitFaults
from flectofold_model.actuation.flow import (AIR_GAS_CONSTANT, ANR_DENSITY_KG_M3,
                                             ANR_TEMPERATURE_K, ATMOSPHERIC_PRESSURE_PA)

#: ``dp/dt`` [Pa/s], fill inflow and vent outflow as free air [m^3/s], each (N,).
Rates = tuple[FloatArray, FloatArray, FloatArray]


class SteppedPlant(Protocol):
    """What a stepper reads of the plant it steps (:class:`~.plant.PneumaticPlant`)."""

    @property
    def parameters(self) -> PlantParameters:
        """The circuit's parameters."""

    @property
    def count(self) -> int:
        """Number of panels N."""

    @property
    def absolute_pressure_pa(self) -> FloatArray:
        """Cushion pressure (N,) [Pa, absolute]."""

    faults: CircuitFaults

    def cushion(self, pressure_pa: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Volume [m^3] and compliance [m^3/Pa] (N,) at absolute pressures."""

    def capacitance_m3(self, pressure_pa: FloatArray,
                       cushion: Optional[tuple[FloatArray, FloatArray]] = None) -> FloatArray:
        """Capacitance ``V + p dV/dp`` (N,) [m^3]."""

    def rates(self, pressure_pa: FloatArray, fill_conductance: FloatOrArray,
              vent_conductance: FloatOrArray, capacitance: Optional[FloatArray] = None) -> Rates:
        """:data:`Rates` at absolute pressures."""


#: Largest relative change of the chamber capacitance over one adaptive sub-step, predicted
#: from the rate at its start; resolves the compliance ramps of a cushion map.
CAPACITANCE_CHANGE = 0.25
#: Trials of the capacitance guard per call before it settles for what it has.
CAPACITANCE_TRIALS = 4


class FixedSubstep:
    """Sub-steps of ``max_step_s``, whatever the valves do: the reference integration."""

    def longest_s(self, plant: SteppedPlant, dt_s: float, fill_conductance: FloatArray,
                  vent_conductance: FloatArray) -> tuple[float, None]:
        """Return ``(max_step_s, None)``: no rates evaluated."""
        return plant.parameters.max_step_s, None


class AdaptiveSubstep:
    """Sub-steps scaled with the active conductance; see the module notes."""

    def longest_s(self, plant: SteppedPlant, dt_s: float, fill_conductance: FloatArray,
                  vent_conductance: FloatArray) -> tuple[float, Optional[Rates]]:
        """Longest sub-step for the coming ``dt_s`` [s], and the rates if they were needed.

        The conductance rule, clipped to ``[max_step_s, min(max_quiet_step_s, dt_s)]``, then
        shortened (not below ``max_step_s``) while the pressure one sub-step at the present
        rate would reach changes the chamber's capacitance by more than
        :data:`CAPACITANCE_CHANGE` of itself. The rates at the present pressure, if that
        needed them, come back as well (else None): they are the first stage of the first
        sub-step.
        """
        parameters = plant.parameters
        shortest = parameters.max_step_s
        pressure = plant.absolute_pressure_pa
        volume, compliance = plant.cushion(pressure)
        capacitance = plant.capacitance_m3(pressure, (volume, compliance))
        exhaust = plant.faults.leak_conductance
        if parameters.relief_conductance_m3_s_pa > 0.0:
            reach = _relief_within_reach(plant, pressure, dt_s, fill_conductance, volume)
            exhaust = exhaust + np.where(reach, parameters.relief_conductance_m3_s_pa, 0.0)
        reference = max(parameters.fill_conductance_m3_s_pa,
                        parameters.vent_conductance_m3_s_pa)
        active = (fill_conductance / parameters.fill_conductance_m3_s_pa
                  + vent_conductance / parameters.vent_conductance_m3_s_pa
                  + exhaust / reference)
        largest = float(np.max(active))
        step_s = min(parameters.max_quiet_step_s, dt_s)
        if largest * step_s > shortest:
            step_s = max(shortest, shortest / largest)
        if step_s <= shortest:
            return step_s, None
        rates = plant.rates(pressure, fill_conductance, vent_conductance, capacitance)
        rate = rates[0]
        for _ in range(CAPACITANCE_TRIALS):
            reached = np.maximum(pressure + step_s * rate, ATMOSPHERIC_PRESSURE_PA)
            volume, compliance = plant.cushion(reached)
            there = volume + parameters.dead_volume_m3 + reached * compliance
            with np.errstate(divide='ignore'):
                change = float(np.max(np.abs(there - capacitance)
                                      / np.minimum(there, capacitance)))
            if change <= CAPACITANCE_CHANGE:
                break
            step_s = max(shortest, step_s * CAPACITANCE_CHANGE / change)
            if step_s == shortest:
                break
        return step_s, rates


def _relief_within_reach(plant: SteppedPlant, pressure: FloatArray, dt_s: float,
                         fill_conductance: FloatArray, volume: FloatArray) -> BoolArray:
    """Panels whose relief valve may be open at some time of the coming ``dt_s``.

    Those at or above the cracking pressure less the largest rise their fill valve could
    make in ``dt_s``: choked flow from the supply (or from the cushion, if higher) into the
    present cushion ``volume`` plus the dead volume. The volume only grows as the pressure
    rises, and every other flow takes air out, so the true rise is smaller.
    """
    parameters = plant.parameters
    room = volume + parameters.dead_volume_m3
    inflow = (fill_conductance * np.maximum(plant.faults.supply_pa, pressure) * ANR_DENSITY_KG_M3
              * math.sqrt(ANR_TEMPERATURE_K / parameters.temperature_k))
    rise = np.full(plant.count, np.inf)
    np.divide(AIR_GAS_CONSTANT * parameters.temperature_k * inflow * dt_s, room, out=rise,
              where=room > 0.0)
    rise = np.where(fill_conductance > 0.0, rise, 0.0)
    gauge = pressure - ATMOSPHERIC_PRESSURE_PA
    return gauge + rise >= parameters.relief_cracking_pa
