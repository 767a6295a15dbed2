"""Air flow through the valves of a cushion circuit: ISO 6358 and the reference atmosphere.

A valve follows ISO 6358 with sonic conductance ``C`` and critical pressure ratio ``b``; for
upstream pressure ``p1`` and downstream pressure ``p2 <= p1`` (both absolute):

=======================  ===============================================================
choked, ``p2/p1 <= b``    ``Q_ANR = C p1``
subsonic                  ``Q_ANR = C p1 sqrt(1 - ((p2/p1 - b) / (1 - b))**2)``
mass flow                 ``mdot = rho_ANR Q_ANR sqrt(T_ANR / T1)``
=======================  ===============================================================

References: [1] ISO 6358-1:2013, flow-rate characteristics of pneumatic components; [2] ISO
8778, the ANR standard reference atmosphere (20 degC, 100 kPa, 65 % RH). See
``docs/references.md`` section 5 for the figures the defaults come from.

Pressures are in Pa (absolute), conductances in m^3/(s*Pa), mass flows in kg/s.
"""

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import FloatArray, FloatOrArray, in_range, real_array

#: Standard atmosphere: the vent, leak and relief exhaust against it [Pa].
ATMOSPHERIC_PRESSURE_PA = 101325.0
#: Specific gas constant of dry air [J/(kg K)].
AIR_GAS_CONSTANT = 287.05
#: Density of air at the ANR reference atmosphere of ISO 8778 [kg/m^3].
ANR_DENSITY_KG_M3 = 1.185
#: Temperature of the ANR reference atmosphere of ISO 8778 [K].
ANR_TEMPERATURE_K = 293.15

#: One catalogue conductance unit, 1 dm^3/(s*bar), in m^3/(s*Pa): 1e-3 m^3 / 1e5 Pa.
M3_S_PA_PER_DM3_S_BAR = 1e-8


def conductance_from_catalogue(dm3_per_s_bar: npt.ArrayLike) -> FloatArray:
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
    return value * M3_S_PA_PER_DM3_S_BAR


def iso6358_mass_flow(upstream_pa: npt.ArrayLike, downstream_pa: npt.ArrayLike,
                      conductance_m3_s_pa: npt.ArrayLike, critical_ratio: npt.ArrayLike,
                      temperature_k: npt.ArrayLike = ANR_TEMPERATURE_K) -> FloatArray:
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
    return mass_flow(upstream_pa, downstream_pa, conductance, critical_ratio, temperature_k)


def _positive(name: str, value: npt.ArrayLike, unit: str) -> FloatArray:
    array = real_array(name, value)
    return in_range(name, array, 0.0, np.inf, unit, low_open=True, high_open=True)


def mass_flow(from_pa: FloatOrArray, to_pa: FloatOrArray, conductance: FloatOrArray,
              critical_ratio: FloatOrArray, temperature_k: FloatOrArray) -> FloatArray:
    """:func:`iso6358_mass_flow` without the input checks, for an integrator's inner loop."""
    high = np.maximum(from_pa, to_pa)
    ratio = np.minimum(from_pa, to_pa) / high
    subsonic = np.clip((ratio - critical_ratio) / (1.0 - critical_ratio), 0.0, 1.0)
    free_air_m3_s = conductance * high * np.sqrt(1.0 - np.square(subsonic))
    mass_flow = free_air_m3_s * ANR_DENSITY_KG_M3 * np.sqrt(ANR_TEMPERATURE_K / temperature_k)
    return np.sign(from_pa - to_pa) * mass_flow
