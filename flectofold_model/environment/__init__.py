"""The world around the facade: where the sun is, and a simulated clock for a sped-up day.

- :mod:`.sun`: solar position and sun vectors by NREL's SPA (pvlib), sites and times;
- :mod:`.ephemeris`: the same sun vectors, computed a batch ahead on a time grid and kept;
- :mod:`.sim_clock`: wall seconds -> simulated time of a sped-up day;
- :mod:`.weather`: hourly weather (irradiance, wind, temperature) from EPW and TMY3 files.
"""

from flectofold_model.environment.ephemeris import SunEphemeris
from flectofold_model.environment.sim_clock import SimulatedClock
from flectofold_model.environment.sun import (angle_of_incidence_rad, day_epochs,
                                              enu_from_azimuth_elevation, epoch_from_iso, Site,
                                              solar_position, SolarPosition, STUTTGART,
                                              sun_vector_enu)
from flectofold_model.environment.weather import (into_reference_year, read_weather,
                                                  REFERENCE_YEAR, site_distance_deg, uncovered,
                                                  Weather, weather_at, WeatherError)

__all__ = [
    'STUTTGART', 'SimulatedClock', 'Site', 'SolarPosition', 'SunEphemeris',
    'angle_of_incidence_rad', 'day_epochs', 'enu_from_azimuth_elevation', 'epoch_from_iso',
    'solar_position', 'sun_vector_enu',
    'REFERENCE_YEAR', 'Weather', 'WeatherError', 'into_reference_year', 'read_weather',
    'site_distance_deg', 'uncovered', 'weather_at',
]
