"""Pneumatic plant of Flectofold cushions: valves, chamber, relief, leaks and pressure sensors.

Each panel's cushion is a chamber of absolute pressure ``p`` fed from a supply through a fill
valve and emptied to the atmosphere through a vent valve, a leak and a relief valve. Valves
follow ISO 6358 with sonic conductance ``C`` and critical pressure ratio ``b``; for upstream
pressure ``p1`` and downstream pressure ``p2 <= p1`` (both absolute):

=======================  ===============================================================
choked, ``p2/p1 <= b``    ``Q_ANR = C p1``
subsonic                  ``Q_ANR = C p1 sqrt(1 - ((p2/p1 - b) / (1 - b))**2)``
mass flow                 ``mdot = rho_ANR Q_ANR sqrt(T_ANR / T1)``
=======================  ===============================================================

The chamber is isothermal: with air mass ``m`` and volume ``V(p)``, ``p V = m R T`` gives
``dp/dt = R T mdot_net / (V + p dV/dp)``. For a soft cushion the compliance ``dV/dp`` dominates
the air's own compressibility ``V / p``. The cushion's volume and compliance come from a
*cushion map*, a callable written elsewhere::

    cushion_map(gauge_pressure_pa) -> (volume_m3, compliance_m3_per_pa)

taking and returning arrays of shape ``(N,)``. The plant adds the rigid dead volume of the
tubing to the cushion volume.

References: ISO 6358-1:2013 (flow-rate characteristics of pneumatic components); ISO 8778
(ANR standard reference atmosphere, 20 degC, 100 kPa, 65 % RH); the Simscape constant-volume
chamber; ``flectofold_model.md`` section 7 for the working pressures, conductances and fill
times of the demonstrator.

Pressures are in Pa (absolute unless the name says gauge), volumes in m^3, conductances in
m^3/(s*Pa), mass flows in kg/s, times in s.
"""

from dataclasses import dataclass
import math
from numbers import Integral

import numpy as np
from scipy.optimize import brentq

from flectofold_model._validate import in_range, real_array, real_fields, real_scalar

#: Standard atmosphere: the vent, leak and relief exhaust against it [Pa].
ATMOSPHERIC_PRESSURE_PA = 101325.0
#: Specific gas constant of dry air [J/(kg K)].
AIR_GAS_CONSTANT = 287.05
#: Density of air at the ANR reference atmosphere of ISO 8778 [kg/m^3].
ANR_DENSITY_KG_M3 = 1.185
#: Temperature of the ANR reference atmosphere of ISO 8778 [K].
ANR_TEMPERATURE_K = 293.15

#: One catalogue conductance unit, 1 dm^3/(s*bar), in m^3/(s*Pa): 1e-3 m^3 / 1e5 Pa.
_M3_S_PA_PER_DM3_S_BAR = 1e-8
#: Largest relative change of the chamber capacitance over one adaptive sub-step, predicted
#: from the rate at its start; resolves the compliance ramps of a cushion map.
_CAPACITANCE_CHANGE = 0.25
#: Trials of the capacitance guard per call before it settles for what it has.
_CAPACITANCE_TRIALS = 4


def conductance_from_catalogue(dm3_per_s_bar):
    """Convert a catalogue sonic conductance from dm^3/(s*bar) to SI [m^3/(s*Pa)].

    Parameters
    ----------
    dm3_per_s_bar : array-like
        Sonic conductance ``C`` as valve catalogues give it [dm^3/(s*bar)], ``>= 0``.

    Returns
    -------
    numpy.ndarray or float
        The same conductance [m^3/(s*Pa)]: ``1 dm^3/(s*bar) = 1e-8 m^3/(s*Pa)``.
    """
    value = real_array('dm3_per_s_bar', dm3_per_s_bar)
    in_range('dm3_per_s_bar', value, 0.0, np.inf, ' dm^3/(s*bar)', high_open=True)
    return value * _M3_S_PA_PER_DM3_S_BAR


def iso6358_mass_flow(upstream_pa, downstream_pa, conductance_m3_s_pa, critical_ratio,
                      temperature_k=ANR_TEMPERATURE_K):
    """Signed ISO 6358 mass flow through a valve [kg/s].

    The formula is applied with the higher of the two pressures upstream, so the flow is
    positive from ``upstream_pa`` to ``downstream_pa`` and negative when it runs the other way.
    It is zero at equal pressures, continuous at the choke boundary ``p2/p1 = b`` and monotone
    in the pressure difference. All inputs broadcast together.

    Parameters
    ----------
    upstream_pa : array-like
        Absolute pressure on the side the flow is counted from [Pa], ``> 0``.
    downstream_pa : array-like
        Absolute pressure on the other side [Pa], ``> 0``.
    conductance_m3_s_pa : array-like
        Sonic conductance ``C`` [m^3/(s*Pa)], ``>= 0``; see :func:`conductance_from_catalogue`.
    critical_ratio : array-like
        Critical pressure ratio ``b``, in ``(0, 1)``; 0.528 for an ideal nozzle.
    temperature_k : array-like, default 293.15
        Temperature of the air on the upstream side [K], ``> 0``.

    Returns
    -------
    numpy.ndarray
        Mass flow [kg/s], positive from ``upstream_pa`` to ``downstream_pa``.
    """
    upstream_pa = _positive('upstream_pa', upstream_pa, ' Pa')
    downstream_pa = _positive('downstream_pa', downstream_pa, ' Pa')
    conductance = real_array('conductance_m3_s_pa', conductance_m3_s_pa)
    in_range('conductance_m3_s_pa', conductance, 0.0, np.inf, ' m^3/(s*Pa)', high_open=True)
    critical_ratio = real_array('critical_ratio', critical_ratio)
    in_range('critical_ratio', critical_ratio, 0.0, 1.0, low_open=True, high_open=True)
    temperature_k = _positive('temperature_k', temperature_k, ' K')
    return _mass_flow(upstream_pa, downstream_pa, conductance, critical_ratio, temperature_k)


def _positive(name, value, unit):
    array = real_array(name, value)
    return in_range(name, array, 0.0, np.inf, unit, low_open=True, high_open=True)


def _mass_flow(from_pa, to_pa, conductance, critical_ratio, temperature_k):
    """:func:`iso6358_mass_flow` without the input checks, for the integrator's inner loop."""
    high = np.maximum(from_pa, to_pa)
    ratio = np.minimum(from_pa, to_pa) / high
    subsonic = np.clip((ratio - critical_ratio) / (1.0 - critical_ratio), 0.0, 1.0)
    free_air_m3_s = conductance * high * np.sqrt(1.0 - np.square(subsonic))
    mass_flow = free_air_m3_s * ANR_DENSITY_KG_M3 * np.sqrt(ANR_TEMPERATURE_K / temperature_k)
    return np.sign(from_pa - to_pa) * mass_flow


@dataclass(frozen=True)
class PlantParameters:
    """Valves, relief, tubing and sensor of one cushion circuit, in SI units.

    The defaults describe a ~1 m^2 demonstrator panel working at 4-9 kPa gauge
    (``flectofold_model.md`` sections 2 and 7). Values marked [estimate] are engineering
    guesses, not measurements of the demonstrator.
    """

    supply_pressure_pa: float = 151325.0
    """Absolute supply pressure upstream of the fill valve [Pa]; 0.5 bar gauge, the supply of
    the fill-time estimate in ``flectofold_model.md`` section 7."""
    fill_conductance_m3_s_pa: float = 0.5 * _M3_S_PA_PER_DM3_S_BAR
    """Sonic conductance of the fully open fill valve [m^3/(s*Pa)]; 0.5 dm^3/(s*bar), the
    middle of the 0.05-1.0 dm^3/(s*bar) range of section 7 [estimate]."""
    vent_conductance_m3_s_pa: float = 0.5 * _M3_S_PA_PER_DM3_S_BAR
    """Sonic conductance of the fully open vent valve [m^3/(s*Pa)]; 0.5 dm^3/(s*bar)
    [estimate]."""
    critical_ratio: float = 0.5
    """Critical pressure ratio ``b`` of every valve; typical of catalogue solenoid valves,
    0.528 for an ideal nozzle [estimate]."""
    leak_conductance_m3_s_pa: float = 0.0005 * _M3_S_PA_PER_DM3_S_BAR
    """Conductance of the healthy circuit's leak to atmosphere [m^3/(s*Pa)]; 0.0005
    dm^3/(s*bar), about 1 Pa/s of pressure loss at 9 kPa gauge [estimate]."""
    relief_cracking_pa: float = 15e3
    """Gauge pressure at which the relief valve starts to open [Pa]; above the 4-9 kPa working
    range of the demonstrator [estimate]."""
    relief_full_open_pa: float = 18e3
    """Gauge pressure at which the relief valve is fully open [Pa] [estimate]."""
    relief_conductance_m3_s_pa: float = 2.0 * _M3_S_PA_PER_DM3_S_BAR
    """Sonic conductance of the fully open relief valve [m^3/(s*Pa)]; 2 dm^3/(s*bar), enough to
    out-blow the default fill valve from the default supply [estimate]."""
    temperature_k: float = ANR_TEMPERATURE_K
    """Temperature of the air everywhere in the circuit [K]; the ANR reference of ISO 8778."""
    dead_volume_m3: float = 2e-4
    """Rigid volume of tubing and fittings added to the cushion [m^3]; about 5 m of 6 mm bore
    tube plus fittings [estimate]."""
    sensor_lag_s: float = 0.02
    """Time constant of the pressure sensor's first-order lag [s]; transducer plus sensing
    line [estimate]."""
    sensor_noise_pa: float = 20.0
    """Standard deviation of the sensors' Gaussian noise [Pa]; 0.1 % of a 20 kPa range
    [estimate]."""
    sensor_offset_pa: float = 0.0
    """Constant offset of the cushion pressure sensor [Pa]."""
    max_step_s: float = 1e-3
    """Longest internal integration sub-step [s]; a fine margin below the stability limit of
    RK4 for the default valves and relief on a 2 L cushion. With ``adaptive_step`` (see
    :class:`PneumaticPlant`), the sub-step with a valve wide open and the shortest taken."""
    max_quiet_step_s: float = 0.25
    """Longest sub-step of a :class:`PneumaticPlant` with ``adaptive_step`` [s], taken while
    only the leak (or a barely open valve) moves air; at least ``max_step_s``."""

    def __post_init__(self):
        real_fields(self)
        self._check_pressures()
        self._check_non_negative()

    def _check_pressures(self):
        if self.supply_pressure_pa <= ATMOSPHERIC_PRESSURE_PA:
            raise ValueError(
                f'supply_pressure_pa must be an absolute pressure above atmospheric '
                f'({ATMOSPHERIC_PRESSURE_PA:g} Pa), got {self.supply_pressure_pa:g} Pa')
        if not 0.0 < self.critical_ratio < 1.0:
            raise ValueError(
                f'critical_ratio must lie in (0, 1), got {self.critical_ratio:g}')
        if self.relief_cracking_pa <= 0.0:
            raise ValueError(
                f'relief_cracking_pa must be a positive gauge pressure, '
                f'got {self.relief_cracking_pa:g} Pa')
        if self.relief_full_open_pa <= self.relief_cracking_pa:
            raise ValueError(
                f'relief_full_open_pa must be above relief_cracking_pa '
                f'({self.relief_cracking_pa:g} Pa), got {self.relief_full_open_pa:g} Pa')

    def _check_non_negative(self):
        for name, unit in (('fill_conductance_m3_s_pa', ' m^3/(s*Pa)'),
                           ('vent_conductance_m3_s_pa', ' m^3/(s*Pa)'),
                           ('temperature_k', ' K'), ('max_step_s', ' s'),
                           ('max_quiet_step_s', ' s')):
            if getattr(self, name) <= 0.0:
                raise ValueError(f'{name} must be positive, got {getattr(self, name):g}{unit}')
        if self.max_quiet_step_s < self.max_step_s:
            raise ValueError(f'max_quiet_step_s must be at least max_step_s '
                             f'({self.max_step_s:g} s), got {self.max_quiet_step_s:g} s')
        for name, unit in (('leak_conductance_m3_s_pa', ' m^3/(s*Pa)'),
                           ('relief_conductance_m3_s_pa', ' m^3/(s*Pa)'),
                           ('dead_volume_m3', ' m^3'), ('sensor_lag_s', ' s'),
                           ('sensor_noise_pa', ' Pa')):
            if getattr(self, name) < 0.0:
                raise ValueError(
                    f'{name} must not be negative, got {getattr(self, name):g}{unit}')


#: The circuit of a demonstrator module [estimate]: the default 0.5 bar supply with a 1.0
#: dm^3/(s*bar) proportional fill valve and a larger, 2.5 dm^3/(s*bar), vent valve, so that
#: venting out-flows even a fill valve jammed open at the working pressures. It fills the 16 L
#: cushion of ``actuation.DEMONSTRATOR_ACTUATED`` to its closed pressure in about 12 s.
DEMONSTRATOR_PLANT = PlantParameters(
    fill_conductance_m3_s_pa=1.0 * _M3_S_PA_PER_DM3_S_BAR,
    vent_conductance_m3_s_pa=2.5 * _M3_S_PA_PER_DM3_S_BAR)


class PneumaticPlant:
    """``N`` cushion circuits in continuous time, integrated with fixed sub-steps.

    The state of each panel is its absolute cushion pressure. :meth:`step` splits any interval
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

    **Adaptive sub-step** (``adaptive_step=True``, opt-in; the default keeps the fixed step bit
    for bit). Each call of :meth:`step` takes one sub-step for all panels,

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
      The demonstrator's :class:`~flectofold_model.actuation.CushionMap` has a capacitance
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
    adaptive_step : bool, default False
        Scale the sub-step with the conductance that is active (see above). ``False`` keeps
        the fixed ``max_step_s`` sub-step, bit for bit.
    """

    def __init__(self, parameters, cushion_map, count, seed=0, initial_gauge_pa=0.0,
                 adaptive_step=False):
        if not isinstance(parameters, PlantParameters):
            raise TypeError(
                f'parameters must be a PlantParameters, got {type(parameters).__name__}')
        if not callable(cushion_map):
            raise TypeError(f'cushion_map must be callable, got {cushion_map!r}')
        if isinstance(count, bool) or not isinstance(count, Integral) or count < 1:
            raise ValueError(f'count must be a positive integer, got {count!r}')
        if isinstance(seed, bool) or not isinstance(seed, Integral) or seed < 0:
            raise ValueError(f'seed must be a non-negative integer, got {seed!r}')
        if not isinstance(adaptive_step, (bool, np.bool_)):
            raise TypeError(f'adaptive_step must be True or False, got {adaptive_step!r}')
        self._adaptive_step = bool(adaptive_step)
        self._substeps_taken = 0
        self._parameters = parameters
        self._cushion_map = cushion_map
        self._count = int(count)
        self._rng = np.random.default_rng(int(seed))
        initial = self._per_panel('initial_gauge_pa', initial_gauge_pa)
        in_range('initial_gauge_pa', initial, 0.0, np.inf, ' Pa', high_open=True)
        self._pressure_pa = initial + ATMOSPHERIC_PRESSURE_PA
        self._sensor_pa = self._pressure_pa.copy()
        self._last_reading_pa = self._sensor_pa + parameters.sensor_offset_pa
        self._free_air_m3 = np.zeros(self._count)
        self._vented_air_m3 = np.zeros(self._count)
        self._time_s = 0.0
        self.clear_faults()
        self._chamber(self._pressure_pa)

    # -- state ------------------------------------------------------------------------------

    @property
    def parameters(self):
        """The :class:`PlantParameters` of the circuit."""
        return self._parameters

    @property
    def count(self):
        """Number of panels ``N``."""
        return self._count

    @property
    def time_s(self):
        """Simulated time since construction [s]."""
        return self._time_s

    @property
    def adaptive_step(self):
        """Whether the sub-step scales with the active conductance (see the class notes)."""
        return self._adaptive_step

    @property
    def substeps_taken(self):
        """Number of RK4 sub-steps integrated since construction: the plant's cost."""
        return self._substeps_taken

    @property
    def absolute_pressure_pa(self):
        """True absolute cushion pressure, ``(N,)`` [Pa]."""
        return self._pressure_pa.copy()

    @property
    def gauge_pressure_pa(self):
        """True cushion gauge pressure, ``(N,)`` [Pa]."""
        return self._pressure_pa - ATMOSPHERIC_PRESSURE_PA

    @property
    def volume_m3(self):
        """Cushion volume from the cushion map, without the dead volume, ``(N,)`` [m^3]."""
        volume, _compliance = self._cushion(self._pressure_pa)
        return volume.copy()

    @property
    def supply_pressure_pa(self):
        """Current absolute supply pressure per panel, atmospheric where it was lost [Pa]."""
        return self._supply_pa.copy()

    @property
    def free_air_used_m3(self):
        """Air that came in through the fill valve, as volume at ANR conditions [m^3].

        Only inflow counts: air flowing back out through the fill valve (after a supply loss)
        is not subtracted.
        """
        return self._free_air_m3.copy()

    @property
    def vented_air_m3(self):
        """Air let out through the vent valve, as volume at ANR conditions [m^3].

        The leak and the relief valve are not included.
        """
        return self._vented_air_m3.copy()

    # -- dynamics ---------------------------------------------------------------------------

    def step(self, dt_s, fill_opening, vent_opening):
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
        fill = np.where(self._fill_stuck_open, 1.0, fill)
        self._advance(dt_s, fill * self._parameters.fill_conductance_m3_s_pa,
                      vent * self._parameters.vent_conductance_m3_s_pa)

    def _advance(self, dt_s, fill_conductance, vent_conductance):
        longest, first_rates = self._parameters.max_step_s, None
        if self._adaptive_step:
            longest, first_rates = self._adaptive_substep_s(dt_s, fill_conductance,
                                                            vent_conductance)
        substeps = max(1, math.ceil(dt_s / longest * (1.0 - 1e-12)))
        step_s = dt_s / substeps
        for _ in range(substeps):
            self._substep(step_s, fill_conductance, vent_conductance, first_rates)
            first_rates = None
        self._substeps_taken += substeps
        self._time_s += dt_s

    def _adaptive_substep_s(self, dt_s, fill_conductance, vent_conductance):
        """Longest sub-step for the coming ``dt_s`` with ``adaptive_step`` [s], and the rates.

        The conductance rule of the class notes, clipped to ``[max_step_s, min(
        max_quiet_step_s, dt_s)]``, then shortened (not below ``max_step_s``) while the
        pressure one sub-step at the present rate would reach changes the chamber's
        capacitance by more than ``_CAPACITANCE_CHANGE`` of itself. The rates at the present
        pressure, if that needed them, come back as well (else None): they are the first
        stage of the first sub-step.
        """
        parameters = self._parameters
        shortest = parameters.max_step_s
        pressure = self._pressure_pa
        volume, compliance = self._cushion(pressure)
        capacitance = self._chamber(pressure, (volume, compliance))
        exhaust = self._leak_conductance
        if parameters.relief_conductance_m3_s_pa > 0.0:
            reach = self._relief_within_reach(dt_s, fill_conductance, volume)
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
        rates = self._rates(pressure, fill_conductance, vent_conductance, capacitance)
        rate = rates[0]
        for _ in range(_CAPACITANCE_TRIALS):
            reached = np.maximum(pressure + step_s * rate, ATMOSPHERIC_PRESSURE_PA)
            volume, compliance = self._cushion(reached)
            there = volume + parameters.dead_volume_m3 + reached * compliance
            with np.errstate(divide='ignore'):
                change = float(np.max(np.abs(there - capacitance)
                                      / np.minimum(there, capacitance)))
            if change <= _CAPACITANCE_CHANGE:
                break
            step_s = max(shortest, step_s * _CAPACITANCE_CHANGE / change)
            if step_s == shortest:
                break
        return step_s, rates

    def _relief_within_reach(self, dt_s, fill_conductance, volume):
        """Panels whose relief valve may be open at some time of the coming ``dt_s``.

        Those at or above the cracking pressure less the largest rise their fill valve could
        make in ``dt_s``: choked flow from the supply (or from the cushion, if higher) into the
        present cushion ``volume`` plus the dead volume. The volume only grows as the pressure
        rises, and every other flow takes air out, so the true rise is smaller.
        """
        parameters = self._parameters
        pressure = self._pressure_pa
        room = volume + parameters.dead_volume_m3
        inflow = (fill_conductance * np.maximum(self._supply_pa, pressure) * ANR_DENSITY_KG_M3
                  * math.sqrt(ANR_TEMPERATURE_K / parameters.temperature_k))
        rise = np.full(self._count, np.inf)
        np.divide(AIR_GAS_CONSTANT * parameters.temperature_k * inflow * dt_s, room, out=rise,
                  where=room > 0.0)
        rise = np.where(fill_conductance > 0.0, rise, 0.0)
        gauge = pressure - ATMOSPHERIC_PRESSURE_PA
        return gauge + rise >= parameters.relief_cracking_pa

    def _substep(self, h, fill_conductance, vent_conductance, k1=None):
        """One RK4 step of pressure and air counters, then the exact sensor-lag update.

        ``k1``, if given, is :meth:`_rates` at the present pressure, already evaluated.
        """
        p0 = self._pressure_pa
        if k1 is None:
            k1 = self._rates(p0, fill_conductance, vent_conductance)
        k2 = self._rates(p0 + 0.5 * h * k1[0], fill_conductance, vent_conductance)
        k3 = self._rates(p0 + 0.5 * h * k2[0], fill_conductance, vent_conductance)
        k4 = self._rates(p0 + h * k3[0], fill_conductance, vent_conductance)
        increments = [h / 6.0 * (a + 2.0 * b + 2.0 * c + d) for a, b, c, d in zip(k1, k2, k3, k4)]
        p1 = np.maximum(p0 + increments[0], ATMOSPHERIC_PRESSURE_PA)
        self._free_air_m3 = self._free_air_m3 + increments[1]
        self._vented_air_m3 = self._vented_air_m3 + increments[2]
        self._sensor_pa = self._lagged(self._sensor_pa, p0, p1, h)
        self._pressure_pa = p1

    def _rates(self, pressure_pa, fill_conductance, vent_conductance, capacitance=None):
        """``dp/dt`` [Pa/s] and the fill inflow and vent outflow as free air [m^3/s].

        ``capacitance``, if given, is :meth:`_chamber` at ``pressure_pa`` (at or above
        atmospheric), already evaluated.
        """
        parameters = self._parameters
        p = np.maximum(pressure_pa, ATMOSPHERIC_PRESSURE_PA)
        b = parameters.critical_ratio
        temperature_k = parameters.temperature_k
        fill = _mass_flow(self._supply_pa, p, fill_conductance, b, temperature_k)
        per_conductance = _mass_flow(p, ATMOSPHERIC_PRESSURE_PA, 1.0, b, temperature_k)
        exhaust_conductance = (vent_conductance + self._leak_conductance
                               + self._relief_conductance(p))
        net = fill - per_conductance * exhaust_conductance
        if capacitance is None:
            capacitance = self._chamber(p)
        pressure_rate = AIR_GAS_CONSTANT * temperature_k * net / capacitance
        return (pressure_rate, np.maximum(fill, 0.0) / ANR_DENSITY_KG_M3,
                per_conductance * vent_conductance / ANR_DENSITY_KG_M3)

    def _relief_conductance(self, pressure_pa):
        """Relief conductance ramping from 0 at cracking to full at full-open [m^3/(s*Pa)]."""
        parameters = self._parameters
        opening = np.clip(
            (pressure_pa - ATMOSPHERIC_PRESSURE_PA - parameters.relief_cracking_pa)
            / (parameters.relief_full_open_pa - parameters.relief_cracking_pa), 0.0, 1.0)
        return opening * parameters.relief_conductance_m3_s_pa

    def _chamber(self, pressure_pa, cushion=None):
        """Isothermal capacitance ``V + p dV/dp`` of cushion plus dead volume [m^3].

        ``cushion``, if given, is :meth:`_cushion` at ``pressure_pa``, already evaluated.
        """
        volume, compliance = self._cushion(pressure_pa) if cushion is None else cushion
        capacitance = volume + self._parameters.dead_volume_m3 + pressure_pa * compliance
        if not np.all(capacitance > 0.0):
            raise ValueError(
                'the chamber has no volume: give dead_volume_m3 > 0 or a cushion map with a '
                'positive volume or compliance')
        return capacitance

    def _cushion(self, pressure_pa):
        """Evaluate the cushion map at ``pressure_pa`` and check its two ``(N,)`` outputs."""
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

    def _lagged(self, sensor_pa, p0, p1, h):
        """Exact first-order lag over ``h`` for a pressure going linearly from ``p0`` to ``p1``.

        ``s(h) = p1 + (s0 - p0) a - (p1 - p0) tau (1 - a) / h`` with ``a = exp(-h / tau)``;
        ``tau = 0`` gives ``s = p1``.
        """
        tau = self._parameters.sensor_lag_s
        if tau == 0.0:
            return p1.copy()
        decay = math.exp(-h / tau)
        return p1 + (sensor_pa - p0) * decay - (p1 - p0) * (tau * (1.0 - decay) / h)

    # -- sensors ----------------------------------------------------------------------------

    def read_sensor(self):
        """Measured absolute cushion pressure, ``(N,)`` [Pa].

        The lagged true pressure plus ``sensor_offset_pa`` plus Gaussian noise of standard
        deviation ``sensor_noise_pa`` drawn now from the seeded generator (one draw per panel
        on every read, faulted or not, so a fault does not shift the other panels' noise). A
        stuck sensor repeats its last reading exactly; a dropped-out sensor reads NaN.
        """
        noise = self._rng.standard_normal(self._count) * self._parameters.sensor_noise_pa
        reading = self._sensor_pa + self._parameters.sensor_offset_pa + noise
        reading = np.where(self._stuck, self._last_reading_pa, reading)
        reading[self._dropout] = np.nan
        self._last_reading_pa = np.where(self._stuck, self._last_reading_pa, reading)
        return reading

    def read_supply_sensor(self):
        """Measured absolute supply pressure, ``(N,)`` [Pa]: no lag, the same noise level."""
        noise = self._rng.standard_normal(self._count) * self._parameters.sensor_noise_pa
        return self._supply_pa + noise

    # -- faults -----------------------------------------------------------------------------

    def inject_sensor_stuck(self, panels):
        """Freeze the cushion sensor of ``panels`` on the value it returned last.

        Before the first read that is the noise-free initial reading.
        """
        self._stuck = self._stuck | self._mask(panels)

    def inject_sensor_dropout(self, panels):
        """Make the cushion sensor of ``panels`` read NaN."""
        self._dropout = self._dropout | self._mask(panels)

    def inject_leak(self, panels, conductance_m3_s_pa):
        """Add a leak to atmosphere of ``conductance_m3_s_pa`` [m^3/(s*Pa)] to ``panels``."""
        conductance = real_scalar('conductance_m3_s_pa', conductance_m3_s_pa)
        if conductance < 0.0:
            raise ValueError(
                f'conductance_m3_s_pa must not be negative, got {conductance:g} m^3/(s*Pa)')
        self._leak_conductance = np.where(
            self._mask(panels), self._leak_conductance + conductance, self._leak_conductance)

    def inject_fill_valve_stuck_open(self, panels):
        """Jam the fill valve of ``panels`` wide open, whatever it is commanded."""
        self._fill_stuck_open = self._fill_stuck_open | self._mask(panels)

    def inject_supply_loss(self, panels):
        """Drop the supply of ``panels`` to atmospheric: an open fill valve then vents."""
        self._supply_pa = np.where(self._mask(panels), ATMOSPHERIC_PRESSURE_PA, self._supply_pa)

    def clear_faults(self):
        """Remove every injected fault; the sensors read live values again."""
        self._stuck = np.zeros(self._count, dtype=bool)
        self._dropout = np.zeros(self._count, dtype=bool)
        self._fill_stuck_open = np.zeros(self._count, dtype=bool)
        self._leak_conductance = np.full(self._count,
                                         self._parameters.leak_conductance_m3_s_pa)
        self._supply_pa = np.full(self._count, self._parameters.supply_pressure_pa)

    # -- input checks -----------------------------------------------------------------------

    def _per_panel(self, name, value):
        array = real_array(name, value)
        if array.ndim == 0:
            return np.full(self._count, float(array))
        if array.shape != (self._count,):
            raise ValueError(
                f'{name} must be a scalar or have shape ({self._count},), got shape {array.shape}')
        return array.copy()

    def _mask(self, panels):
        """Turn a boolean mask or an array of panel indices into a boolean ``(N,)`` mask."""
        if isinstance(panels, (str, bytes)):
            raise TypeError(f'panels must be a boolean mask or panel indices, got {panels!r}')
        selection = np.asarray(panels)
        if selection.dtype == np.bool_:
            if selection.shape != (self._count,):
                raise ValueError(f'a panel mask must have shape ({self._count},), '
                                 f'got shape {selection.shape}')
            return selection.copy()
        if selection.size == 0:
            return np.zeros(self._count, dtype=bool)
        if selection.dtype.kind not in 'iu':
            raise TypeError(f'panels must be a boolean mask or panel indices, got {panels!r}')
        selection = selection.reshape(-1)
        if np.any(selection < 0) or np.any(selection >= self._count):
            raise ValueError(f'panel indices must lie in [0, {self._count - 1}], got {panels!r}')
        mask = np.zeros(self._count, dtype=bool)
        mask[selection] = True
        return mask


def physical_fill_time_s(parameters, cushion_map, target_gauge_pa, start_gauge_pa=0.0,
                         dt_s=1e-3, limit_s=600.0):
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
    reachable = _holding_gauge_pa(parameters)
    if target >= reachable:
        raise ValueError(
            f'target_gauge_pa={target:g} Pa is at or above the {reachable:.6g} Pa gauge that the '
            f'supply of {parameters.supply_pressure_pa:g} Pa can hold against the leak and the '
            f'relief valve: it cannot be reached')
    plant = PneumaticPlant(parameters, cushion_map, 1, initial_gauge_pa=start)
    fill = np.array([parameters.fill_conductance_m3_s_pa])
    closed = np.zeros(1)
    previous = start
    for index in range(math.ceil(limit_s / dt_s)):
        plant._advance(dt_s, fill, closed)
        current = float(plant._pressure_pa[0]) - ATMOSPHERIC_PRESSURE_PA
        if current >= target:
            return (index + (target - previous) / (current - previous)) * dt_s
        previous = current
    raise ValueError(
        f'target_gauge_pa={target:g} Pa was not reached within limit_s={limit_s:g} s '
        f'(the cushion got to {previous:.6g} Pa)')


def _holding_gauge_pa(parameters):
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

    def net_mass_flow(pressure_pa):
        opening = min(max((pressure_pa - ATMOSPHERIC_PRESSURE_PA
                           - parameters.relief_cracking_pa) / span, 0.0), 1.0)
        exhaust = (parameters.leak_conductance_m3_s_pa
                   + opening * parameters.relief_conductance_m3_s_pa)
        return float(
            _mass_flow(supply, pressure_pa, parameters.fill_conductance_m3_s_pa, b, temperature_k)
            - _mass_flow(pressure_pa, ATMOSPHERIC_PRESSURE_PA, exhaust, b, temperature_k))

    if net_mass_flow(supply) >= 0.0:
        return supply - ATMOSPHERIC_PRESSURE_PA
    balance = brentq(net_mass_flow, ATMOSPHERIC_PRESSURE_PA, supply, xtol=1e-9, rtol=1e-15)
    return balance - ATMOSPHERIC_PRESSURE_PA
