"""A shoebox office behind a shading facade, as an EnergyPlus 25.2 epJSON document.

The room is one thermal zone, ``width_m`` wide along the facade, ``depth_m`` deep and
``height_m`` high. Only the facade wall is exterior; the other walls, the floor and the ceiling
are adiabatic, so the zone behaves like a mid-floor office between identical neighbours. The
facade wall holds one centred window (both its width and height are ``sqrt(window_to_wall)`` of
the wall's) with a ``WindowMaterial:SimpleGlazingSystem``. The facade is a
``Shading:Building:Detailed`` rectangle covering the whole wall, ``shade_offset_m`` in front of
it, whose transmittance schedule is a ``Schedule:Compact`` (value 1.0 in the file) that a
callback sets every zone time step through the runtime API (:func:`schedule_actuator`).

Facts the document relies on (EnergyPlus 25.2 Input Output Reference, and the tracker at
github.com/NatLabRockies/EnergyPlus, formerly NREL/EnergyPlus):

- a shading surface's transmittance schedule can be actuated as ``Schedule:Compact`` /
  ``Schedule Value`` since PR #10008 (issue #5185), which also stopped schedules that are 1.0
  throughout from being skipped as transparent when actuators or API callbacks exist;
  a ``Schedule:Constant`` gives a valid handle whose value is not used;
- shadows follow a changing value only if ``ShadowCalculation`` updates every time step
  (``Timestep``); with the default ``Periodic`` method the value present when the shadows are
  computed is used for the whole period (issue #3073 reports the same symptom);
- EnergyPlus treats a shading surface's transmittance as equal for solar and visible light and
  non-diffusing (I/O Reference, ``Shading:Building:Detailed``; quoted in issue #992);
- HVAC output variables are per system time step, so energies are read from ``eplusout.sql``
  rather than summed from API reads at zone time steps.

The actuation recipe, measured against static schedules on this model (Phoenix TMY3, weeks of
13-19 January and July, and a year): ``DetailedSkyDiffuseModeling``, ``Timestep`` shadows,
the ``Schedule:Compact`` at 1.0 in the file, and :func:`schedule_actuator` setting it every
zone time step *including warm-up*. It reproduces a static ``Schedule:Compact`` with the same
values exactly (every figure of :class:`RunFigures`) when the static schedule is 0.8 or more
from 0 to 1 h, and for some other schedules. Caveats measured:

- with ``SimpleSkyDiffuseModeling`` the sky diffuse shading is fixed when the run starts, from
  the file value, so an actuated facade admits too much diffuse (+19 to +74 % transmitted solar);
- a file value other than 1.0 fixes the sky diffuse shading at that value even with
  ``DetailedSkyDiffuseModeling``;
- not actuating during warm-up starts the period from a warm-up with the facade open
  (+12 to +25 % cooling over a January week);
- a *static* schedule's results depend on values it holds at night when its first hour is low:
  a schedule at 0.2 all day gives 14 % more cooling in January than one at 0.8 from 0 to 1 h
  and 0.2 otherwise, with equal solar figures. The actuated run matches the second.

Units: lengths in m, U in W/(m2 K), energies returned by :func:`run` in kWh, rates in W.
"""

import dataclasses
import datetime
import json
import math
import os
import sqlite3
import time
from typing import Any, Callable, Iterable, Mapping, Optional, Sequence, Union

import numpy as np

from flectofold_model._validate import FloatArray, PathLike

ZONE = 'Office'
WINDOW = 'Office Window'
FACADE_WALL = 'Office Facade Wall'
IDEAL_LOADS = 'Office Ideal Loads'
SHADE = 'Facade Shade'
#: The schedule of the window's ground reflectance seen through the facade.
GROUND_SCHEDULE = 'FacadeGroundReflectance'
#: Ground reflectance (EnergyPlus's default, ``Site:GroundReflectance`` not set) [-].
GROUND_ALBEDO = 0.2
TIMESTEPS_PER_HOUR = 6
DAYS_PER_YEAR = 365
#: ((begin month, day), (end month, day)) of a run, inclusive.
RunPeriod = tuple[tuple[int, int], tuple[int, int]]
#: A callback ``callback(api, state)`` of EnergyPlus's runtime API (its API object, the state).
Callback = Callable[[Any, Any], None]
#: A point (x, y, z) [m].
_Point = tuple[float, float, float]

#: Output variables: (name, key, reporting frequency).
OUTPUT_VARIABLES = (
    ('Enclosure Windows Total Transmitted Solar Radiation Energy', '*', 'Hourly'),
    ('Surface Window Heat Gain Energy', WINDOW, 'Hourly'),
    ('Surface Window Total Glazing Layers Absorbed Solar Radiation Energy', WINDOW, 'Hourly'),
    ('Surface Window Transmitted Solar Radiation Energy', WINDOW, 'Hourly'),
    ('Zone Ideal Loads Zone Sensible Cooling Energy', IDEAL_LOADS, 'Hourly'),
    ('Zone Ideal Loads Zone Sensible Heating Energy', IDEAL_LOADS, 'Hourly'),
    ('Zone Ideal Loads Zone Sensible Cooling Rate', IDEAL_LOADS, 'Timestep'),
    ('Zone Ideal Loads Zone Sensible Heating Rate', IDEAL_LOADS, 'Timestep'),
    ('Zone Lights Electricity Energy', ZONE, 'Hourly'),
    ('Daylighting Reference Point 1 Illuminance', ZONE + ' Daylighting', 'Hourly'),
    ('Site Direct Solar Radiation Rate per Area', 'Environment', 'Hourly'),
    ('Site Diffuse Solar Radiation Rate per Area', 'Environment', 'Hourly'),
    ('Site Solar Altitude Angle', 'Environment', 'Timestep'),
    ('Site Solar Azimuth Angle', 'Environment', 'Timestep'),
)


@dataclasses.dataclass(frozen=True)
class Room:
    """A shoebox office: geometry, glazing and internal gains, in SI units.

    ``azimuth_deg`` is the direction the facade faces, clockwise from north (180 = south).
    Internal gains apply weekdays from 8 to 18 h; the thermostat holds 21 to 24 C all the time.
    """

    width_m: float = 6.0
    depth_m: float = 6.0
    height_m: float = 3.5
    window_to_wall: float = 0.6
    glazing_u_w_m2k: float = 1.4
    glazing_shgc: float = 0.4
    glazing_vt: float = 0.6
    azimuth_deg: float = 180.0
    people_per_m2: float = 0.1
    equipment_w_m2: float = 10.0
    lighting_w_m2: float = 10.0
    heating_setpoint_c: float = 21.0
    cooling_setpoint_c: float = 24.0
    illuminance_setpoint_lx: float = 500.0
    workplane_height_m: float = 0.8

    def __post_init__(self) -> None:
        for name in ('width_m', 'depth_m', 'height_m', 'glazing_u_w_m2k'):
            if not getattr(self, name) > 0.0:
                raise ValueError(f'{name} must be positive, got {getattr(self, name)}')
        if not 0.0 < self.window_to_wall < 0.95:
            raise ValueError(f'window_to_wall must be in (0, 0.95), got {self.window_to_wall}')
        for name in ('glazing_shgc', 'glazing_vt'):
            if not 0.0 < getattr(self, name) < 1.0:
                raise ValueError(f'{name} must be in (0, 1), got {getattr(self, name)}')
        if self.glazing_u_w_m2k > 7.0:
            raise ValueError(f'glazing_u_w_m2k must be at most 7, got {self.glazing_u_w_m2k}')
        if not math.isfinite(self.azimuth_deg):
            raise ValueError(f'azimuth_deg must be finite, got {self.azimuth_deg}')
        for name in ('people_per_m2', 'equipment_w_m2', 'lighting_w_m2',
                     'illuminance_setpoint_lx'):
            if not getattr(self, name) >= 0.0:
                raise ValueError(f'{name} must not be negative, got {getattr(self, name)}')
        if not self.heating_setpoint_c < self.cooling_setpoint_c:
            raise ValueError('heating_setpoint_c must be below cooling_setpoint_c, got '
                             f'{self.heating_setpoint_c} and {self.cooling_setpoint_c}')
        if not 0.0 < self.workplane_height_m < self.height_m:
            raise ValueError(f'workplane_height_m must be in (0, height_m), got '
                             f'{self.workplane_height_m}')

    @property
    def window_width_m(self) -> float:
        """Width of the centred window [m]."""
        return self.width_m * math.sqrt(self.window_to_wall)

    @property
    def window_height_m(self) -> float:
        """Height of the centred window [m]."""
        return self.height_m * math.sqrt(self.window_to_wall)


@dataclasses.dataclass(frozen=True)
class RunFigures:
    """A run's totals over its run period, from ``eplusout.sql`` (warm-up excluded).

    Energies in kWh, ``peak_cooling_w`` the largest zone-time-step sensible cooling rate in W,
    ``elapsed_s`` the wall-clock time of the run in s.
    """

    cooling_kwh: float
    heating_kwh: float
    lighting_kwh: float
    transmitted_solar_kwh: float
    window_absorbed_kwh: float
    window_heat_gain_kwh: float
    peak_cooling_w: float
    elapsed_s: float
    monthly_kwh: dict = dataclasses.field(default_factory=dict)
    """``cooling``, ``heating``, ``lighting``: (12,) energy of each calendar month [kWh]."""


def _rotated(points: Iterable[_Point], azimuth_deg: float) -> list[_Point]:
    """World coordinates of room-frame points; the room frame's facade faces -y (south)."""
    phi = math.radians(azimuth_deg - 180.0)
    c, s = math.cos(phi), math.sin(phi)
    return [(x * c + y * s, -x * s + y * c, z) for x, y, z in points]


def _vertices(points: Iterable[_Point], azimuth_deg: float) -> list[dict[str, float]]:
    return [{'vertex_x_coordinate': round(x, 6), 'vertex_y_coordinate': round(y, 6),
             'vertex_z_coordinate': round(z, 6)} for x, y, z in _rotated(points, azimuth_deg)]


def _compact(values: Sequence[float], limits: str = 'Fraction') -> dict[str, Any]:
    """Build a ``Schedule:Compact`` from one value per time step of a year, runs merged."""
    per_day = TIMESTEPS_PER_HOUR * 24
    days = []
    for day in range(DAYS_PER_YEAR):
        steps = values[day * per_day:(day + 1) * per_day]
        runs: list[list[Any]] = []
        for index, value in enumerate(steps):
            if runs and runs[-1][1] == value:
                runs[-1][0] = index + 1
            else:
                runs.append([index + 1, value])
        days.append(tuple((end, value) for end, value in runs))
    data: list[Union[str, float]] = []
    for day, profile in enumerate(days):
        if day + 1 < DAYS_PER_YEAR and days[day + 1] == profile:
            continue
        date = datetime.date(2001, 1, 1) + datetime.timedelta(days=day)
        data += [f'Through: {date.month}/{date.day}', 'For: AllDays']
        for end, value in profile:
            minutes = end * 60 // TIMESTEPS_PER_HOUR
            data += [f'Until: {minutes // 60:02d}:{minutes % 60:02d}', float(value)]
    return {'schedule_type_limits_name': limits, 'data': [{'field': f} for f in data]}


def timestep_values(values: Iterable[float]) -> list[float]:
    """Return a year at the model time step from 8760 hourly or 52560 per-step values."""
    values = [float(v) for v in values]
    if len(values) == DAYS_PER_YEAR * 24:
        values = [v for v in values for _ in range(TIMESTEPS_PER_HOUR)]
    if len(values) != DAYS_PER_YEAR * 24 * TIMESTEPS_PER_HOUR:
        raise ValueError('static_schedule_values needs 8760 hourly or '
                         f'{DAYS_PER_YEAR * 24 * TIMESTEPS_PER_HOUR} per-time-step values, '
                         f'got {len(values)}')
    if not all(0.0 <= v <= 1.0 for v in values):
        raise ValueError('static_schedule_values must lie in [0, 1]')
    return values


def _day_schedule(on: Union[str, float], off: Union[str, float] = '0.0') -> dict[str, Any]:
    return {'schedule_type_limits_name': 'Fraction', 'data': [{'field': f} for f in (
        'Through: 12/31', 'For: Weekdays', 'Until: 08:00', float(off), 'Until: 18:00',
        float(on), 'Until: 24:00', float(off), 'For: AllOtherDays', 'Until: 24:00',
        float(off))]}


def _constant(value: float, limits: str = 'Any Number') -> dict[str, Any]:
    return {'schedule_type_limits_name': limits, 'data': [{'field': f} for f in (
        'Through: 12/31', 'For: AllDays', 'Until: 24:00', float(value))]}


def shoebox_epjson(room: Room = Room(), shade_schedule: str = 'FacadeTransmittance', *,
                   shade: bool = True, static_schedule_values: Optional[Iterable[float]] = None,
                   run_period: RunPeriod = ((1, 13), (1, 19)),
                   sky_diffuse: str = 'SimpleSkyDiffuseModeling', shade_offset_m: float = 0.3,
                   shade_margin_m: float = 0.0,
                   static_ground_values: Optional[Iterable[float]] = None) -> dict[str, Any]:
    """Return the epJSON document (a dict) of ``room`` behind a facade with a schedule.

    ``shade_schedule`` names the facade's ``Schedule:Compact`` transmittance schedule: 1.0
    throughout, or ``static_schedule_values`` (8760 hourly or 52560 ten-minute values from
    1 January, non-leap year) for a static reference. ``shade=False`` leaves the facade out.
    ``run_period`` is ((begin month, day), (end month, day)); ``sky_diffuse`` the
    ``ShadowCalculation`` sky diffuse modelling algorithm.
    """
    if sky_diffuse not in ('SimpleSkyDiffuseModeling', 'DetailedSkyDiffuseModeling'):
        raise ValueError(f'unknown sky_diffuse {sky_diffuse!r}')
    if not shade_offset_m > 0.0:
        raise ValueError(f'shade_offset_m must be positive, got {shade_offset_m}')
    if not shade_margin_m >= 0.0:
        raise ValueError(f'shade_margin_m must not be negative, got {shade_margin_m}')
    m = float(shade_margin_m)
    w, d, h, a = room.width_m, room.depth_m, room.height_m, room.azimuth_deg
    ww, wh = room.window_width_m, room.window_height_m
    x0, z0 = (w - ww) / 2.0, (h - wh) / 2.0
    (begin_month, begin_day), (end_month, end_day) = run_period

    def surface(kind: str, construction: str, boundary: str,
                points: Sequence[_Point]) -> dict[str, Any]:
        outdoors = boundary == 'Outdoors'
        return {'surface_type': kind, 'construction_name': construction, 'zone_name': ZONE,
                'outside_boundary_condition': boundary,
                'sun_exposure': 'SunExposed' if outdoors else 'NoSun',
                'wind_exposure': 'WindExposed' if outdoors else 'NoWind',
                'number_of_vertices': len(points), 'vertices': _vertices(points, a)}

    window: dict[str, Any]
    window = {'surface_type': 'Window', 'construction_name': 'Double Glazing',
              'building_surface_name': FACADE_WALL, 'number_of_vertices': 4}
    corners = ((x0, 0.0, z0 + wh), (x0, 0.0, z0), (x0 + ww, 0.0, z0), (x0 + ww, 0.0, z0 + wh))
    for index, (x, y, z) in enumerate(_rotated(corners, a), start=1):
        window[f'vertex_{index}_x_coordinate'] = round(x, 6)
        window[f'vertex_{index}_y_coordinate'] = round(y, 6)
        window[f'vertex_{index}_z_coordinate'] = round(z, 6)

    doc: dict[str, Any] = {
        'Version': {'Version 1': {'version_identifier': '25.2'}},
        'SimulationControl': {'SimulationControl 1': {
            'do_zone_sizing_calculation': 'No', 'do_system_sizing_calculation': 'No',
            'do_plant_sizing_calculation': 'No', 'run_simulation_for_sizing_periods': 'No',
            'run_simulation_for_weather_file_run_periods': 'Yes'}},
        'Building': {'Shoebox Office': {
            'north_axis': 0.0, 'terrain': 'City', 'solar_distribution': 'FullExterior',
            'loads_convergence_tolerance_value': 0.04,
            'temperature_convergence_tolerance_value': 0.4,
            'maximum_number_of_warmup_days': 25, 'minimum_number_of_warmup_days': 6}},
        'Timestep': {'Timestep 1': {'number_of_timesteps_per_hour': TIMESTEPS_PER_HOUR}},
        'GlobalGeometryRules': {'GlobalGeometryRules 1': {
            'starting_vertex_position': 'UpperLeftCorner',
            'vertex_entry_direction': 'Counterclockwise', 'coordinate_system': 'World',
            'daylighting_reference_point_coordinate_system': 'World'}},
        'ShadowCalculation': {'ShadowCalculation 1': {
            'shading_calculation_method': 'PolygonClipping',
            'shading_calculation_update_frequency_method': 'Timestep',
            'shading_calculation_update_frequency': 1,
            'maximum_figures_in_shadow_overlap_calculations': 15000,
            'polygon_clipping_algorithm': 'SutherlandHodgman',
            'sky_diffuse_modeling_algorithm': sky_diffuse}},
        'RunPeriod': {'Period': {
            'begin_month': begin_month, 'begin_day_of_month': begin_day,
            'end_month': end_month, 'end_day_of_month': end_day,
            'day_of_week_for_start_day': 'Monday',
            'use_weather_file_holidays_and_special_days': 'No',
            'use_weather_file_daylight_saving_period': 'No',
            'apply_weekend_holiday_rule': 'No', 'use_weather_file_rain_indicators': 'Yes',
            'use_weather_file_snow_indicators': 'Yes'}},
        'ScheduleTypeLimits': {
            'Fraction': {'lower_limit_value': 0.0, 'upper_limit_value': 1.0,
                         'numeric_type': 'Continuous'},
            'Any Number': {}},
        'Schedule:Compact': {
            'Occupancy': _day_schedule(1.0), 'Lighting': _day_schedule(1.0),
            'Equipment': _day_schedule(1.0), 'Activity': _constant(120.0),
            'Always On': _constant(1.0, 'Fraction'), 'Thermostat Type': _constant(4.0),
            'Heating Setpoint': _constant(room.heating_setpoint_c),
            'Cooling Setpoint': _constant(room.cooling_setpoint_c)},
        'Material': {
            'Concrete 200mm': {'roughness': 'MediumRough', 'thickness': 0.2,
                               'conductivity': 1.95, 'density': 2240.0,
                               'specific_heat': 900.0},
            'Insulation 120mm': {'roughness': 'MediumRough', 'thickness': 0.12,
                                 'conductivity': 0.035, 'density': 30.0,
                                 'specific_heat': 1400.0},
            'Gypsum 25mm': {'roughness': 'Smooth', 'thickness': 0.025, 'conductivity': 0.16,
                            'density': 800.0, 'specific_heat': 1090.0,
                            'solar_absorptance': 0.4, 'visible_absorptance': 0.4}},
        'WindowMaterial:SimpleGlazingSystem': {'Double Glazing Layer': {
            'u_factor': room.glazing_u_w_m2k,
            'solar_heat_gain_coefficient': room.glazing_shgc,
            'visible_transmittance': room.glazing_vt}},
        'Construction': {
            'Exterior Wall': {'outside_layer': 'Concrete 200mm', 'layer_2': 'Insulation 120mm',
                              'layer_3': 'Gypsum 25mm'},
            'Slab': {'outside_layer': 'Concrete 200mm'},
            'Partition': {'outside_layer': 'Gypsum 25mm'},
            'Double Glazing': {'outside_layer': 'Double Glazing Layer'}},
        'Zone': {ZONE: {'direction_of_relative_north': 0.0, 'x_origin': 0.0, 'y_origin': 0.0,
                        'z_origin': 0.0, 'multiplier': 1}},
        'BuildingSurface:Detailed': {
            FACADE_WALL: surface('Wall', 'Exterior Wall', 'Outdoors', (
                (0.0, 0.0, h), (0.0, 0.0, 0.0), (w, 0.0, 0.0), (w, 0.0, h))),
            'Office Back Wall': surface('Wall', 'Partition', 'Adiabatic', (
                (w, d, h), (w, d, 0.0), (0.0, d, 0.0), (0.0, d, h))),
            'Office Right Wall': surface('Wall', 'Partition', 'Adiabatic', (
                (w, 0.0, h), (w, 0.0, 0.0), (w, d, 0.0), (w, d, h))),
            'Office Left Wall': surface('Wall', 'Partition', 'Adiabatic', (
                (0.0, d, h), (0.0, d, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, h))),
            'Office Floor': surface('Floor', 'Slab', 'Adiabatic', (
                (0.0, 0.0, 0.0), (0.0, d, 0.0), (w, d, 0.0), (w, 0.0, 0.0))),
            'Office Ceiling': surface('Ceiling', 'Slab', 'Adiabatic', (
                (0.0, 0.0, h), (w, 0.0, h), (w, d, h), (0.0, d, h)))},
        'FenestrationSurface:Detailed': {WINDOW: window},
        'People': {'Office People': {
            'zone_or_zonelist_or_space_or_spacelist_name': ZONE,
            'number_of_people_schedule_name': 'Occupancy',
            'number_of_people_calculation_method': 'People/Area',
            'people_per_floor_area': room.people_per_m2, 'fraction_radiant': 0.3,
            'activity_level_schedule_name': 'Activity'}},
        'ElectricEquipment': {'Office Equipment': {
            'zone_or_zonelist_or_space_or_spacelist_name': ZONE,
            'schedule_name': 'Equipment', 'design_level_calculation_method': 'Watts/Area',
            'watts_per_floor_area': room.equipment_w_m2, 'fraction_radiant': 0.5}},
        'Lights': {'Office Lights': {
            'zone_or_zonelist_or_space_or_spacelist_name': ZONE, 'schedule_name': 'Lighting',
            'design_level_calculation_method': 'Watts/Area',
            'watts_per_floor_area': room.lighting_w_m2, 'fraction_radiant': 0.37,
            'fraction_visible': 0.18}},
        'Daylighting:Controls': {ZONE + ' Daylighting': {
            'zone_or_space_name': ZONE, 'daylighting_method': 'SplitFlux',
            'availability_schedule_name': 'Always On', 'lighting_control_type': 'Continuous',
            'minimum_input_power_fraction_for_continuous_or_continuousoff_dimming_control':
                0.3,
            'minimum_light_output_fraction_for_continuous_or_continuousoff_dimming_control':
                0.2,
            'glare_calculation_daylighting_reference_point_name': ZONE + ' Reference Point',
            'glare_calculation_azimuth_angle_of_view_direction_clockwise_from_zone_y_axis':
                90.0,
            'control_data': [{'daylighting_reference_point_name': ZONE + ' Reference Point',
                              'fraction_of_lights_controlled_by_reference_point': 1.0,
                              'illuminance_setpoint_at_reference_point':
                                  room.illuminance_setpoint_lx}]}},
        'Daylighting:ReferencePoint': {ZONE + ' Reference Point': dict(zip(
            ('x_coordinate_of_reference_point', 'y_coordinate_of_reference_point',
             'z_coordinate_of_reference_point'),
            (round(c, 6) for c in _rotated(((w / 2.0, d / 2.0, room.workplane_height_m),),
                                           a)[0])), zone_or_space_name=ZONE)},
        'ZoneHVAC:IdealLoadsAirSystem': {IDEAL_LOADS: {
            'zone_supply_air_node_name': 'Office Supply Inlet',
            'dehumidification_control_type': 'None', 'humidification_control_type': 'None'}},
        'ZoneHVAC:EquipmentList': {'Office Equipment List': {
            'load_distribution_scheme': 'SequentialLoad',
            'equipment': [{'zone_equipment_object_type': 'ZoneHVAC:IdealLoadsAirSystem',
                           'zone_equipment_name': IDEAL_LOADS,
                           'zone_equipment_cooling_sequence': 1,
                           'zone_equipment_heating_or_no_load_sequence': 1}]}},
        'ZoneHVAC:EquipmentConnections': {'Office Connections': {
            'zone_name': ZONE, 'zone_conditioning_equipment_list_name': 'Office Equipment List',
            'zone_air_inlet_node_or_nodelist_name': 'Office Supply Inlet',
            'zone_air_node_name': 'Office Air Node',
            'zone_return_air_node_or_nodelist_name': 'Office Return Outlet'}},
        'ZoneControl:Thermostat': {'Office Thermostat': {
            'zone_or_zonelist_name': ZONE, 'control_type_schedule_name': 'Thermostat Type',
            'control_1_object_type': 'ThermostatSetpoint:DualSetpoint',
            'control_1_name': 'Office Setpoints'}},
        'ThermostatSetpoint:DualSetpoint': {'Office Setpoints': {
            'heating_setpoint_temperature_schedule_name': 'Heating Setpoint',
            'cooling_setpoint_temperature_schedule_name': 'Cooling Setpoint'}},
        'Output:Variable': {f'Output {i}': {'key_value': key, 'variable_name': name,
                                            'reporting_frequency': frequency}
                            for i, (name, key, frequency) in enumerate(OUTPUT_VARIABLES)},
        'Output:SQLite': {'Output:SQLite 1': {'option_type': 'SimpleAndTabular'}},
    }
    if shade:
        if static_schedule_values is None:
            doc['Schedule:Compact'][shade_schedule] = _constant(1.0, 'Fraction')
        else:
            doc['Schedule:Compact'][shade_schedule] = _compact(
                timestep_values(static_schedule_values))
        # EnergyPlus lets ground-reflected light reach the window past shading surfaces
        # (FullExterior); the facade's share of it is a ground reflectance seen by the window.
        doc['Schedule:Compact'][GROUND_SCHEDULE] = (
            _constant(GROUND_ALBEDO, 'Fraction') if static_ground_values is None
            else _compact(timestep_values(static_ground_values)))
        doc['SurfaceProperty:GroundSurfaces'] = {'Window Ground': {'ground_surfaces': [{
            'ground_surface_name': 'Ground', 'ground_surface_view_factor': 0.5,
            'ground_surface_reflectance_schedule_name': GROUND_SCHEDULE}]}}
        doc['SurfaceProperty:LocalEnvironment'] = {'Window Environment': {
            'exterior_surface_name': WINDOW, 'ground_surfaces_object_name': 'Window Ground'}}
        doc['Shading:Building:Detailed'] = {SHADE: {
            'transmittance_schedule_name': shade_schedule, 'number_of_vertices': 4,
            'vertices': _vertices(((-m, -shade_offset_m, h + m), (-m, -shade_offset_m, -m),
                                   (w + m, -shade_offset_m, -m),
                                   (w + m, -shade_offset_m, h + m)), a)}}
    elif static_schedule_values is not None:
        raise ValueError('static_schedule_values needs shade=True')
    return doc


def schedule_actuator(values: Iterable[float], schedule_name: str = 'FacadeTransmittance',
                      during_warmup: bool = True) -> Callback:
    """Make a callback that sets ``schedule_name`` every zone time step from a year's values.

    ``values`` are as for :func:`shoebox_epjson`'s ``static_schedule_values``: the value of the
    time step that *ends* at a time, as a ``Schedule:Compact`` "Until:" reads it. Register the
    callback with :func:`run` (``begin_zone_timestep_before_init_heat_balance``). During
    warm-up (the first day repeated) it sets that day's values too when ``during_warmup``,
    as a static schedule would; otherwise the file value (1.0) applies until warm-up ends.
    """
    series = timestep_values(values)
    per_day = TIMESTEPS_PER_HOUR * 24
    handle: list[Optional[int]] = [None]

    def actuate(api: Any, state: Any) -> None:
        exchange = api.exchange
        if not exchange.api_data_fully_ready(state):
            return
        if not during_warmup and exchange.warmup_flag(state):
            return
        if handle[0] is None:
            handle[0] = found = exchange.get_actuator_handle(state, 'Schedule:Compact',
                                                             'Schedule Value', schedule_name)
            if found < 0:
                raise RuntimeError(f'no Schedule:Compact actuator named {schedule_name!r}')
        day = (exchange.day_of_year(state) - 1) % DAYS_PER_YEAR
        step = exchange.hour(state) * TIMESTEPS_PER_HOUR + exchange.zone_time_step_number(state)
        exchange.set_actuator_value(state, handle[0], series[day * per_day + step - 1])

    return actuate


def _sum(cursor: sqlite3.Cursor, name: str, key: Optional[str] = None,
         frequency: Optional[str] = None, aggregate: str = 'SUM') -> tuple[Any, int]:
    query = (f'SELECT {aggregate}(d.Value), COUNT(d.Value) FROM ReportData d '
             'JOIN ReportDataDictionary k ON d.ReportDataDictionaryIndex = '
             'k.ReportDataDictionaryIndex JOIN Time t ON d.TimeIndex = t.TimeIndex '
             'WHERE k.Name = ? AND (t.WarmupFlag IS NULL OR t.WarmupFlag = 0)')
    arguments = [name]
    if key is not None:
        query += ' AND upper(k.KeyValue) = upper(?)'
        arguments.append(key)
    if frequency is not None:
        query += ' AND k.ReportingFrequency = ?'
        arguments.append(frequency)
    value, count = cursor.execute(query, arguments).fetchone()
    if count == 0:
        raise LookupError(f'{name} ({key}) is not in the SQLite output')
    return value, count


def read_figures(sql_path: PathLike, elapsed_s: float = float('nan')) -> RunFigures:
    """Read the :class:`RunFigures` of a finished run from its ``eplusout.sql``."""
    joules_per_kwh = 3.6e6
    with sqlite3.connect(sql_path) as connection:
        cursor = connection.cursor()
        transmitted = _sum(cursor, 'Enclosure Windows Total Transmitted Solar Radiation Energy',
                           ZONE)[0]
        figures = {
            'cooling_kwh': _sum(cursor, 'Zone Ideal Loads Zone Sensible Cooling Energy',
                                IDEAL_LOADS)[0],
            'heating_kwh': _sum(cursor, 'Zone Ideal Loads Zone Sensible Heating Energy',
                                IDEAL_LOADS)[0],
            'lighting_kwh': _sum(cursor, 'Zone Lights Electricity Energy', ZONE)[0],
            'transmitted_solar_kwh': transmitted,
            'window_absorbed_kwh': _sum(
                cursor, 'Surface Window Total Glazing Layers Absorbed Solar Radiation Energy',
                WINDOW)[0],
            'window_heat_gain_kwh': _sum(cursor, 'Surface Window Heat Gain Energy',
                                         WINDOW)[0]}
        peak = _sum(cursor, 'Zone Ideal Loads Zone Sensible Cooling Rate', IDEAL_LOADS,
                    aggregate='MAX')[0]
        monthly = {kind: _monthly(cursor, name, key) / joules_per_kwh for kind, name, key in (
            ('cooling', 'Zone Ideal Loads Zone Sensible Cooling Energy', IDEAL_LOADS),
            ('heating', 'Zone Ideal Loads Zone Sensible Heating Energy', IDEAL_LOADS),
            ('lighting', 'Zone Lights Electricity Energy', ZONE))}
    return RunFigures(**{k: v / joules_per_kwh for k, v in figures.items()},
                      peak_cooling_w=peak, elapsed_s=elapsed_s, monthly_kwh=monthly)


def _monthly(cursor: sqlite3.Cursor, name: str, key: str) -> FloatArray:
    """(12,) sum of ``name`` (``key``) per calendar month, warm-up excluded [output units]."""
    rows = cursor.execute(
        'SELECT t.Month, SUM(d.Value) FROM ReportData d JOIN ReportDataDictionary k ON '
        'd.ReportDataDictionaryIndex = k.ReportDataDictionaryIndex JOIN Time t ON '
        'd.TimeIndex = t.TimeIndex WHERE k.Name = ? AND upper(k.KeyValue) = upper(?) AND '
        '(t.WarmupFlag IS NULL OR t.WarmupFlag = 0) GROUP BY t.Month', (name, key)).fetchall()
    monthly = np.zeros(12)
    for month, value in rows:
        monthly[int(month) - 1] = value
    return monthly


def run(document: Mapping[str, Any], epw: PathLike, outdir: PathLike,
        callback: Optional[Callback] = None, name: str = 'shoebox.epJSON') -> RunFigures:
    """Write ``document`` to ``outdir``, simulate it with ``epw`` and return its figures.

    Each run has its own EnergyPlus state. ``callback(api, state)``, if given, is called at
    every ``begin_zone_timestep_before_init_heat_balance`` (warm-up and sizing included).
    Raises RuntimeError when EnergyPlus fails (see ``outdir/eplusout.err``).
    """
    from pyenergyplus.api import EnergyPlusAPI

    os.makedirs(outdir, exist_ok=True)
    path = os.path.join(outdir, name)
    with open(path, 'w') as stream:
        json.dump(document, stream)
    api = EnergyPlusAPI()
    state = api.state_manager.new_state()
    try:
        api.runtime.set_console_output_status(state, False)
        if callback is not None:
            api.runtime.callback_begin_zone_timestep_before_init_heat_balance(
                state, lambda s: callback(api, s))
        start = time.perf_counter()
        status = api.runtime.run_energyplus(state, ['-w', epw, '-d', outdir, path])
        elapsed = time.perf_counter() - start
    finally:
        api.state_manager.delete_state(state)
    if status != 0:
        raise RuntimeError(f'EnergyPlus failed with status {status}; see '
                           f'{os.path.join(outdir, "eplusout.err")}')
    return read_figures(os.path.join(outdir, 'eplusout.sql'), elapsed)
