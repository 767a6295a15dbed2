"""Pneumatic plant of Flectofold cushions: N chambers integrated in continuous time.

Each panel's cushion is a chamber of absolute pressure ``p`` fed from a supply through a fill
valve and emptied to the atmosphere through a vent valve, a leak and a relief valve, each an
ISO 6358 valve (:mod:`.flow`) of the circuit (:mod:`.circuit`). The chamber is isothermal:
with air mass ``m`` and volume ``V(p)``, ``p V = m R T`` gives
``dp/dt = R T mdot_net / (V + p dV/dp)``. For a soft cushion the compliance ``dV/dp`` dominates
the air's own compressibility ``V / p``. The cushion's volume and compliance come from a
*cushion map*, a callable written elsewhere (:class:`~.cushion_map.CushionMap`)::

    cushion_map(gauge_pressure_pa) -> (volume_m3, compliance_m3_per_pa)

taking and returning arrays of shape ``(N,)``. The plant adds the rigid dead volume of the
tubing to the cushion volume.

References: [1] ISO 6358-1:2013; [2] the Simscape constant-volume chamber,
``G = (V / R T)(dp/dt - (p / T) dT/dt)``; ``docs/references.md`` section 5 for the working
pressures, conductances and fill times of the demonstrator.

Pressures are in Pa (absolute unless the name says gauge), volumes in m^3, conductances in
m^3/(s*Pa), mass flows in kg/s, times in s.
"""

import math
from numbers import Integral
from typing import Any, Callable, cast, Optional, TYPE_CHECKING, Union

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import (BoolArray, FloatArray, FloatOrArray, in_range,
                                        real_array, real_scalar)
from flectofold_model.actuation.circuit import PlantParameters
from flectofold_model.actuation.cushion_map import CushionMap
from flectofold_model.actuation.faults import CircuitFaults
from flectofold_model.actuation.flow import (AIR_GAS_CONSTANT, ANR_DENSITY_KG_M3,
                                             ATMOSPHERIC_PRESSURE_PA, mass_flow)
from flectofold_model.actuation.sensors import CushionSensors, SensorView
from flectofold_model.actuation.stepping import AdaptiveSubstep, FixedSubstep, Rates

if TYPE_CHECKING:  # numba takes a second to import: the engine's module loads when used
    from flectofold_model.actuation.integration import EmbeddedIntegrator, RowArray
    #: The constants of :meth:`PneumaticPlant.kernel_view`: full fill and vent conductances,
    #: then :meth:`.EmbeddedIntegrator.kernel_constants`.
    KernelConstants = tuple[float, float, tuple[FloatArray, ...], RowArray, tuple[float, ...],
                            float, float]

#: A cushion map: ``cushion_map(gauge_pressure_pa) -> (volume_m3, compliance_m3_per_pa)``.
CushionMapFunction = Callable[[FloatArray], tuple[npt.ArrayLike, npt.ArrayLike]]
#: The live arrays of :meth:`PneumaticPlant.kernel_view`: absolute pressure, free air in and
#: vented, lagged pressure, each panel's step, leak conductance, fill valve jammed, supply.
KernelArrays = tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray,
                     BoolArray, FloatArray]


class PneumaticPlant:
    """``N`` cushion circuits in continuous time: the RK4 reference, or the compiled engine.

    The state of each panel is its absolute cushion pressure. With the default
    ``integrator='fixed'``, :meth:`step` splits any interval
    into equal sub-steps no longer than ``parameters.max_step_s`` and integrates each with the
    classic fourth-order Runge-Kutta scheme: the right-hand side is smooth almost everywhere,
    cheap to evaluate on arrays and non-stiff at the millisecond scale for the documented
    range of volumes and conductances, so an explicit fourth-order method gives errors far
    below the sensor noise at no cost in solver logic, and stays bit-for-bit deterministic.
    The sensor's first-order lag, the one fast mode that may be stiff (a short or zero
    ``sensor_lag_s``), is integrated exactly for a pressure that varies linearly over each
    sub-step, which is stable for any time constant. The pressure is held at or above
    atmospheric after every sub-step (every source is at or above it, so this only removes
    numerical undershoot where the vent flow vanishes); stages below it are evaluated at
    atmospheric pressure. Two limits of the fixed step: the valve flow has a square-root
    singularity at zero pressure difference, so a rigid chamber can settle a fraction of a Pa
    short of its equilibrium (about 0.2 Pa for the 0.2 L dead volume alone at the default
    step); and a cushion map whose compliance jumps (e.g. from zero when flat) makes the
    error first order in the step for the sub-step that crosses the jump.

    Three integrators, chosen with ``integrator``:

    - ``'fixed'`` (default): the RK4 sub-step fixed at ``max_step_s``, the *reference* that
      the others are tested against;
    - ``'adaptive'``: the same RK4 with the sub-step scaled with the active conductance
      (:mod:`.stepping`);
    - ``'embedded'``: the compiled, error-controlled Dormand-Prince 5(4) integration of
      :mod:`.integration`, each panel with its own steps (a few per control period while a
      valve moves air, one while the valves are shut): the engine of the simulated facade.
      It needs a :class:`~.cushion_map.CushionMap` (its tables are compiled in).

    The sensors are :class:`~.sensors.CushionSensors`, the faults of the air path
    :class:`~.faults.CircuitFaults`.

    Parameters
    ----------
    parameters : PlantParameters
        The circuit, shared by all panels.
    cushion_map : callable
        ``cushion_map(gauge_pressure_pa) -> (volume_m3, compliance_m3_per_pa)`` on arrays of
        shape ``(N,)``; volumes and compliances must be finite and non-negative.
    count : int
        Number of panels ``N``.
    seed : int, default 0
        Seed of the sensor noise generator; the same seed and inputs give identical outputs.
    initial_gauge_pa : array-like, default 0.0
        Initial cushion gauge pressure, scalar or ``(N,)`` [Pa], ``>= 0``. The sensor starts
        settled on it.
    integrator : {'fixed', 'adaptive', 'embedded'}, default 'fixed'
        How the plant is integrated (see above).
    tolerance_pa : float, optional
        ``integrator='embedded'`` only: bound on each step's local error estimate [Pa];
        :data:`.integration.TOLERANCE_PA` when not given.
    """

    INTEGRATORS = ('fixed', 'adaptive', 'embedded')
    _stepper: Union[AdaptiveSubstep, FixedSubstep]
    _engine: Optional['EmbeddedIntegrator']  # the compiled engine of integrator='embedded'

    def __init__(self, parameters: PlantParameters, cushion_map: CushionMapFunction,
                 count: Union[int, np.integer[Any]], seed: Union[int, np.integer[Any]] = 0,
                 initial_gauge_pa: npt.ArrayLike = 0.0, integrator: str = 'fixed',
                 tolerance_pa: Optional[float] = None) -> None:
        if not isinstance(parameters, PlantParameters):
            raise TypeError(
                f'parameters must be a PlantParameters, got {type(parameters).__name__}')
        if not callable(cushion_map):
            raise TypeError(f'cushion_map must be callable, got {cushion_map!r}')
        if isinstance(count, bool) or not isinstance(count, Integral) or count < 1:
            raise ValueError(f'count must be a positive integer, got {count!r}')
        if isinstance(seed, bool) or not isinstance(seed, Integral) or seed < 0:
            raise ValueError(f'seed must be a non-negative integer, got {seed!r}')
        if not isinstance(integrator, str) or integrator not in self.INTEGRATORS:
            raise ValueError(f'integrator must be one of {", ".join(self.INTEGRATORS)}, '
                             f'got {integrator!r}')
        if integrator == 'embedded' and not isinstance(cushion_map, CushionMap):
            raise TypeError(f"integrator='embedded' needs a CushionMap, got "
                            f'{type(cushion_map).__name__}')
        # the attributes' types written out: mypy checks this method late (the Integral checks)
        self._integrator: str = integrator
        self._stepper = AdaptiveSubstep() if integrator == 'adaptive' else FixedSubstep()
        self._engine = None
        if integrator == 'embedded':  # imported here: numba takes a second to import
            from flectofold_model.actuation.integration import EmbeddedIntegrator, TOLERANCE_PA
            self._engine = EmbeddedIntegrator(
                parameters, cushion_map, int(count),
                TOLERANCE_PA if tolerance_pa is None else tolerance_pa)
        self._substeps_taken: int = 0
        self._parameters: PlantParameters = parameters
        self._cushion_map: CushionMapFunction = cushion_map
        self._count: int = int(count)
        initial = self._per_panel('initial_gauge_pa', initial_gauge_pa)
        in_range('initial_gauge_pa', initial, 0.0, np.inf, ' Pa', high_open=True)
        self._pressure_pa: FloatArray = initial + ATMOSPHERIC_PRESSURE_PA
        self.sensors: CushionSensors = CushionSensors(parameters, self._count, seed,
                                                      self._pressure_pa)
        """The cushion and supply sensors, with their faults."""
        self.faults: CircuitFaults = CircuitFaults(parameters, self._count)
        """The air path's injected faults: leaks, a jammed fill valve, a lost supply."""
        self._free_air_m3: FloatArray = np.zeros(self._count)
        self._vented_air_m3: FloatArray = np.zeros(self._count)
        self._time_s: float = 0.0
        self.capacitance_m3(self._pressure_pa)

    # -- state ------------------------------------------------------------------------------

    @property
    def parameters(self) -> PlantParameters:
        """The :class:`~.circuit.PlantParameters` of the circuit."""
        return self._parameters

    @property
    def count(self) -> int:
        """Number of panels ``N``."""
        return self._count

    @property
    def time_s(self) -> float:
        """Simulated time since construction [s]."""
        return self._time_s

    @property
    def integrator(self) -> str:
        """``'fixed'``, ``'adaptive'`` or ``'embedded'``: how the plant is integrated."""
        return self._integrator

    @property
    def substeps_taken(self) -> int:
        """Number of sub-steps integrated since construction: the plant's cost.

        RK4 sub-steps, or accepted Dormand-Prince steps for ``integrator='embedded'``.
        """
        return self._substeps_taken

    @property
    def absolute_pressure_pa(self) -> FloatArray:
        """True absolute cushion pressure, ``(N,)`` [Pa]."""
        return self._pressure_pa.copy()

    @property
    def gauge_pressure_pa(self) -> FloatArray:
        """True cushion gauge pressure, ``(N,)`` [Pa]."""
        return self._pressure_pa - ATMOSPHERIC_PRESSURE_PA

    @property
    def volume_m3(self) -> FloatArray:
        """Cushion volume from the cushion map, without the dead volume, ``(N,)`` [m^3]."""
        volume, _compliance = self.cushion(self._pressure_pa)
        return volume.copy()

    @property
    def supply_pressure_pa(self) -> FloatArray:
        """Current absolute supply pressure per panel, atmospheric where it was lost [Pa]."""
        return self.faults.supply_pa.copy()

    @property
    def free_air_used_m3(self) -> FloatArray:
        """Air that came in through the fill valve, as volume at ANR conditions [m^3].

        Only inflow counts: air flowing back out through the fill valve (after a supply loss)
        is not subtracted.
        """
        return self._free_air_m3.copy()

    @property
    def vented_air_m3(self) -> FloatArray:
        """Air let out through the vent valve, as volume at ANR conditions [m^3].

        The leak and the relief valve are not included.
        """
        return self._vented_air_m3.copy()

    # -- dynamics ---------------------------------------------------------------------------

    def step(self, dt_s: float, fill_opening: npt.ArrayLike,
             vent_opening: npt.ArrayLike) -> None:
        """Advance the plant by ``dt_s`` seconds with the valves held at the given openings.

        Parameters
        ----------
        dt_s : float
            Interval to advance [s], ``> 0``.
        fill_opening, vent_opening : array-like
            Valve openings in ``[0, 1]``, scalar or ``(N,)``; a valve's conductance scales
            linearly with its opening.
        """
        dt_s = real_scalar('dt_s', dt_s)
        if dt_s <= 0.0:
            raise ValueError(f'dt_s must be positive, got {dt_s:g} s')
        fill = in_range('fill_opening', self._per_panel('fill_opening', fill_opening), 0.0, 1.0)
        vent = in_range('vent_opening', self._per_panel('vent_opening', vent_opening), 0.0, 1.0)
        fill = np.where(self.faults.fill_stuck_open, 1.0, fill)
        fill_conductance = fill * self._parameters.fill_conductance_m3_s_pa
        vent_conductance = vent * self._parameters.vent_conductance_m3_s_pa
        if self._engine is not None:
            self._step_embedded(dt_s, fill_conductance, vent_conductance)
            return
        longest, first_rates = self._stepper.longest_s(self, dt_s, fill_conductance,
                                                       vent_conductance)
        substeps = max(1, math.ceil(dt_s / longest * (1.0 - 1e-12)))
        step_s = dt_s / substeps
        for _ in range(substeps):
            self._substep(step_s, fill_conductance, vent_conductance, first_rates)
            first_rates = None
        self._substeps_taken += substeps
        self._time_s += dt_s

    def kernel_view(self) -> tuple[KernelArrays, 'KernelConstants', SensorView]:
        """Return the compiled engine's live state and constants, for a caller that runs it.

        Returns ``(arrays, constants, sensors)``: the arrays the engine updates in place
        (absolute pressure, free air in and vented, lagged pressure, each panel's step, leak
        conductance, fill valve jammed, supply pressure), its constants (full fill and vent
        conductances, cushion tables and rows, circuit, sensor lag, tolerance) and
        :meth:`.CushionSensors.kernel_view`. Fetch it anew for each run: an injected fault
        replaces arrays. Report the time run with :meth:`account`.
        """
        if self._engine is None:
            raise ValueError("kernel_view needs integrator='embedded', not "
                             f'{self._integrator!r}')
        engine, faults, parameters = self._engine, self.faults, self._parameters
        arrays = (self._pressure_pa, self._free_air_m3, self._vented_air_m3,
                  self.sensors.lagged_pa, engine.step_s, faults.leak_conductance,
                  faults.fill_stuck_open, faults.supply_pa)
        return arrays, (parameters.fill_conductance_m3_s_pa, parameters.vent_conductance_m3_s_pa,
                        *engine.kernel_constants()), self.sensors.kernel_view()

    def account(self, dt_s: float, accepted: int, rejected: int) -> None:
        """Count ``dt_s`` [s] and the steps a caller of :meth:`kernel_view` ran.

        Refused, with nothing counted, as :meth:`kernel_view` is: ``ValueError`` unless the
        plant's integrator is ``'embedded'``.
        """
        if self._engine is None:
            raise ValueError("account needs integrator='embedded', not "
                             f'{self._integrator!r}')
        self._engine.rejected_steps += rejected
        self._time_s += dt_s
        self._substeps_taken += accepted

    def _step_embedded(self, dt_s: float, fill_conductance: FloatArray,
                       vent_conductance: FloatArray) -> None:
        state = (self._pressure_pa, self._free_air_m3, self._vented_air_m3,
                 self.sensors.lagged_pa)
        # step() calls this only with the engine
        self._substeps_taken += cast('EmbeddedIntegrator', self._engine).advance(
            dt_s, state, fill_conductance, vent_conductance, self.faults.leak_conductance,
            self.faults.supply_pa)
        self._time_s += dt_s

    def _substep(self, h: float, fill_conductance: FloatArray, vent_conductance: FloatArray,
                 k1: Optional[Rates] = None) -> None:
        """One RK4 step of pressure and air counters, then the exact sensor-lag update.

        ``k1``, if given, is :meth:`rates` at the present pressure, already evaluated.
        """
        p0 = self._pressure_pa
        if k1 is None:
            k1 = self.rates(p0, fill_conductance, vent_conductance)
        k2 = self.rates(p0 + 0.5 * h * k1[0], fill_conductance, vent_conductance)
        k3 = self.rates(p0 + 0.5 * h * k2[0], fill_conductance, vent_conductance)
        k4 = self.rates(p0 + h * k3[0], fill_conductance, vent_conductance)
        increments = [h / 6.0 * (a + 2.0 * b + 2.0 * c + d) for a, b, c, d in zip(k1, k2, k3, k4)]
        p1 = np.maximum(p0 + increments[0], ATMOSPHERIC_PRESSURE_PA)
        self._free_air_m3 = self._free_air_m3 + increments[1]
        self._vented_air_m3 = self._vented_air_m3 + increments[2]
        self.sensors.track(p0, p1, h)
        self._pressure_pa = p1

    def rates(self, pressure_pa: FloatArray, fill_conductance: FloatOrArray,
              vent_conductance: FloatOrArray, capacitance: Optional[FloatArray] = None) -> Rates:
        """``dp/dt`` [Pa/s] and the fill inflow and vent outflow as free air [m^3/s].

        The right-hand side of the integration at absolute pressures ``pressure_pa`` (N,)
        (below atmospheric taken as atmospheric) with the valves at the given conductances
        [m^3/(s*Pa)]. ``capacitance``, if given, is :meth:`capacitance_m3` there, already
        evaluated.
        """
        parameters = self._parameters
        p = np.maximum(pressure_pa, ATMOSPHERIC_PRESSURE_PA)
        b = parameters.critical_ratio
        temperature_k = parameters.temperature_k
        fill = mass_flow(self.faults.supply_pa, p, fill_conductance, b, temperature_k)
        per_conductance = mass_flow(p, ATMOSPHERIC_PRESSURE_PA, 1.0, b, temperature_k)
        exhaust_conductance = (vent_conductance + self.faults.leak_conductance
                               + self._relief_conductance(p))
        net = fill - per_conductance * exhaust_conductance
        if capacitance is None:
            capacitance = self.capacitance_m3(p)
        pressure_rate = AIR_GAS_CONSTANT * temperature_k * net / capacitance
        return (pressure_rate, np.maximum(fill, 0.0) / ANR_DENSITY_KG_M3,
                per_conductance * vent_conductance / ANR_DENSITY_KG_M3)

    def _relief_conductance(self, pressure_pa: FloatArray) -> FloatArray:
        """Relief conductance ramping from 0 at cracking to full at full-open [m^3/(s*Pa)]."""
        parameters = self._parameters
        opening = np.clip(
            (pressure_pa - ATMOSPHERIC_PRESSURE_PA - parameters.relief_cracking_pa)
            / (parameters.relief_full_open_pa - parameters.relief_cracking_pa), 0.0, 1.0)
        return opening * parameters.relief_conductance_m3_s_pa

    def capacitance_m3(self, pressure_pa: FloatArray,
                       cushion: Optional[tuple[FloatArray, FloatArray]] = None) -> FloatArray:
        """Isothermal capacitance ``V + p dV/dp`` of cushion plus dead volume [m^3].

        ``cushion``, if given, is :meth:`cushion` at ``pressure_pa``, already evaluated.
        """
        volume, compliance = self.cushion(pressure_pa) if cushion is None else cushion
        capacitance = volume + self._parameters.dead_volume_m3 + pressure_pa * compliance
        if not np.all(capacitance > 0.0):
            raise ValueError(
                'the chamber has no volume: give dead_volume_m3 > 0 or a cushion map with a '
                'positive volume or compliance')
        return capacitance

    def cushion(self, pressure_pa: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Evaluate the cushion map at absolute pressures: checked (N,) volume and compliance."""
        volume, compliance = self._cushion_map(pressure_pa - ATMOSPHERIC_PRESSURE_PA)
        volume = np.asarray(volume, dtype=np.float64)
        compliance = np.asarray(compliance, dtype=np.float64)
        for name, value in (('volume_m3', volume), ('compliance_m3_per_pa', compliance)):
            if value.shape != (self._count,):
                raise ValueError(f'cushion_map must return {name} of shape ({self._count},), '
                                 f'got shape {value.shape}')
            if not np.all(value >= 0.0) or not np.all(np.isfinite(value)):
                raise ValueError(f'cushion_map returned a negative or non-finite {name}')
        return volume, compliance

    # -- sensors ----------------------------------------------------------------------------

    def read_sensor(self) -> FloatArray:
        """Measured absolute cushion pressure, ``(N,)`` [Pa]; see :meth:`.CushionSensors.read`."""
        return self.sensors.read()

    def read_supply_sensor(self) -> FloatArray:
        """Measured absolute supply pressure, ``(N,)`` [Pa]: no lag, the same noise level."""
        return self.sensors.read_supply(self.faults.supply_pa)

    # -- faults -----------------------------------------------------------------------------

    def inject_sensor_stuck(self, panels: npt.ArrayLike) -> None:
        """Freeze the cushion sensor of ``panels`` on the value it returned last.

        Before the first read that is the noise-free initial reading.
        """
        self.sensors.inject_stuck(panels)

    def inject_sensor_dropout(self, panels: npt.ArrayLike) -> None:
        """Make the cushion sensor of ``panels`` read NaN."""
        self.sensors.inject_dropout(panels)

    def inject_sensor_noise(self, panels: npt.ArrayLike, noise_pa: float) -> None:
        """Give the cushion sensor of ``panels`` noise of standard deviation ``noise_pa`` [Pa]."""
        self.sensors.inject_noise(panels, noise_pa)

    def inject_leak(self, panels: npt.ArrayLike, conductance_m3_s_pa: float) -> None:
        """Add a leak to atmosphere of ``conductance_m3_s_pa`` [m^3/(s*Pa)] to ``panels``."""
        self.faults.inject_leak(panels, conductance_m3_s_pa)

    def inject_fill_valve_stuck_open(self, panels: npt.ArrayLike) -> None:
        """Jam the fill valve of ``panels`` wide open, whatever it is commanded."""
        self.faults.inject_fill_valve_stuck_open(panels)

    def inject_supply_loss(self, panels: npt.ArrayLike) -> None:
        """Drop the supply of ``panels`` to atmospheric: an open fill valve then vents."""
        self.faults.inject_supply_loss(panels)

    def clear_faults(self) -> None:
        """Remove every injected fault; the sensors read live values again."""
        self.sensors.clear_faults()
        self.faults.clear()

    def _per_panel(self, name: str, value: npt.ArrayLike) -> FloatArray:
        array = real_array(name, value)
        if array.ndim == 0:
            return np.full(self._count, float(array))
        if array.shape != (self._count,):
            raise ValueError(
                f'{name} must be a scalar or have shape ({self._count},), got shape {array.shape}')
        return array.copy()
