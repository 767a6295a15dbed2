"""The cushion circuit of a panel: supply, valves, relief, tubing and sensor, in SI units.

The defaults describe a ~1 m^2 demonstrator panel working at 4-9 kPa gauge; the sources of the
published figures and the estimates are in ``docs/references.md`` sections 2 and 5.
"""

from dataclasses import dataclass

from flectofold_model._validate import real_fields
from flectofold_model.actuation.flow import (ANR_TEMPERATURE_K, ATMOSPHERIC_PRESSURE_PA,
                                             M3_S_PA_PER_DM3_S_BAR)


@dataclass(frozen=True)
class PlantParameters:
    """Valves, relief, tubing and sensor of one cushion circuit, in SI units.

    The defaults describe a ~1 m^2 demonstrator panel working at 4-9 kPa gauge
    (``docs/references.md`` sections 2 and 5). Values marked [estimate] are engineering
    guesses, not measurements of the demonstrator.
    """

    supply_pressure_pa: float = 151325.0
    """Absolute supply pressure upstream of the fill valve [Pa]; 0.5 bar gauge, the supply of
    the fill-time estimate in ``docs/references.md`` section 5."""
    fill_conductance_m3_s_pa: float = 0.5 * M3_S_PA_PER_DM3_S_BAR
    """Sonic conductance of the fully open fill valve [m^3/(s*Pa)]; 0.5 dm^3/(s*bar), the
    middle of the 0.05-1.0 dm^3/(s*bar) range of section 7 [estimate]."""
    vent_conductance_m3_s_pa: float = 0.5 * M3_S_PA_PER_DM3_S_BAR
    """Sonic conductance of the fully open vent valve [m^3/(s*Pa)]; 0.5 dm^3/(s*bar)
    [estimate]."""
    critical_ratio: float = 0.5
    """Critical pressure ratio ``b`` of every valve; typical of catalogue solenoid valves,
    0.528 for an ideal nozzle [estimate]."""
    leak_conductance_m3_s_pa: float = 0.0005 * M3_S_PA_PER_DM3_S_BAR
    """Conductance of the healthy circuit's leak to atmosphere [m^3/(s*Pa)]; 0.0005
    dm^3/(s*bar), about 1 Pa/s of pressure loss at 9 kPa gauge [estimate]."""
    relief_cracking_pa: float = 15e3
    """Gauge pressure at which the relief valve starts to open [Pa]; above the 4-9 kPa working
    range of the demonstrator [estimate]."""
    relief_full_open_pa: float = 18e3
    """Gauge pressure at which the relief valve is fully open [Pa] [estimate]."""
    relief_conductance_m3_s_pa: float = 2.0 * M3_S_PA_PER_DM3_S_BAR
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
    RK4 for the default valves and relief on a 2 L cushion. With ``integrator='adaptive'``
    (see :class:`PneumaticPlant`), the sub-step with a valve wide open and the shortest taken."""
    max_quiet_step_s: float = 0.25
    """Longest sub-step of a :class:`PneumaticPlant` with ``integrator='adaptive'`` [s], taken
    while only the leak (or a barely open valve) moves air; at least ``max_step_s``."""

    def __post_init__(self) -> None:
        real_fields(self)
        self._check_pressures()
        self._check_non_negative()

    def _check_pressures(self) -> None:
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

    def _check_non_negative(self) -> None:
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
    fill_conductance_m3_s_pa=1.0 * M3_S_PA_PER_DM3_S_BAR,
    vent_conductance_m3_s_pa=2.5 * M3_S_PA_PER_DM3_S_BAR)
