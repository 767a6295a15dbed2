"""Where the sun is: solar position and sun vectors for a facade site, from NREL's SPA.

The position comes from :func:`pvlib.solarposition.spa_python`, the Solar Position Algorithm
of Reda and Andreas (NREL/TP-560-34302), which is accurate to +-0.0003 deg for the years -2000
to 6000. Times are POSIX seconds (UTC); sites are geodetic latitude and longitude, north and
east positive.

Conventions:

* the azimuth is a *compass bearing*, as in pvlib: 0 = north, pi/2 = east, clockwise seen from
  above, in ``[0, 2 pi)``. It is not the REP-103 yaw of the direction, which is measured
  counter-clockwise from east: ``yaw = pi/2 - azimuth``;
* the elevation used for beam geometry is the *apparent* one, corrected for atmospheric
  refraction with the site's pressure and temperature. Near the horizon refraction lifts the
  sun by about 0.5 deg; at 40 deg elevation by about 0.02 deg;
* the sun vector is the unit vector from the site toward the sun in the site's ENU frame (x
  east, y north, z up, REP-103): ``s = (sin A cos h, cos A cos h, sin h)`` with ``A`` the
  azimuth and ``h`` the apparent elevation. It is returned at every time, also at night, when
  it points below the horizon (``z <= 0``) and there is no direct sun: mask it with
  :attr:`SolarPosition.above_horizon`.

Angles are in radians, lengths in m, pressures in Pa, temperatures in degC, except the inputs
that say ``_deg`` (site coordinates, as surveys and maps give them).
"""

from dataclasses import dataclass, fields
import datetime
import re

import numpy as np
import numpy.typing as npt
import pandas as pd
from pvlib.solarposition import spa_python

from flectofold_model._validate import (BoolArray, FloatArray, in_range, real_array, real_fields,
                                        real_scalar)

#: Seconds in a calendar day of a fixed-offset clock (no daylight-saving switch) [s].
SECONDS_PER_DAY = 86400.0

# The SPA's validity range, years -2000 to 6000 (proleptic Gregorian, UTC), in POSIX seconds.
_SPA_FIRST_S = float(np.datetime64('-2000-01-01T00:00:00', 's').astype(np.int64))
_SPA_END_S = float(np.datetime64('6001-01-01T00:00:00', 's').astype(np.int64))

_DATE = re.compile(r'\d{4}-\d{2}-\d{2}')


@dataclass(frozen=True)
class Site:
    """A place on Earth and its air: what the SPA needs besides the time.

    Every field is checked on construction; the error names the field.
    """

    latitude_deg: float
    """Geodetic latitude, north positive [deg], in ``[-90, 90]``."""
    longitude_deg: float
    """Longitude, east positive [deg], in ``[-180, 180]``."""
    elevation_m: float
    """Height of the site above mean sea level [m], in ``[-500, 9000]``."""
    pressure_pa: float = 101325.0
    """Mean air pressure at the site, for the refraction correction [Pa], in ``[25e3, 120e3]``;
    the standard atmosphere at sea level by default. Refraction scales with the pressure, so
    the 3 % a site 250 m high is off by moves the sun by under 0.02 deg even at the horizon;
    ``pvlib.atmosphere.alt2pres(elevation_m)`` gives the standard atmosphere's pressure at the
    site's height."""
    temperature_c: float = 12.0
    """Mean air temperature at the site, for the refraction correction [degC], in
    ``[-100, 100]``; 12 degC, pvlib's default, by default."""

    def __post_init__(self) -> None:
        real_fields(self)
        in_range('latitude_deg', np.asarray(self.latitude_deg), -90.0, 90.0, ' deg')
        in_range('longitude_deg', np.asarray(self.longitude_deg), -180.0, 180.0, ' deg')
        in_range('elevation_m', np.asarray(self.elevation_m), -500.0, 9000.0, ' m')
        if not 25e3 <= self.pressure_pa <= 120e3:
            raise ValueError(
                f'pressure_pa must lie in [25000, 120000] Pa, the air pressures of inhabited '
                f'heights, got {self.pressure_pa:g} Pa (give it in Pa, not hPa or mbar)')
        in_range('temperature_c', np.asarray(self.temperature_c), -100.0, 100.0, ' degC')


#: Central Stuttgart: 48.7784 deg N, 9.1800 deg E, 245 m above sea level, the city centre in
#: its valley basin. The city of the Flectofold demonstrator (BauBionik, Stuttgart 2017-18).
STUTTGART = Site(48.7784, 9.1800, 245.0)


@dataclass(frozen=True, eq=False)
class SolarPosition:
    """The sun seen from one site at ``T`` times: arrays of shape ``(T,)``, ``enu`` ``(T, 3)``.

    ``eq=False``: two positions compare by identity, since ``==`` on arrays is elementwise.
    """

    epoch_s: np.ndarray
    """The times, POSIX seconds (UTC) [s]."""
    azimuth_rad: np.ndarray
    """Compass bearing of the sun, clockwise from north, in ``[0, 2 pi)`` [rad]."""
    apparent_elevation_rad: np.ndarray
    """Elevation above the horizon, refraction-corrected: the one for beam geometry [rad]."""
    apparent_zenith_rad: np.ndarray
    """Zenith angle, refraction-corrected: ``pi/2 - apparent_elevation_rad`` [rad]."""
    geometric_elevation_rad: np.ndarray
    """Elevation without refraction, as the sun's centre would be seen without air [rad]."""
    enu: np.ndarray
    """Unit vectors from the site toward the sun in the site's ENU frame, shape ``(T, 3)``;
    built from the apparent elevation [-]."""

    def __post_init__(self) -> None:
        count = None
        for field in fields(self):
            value = real_array(field.name, getattr(self, field.name))
            expected = 2 if field.name == 'enu' else 1
            if value.ndim != expected or (field.name == 'enu' and value.shape[1] != 3):
                shape = '(T, 3)' if field.name == 'enu' else '(T,)'
                raise ValueError(f'{field.name} must have shape {shape}, got {value.shape}')
            if count is None:
                count = value.shape[0]
            elif value.shape[0] != count:
                raise ValueError(f'{field.name} has {value.shape[0]} times, epoch_s has {count}')
            object.__setattr__(self, field.name, value)

    def __len__(self) -> int:
        return self.epoch_s.shape[0]

    @property
    def above_horizon(self) -> BoolArray:
        """``True`` where the sun's apparent centre is above the horizon (direct sun), ``(T,)``."""
        return self.apparent_elevation_rad > 0.0


def solar_position(epoch_s: npt.ArrayLike, site: Site, delta_t_s: float = 67.0) -> SolarPosition:
    """Position of the sun seen from ``site`` at the times ``epoch_s``, by NREL's SPA.

    One vectorised call of :func:`pvlib.solarposition.spa_python` for all times.

    Parameters
    ----------
    epoch_s : float or array-like
        POSIX time(s) (UTC) [s], a scalar or a 1-D array, within the years -2000 to 6000.
    site : Site
        Where the sun is seen from, with the air pressure and temperature for refraction.
    delta_t_s : float, default 67.0
        ``TT - UT1``, the difference between terrestrial time and universal time [s]; 67 s
        is about right for the years 2000-2030 (63.8 s in 2000, 69.2 s in 2023); an error of
        1 s moves the sun by about 0.004 deg.

    Returns
    -------
    SolarPosition
        Arrays of shape ``(T,)`` (``T = 1`` for a scalar ``epoch_s``) and sun vectors of shape
        ``(T, 3)``.

    Raises
    ------
    TypeError
        If ``epoch_s`` or ``delta_t_s`` is not made of real numbers, or ``site`` is not a
        :class:`Site`.
    ValueError
        If a time is NaN, infinite or outside the SPA's years, or ``epoch_s`` has more than one
        dimension.
    """
    epochs = _epochs('epoch_s', epoch_s)
    if not isinstance(site, Site):
        raise TypeError(f'site must be a Site, got {type(site).__name__}')
    delta_t_s = real_scalar('delta_t_s', delta_t_s)
    times = pd.to_datetime(epochs, unit='s', utc=True)
    table = spa_python(times, site.latitude_deg, site.longitude_deg, altitude=site.elevation_m,
                       pressure=site.pressure_pa, temperature=site.temperature_c,
                       delta_t=delta_t_s)
    azimuth = np.radians(table['azimuth'].to_numpy(dtype=np.float64))
    elevation = np.radians(table['apparent_elevation'].to_numpy(dtype=np.float64))
    return SolarPosition(
        epoch_s=epochs,
        azimuth_rad=azimuth,
        apparent_elevation_rad=elevation,
        apparent_zenith_rad=np.radians(table['apparent_zenith'].to_numpy(dtype=np.float64)),
        geometric_elevation_rad=np.radians(table['elevation'].to_numpy(dtype=np.float64)),
        enu=_enu(azimuth, elevation))


def sun_vector_enu(epoch_s: npt.ArrayLike, site: Site, delta_t_s: float = 67.0) -> FloatArray:
    """Return the unit vectors toward the sun in the site's ENU frame, shape ``(T, 3)`` [-].

    Shorthand for ``solar_position(epoch_s, site, delta_t_s).enu``; see :func:`solar_position`
    for the parameters. The vectors point below the horizon (``z <= 0``) at night.
    """
    return solar_position(epoch_s, site, delta_t_s).enu


def enu_from_azimuth_elevation(azimuth_rad: npt.ArrayLike,
                               elevation_rad: npt.ArrayLike) -> FloatArray:
    """Return the ENU unit vector(s) of a compass azimuth and an elevation.

    Parameters
    ----------
    azimuth_rad : array-like
        Compass bearing, clockwise from north (0 = north, pi/2 = east) [rad].
    elevation_rad : array-like
        Elevation above the horizontal plane [rad], in ``[-pi/2, pi/2]``.

    Returns
    -------
    numpy.ndarray
        ``(sin A cos h, cos A cos h, sin h)``, shape ``broadcast(A, h).shape + (3,)`` [-].
    """
    azimuth = real_array('azimuth_rad', azimuth_rad)
    elevation = real_array('elevation_rad', elevation_rad)
    in_range('elevation_rad', elevation, -np.pi / 2, np.pi / 2, ' rad')
    return _enu(*np.broadcast_arrays(azimuth, elevation))


def _enu(azimuth: FloatArray, elevation: FloatArray) -> FloatArray:
    horizontal = np.cos(elevation)
    return np.stack([np.sin(azimuth) * horizontal, np.cos(azimuth) * horizontal,
                     np.sin(elevation)], axis=-1)


def angle_of_incidence_rad(sun_enu: npt.ArrayLike, normal_enu: npt.ArrayLike) -> FloatArray:
    """Angle between sun vectors and surface normals [rad], in ``[0, pi]``.

    Both inputs are normalised here, so their lengths do not matter (but must not be zero).
    An angle above ``pi/2`` means the sun is behind the surface. The angle is pure geometry:
    it does not know whether the sun is above the horizon.

    Broadcasting follows ``sun @ normal.T``:

    =================  =================  =============
    ``sun_enu``        ``normal_enu``     result
    =================  =================  =============
    ``(3,)``           ``(3,)``           scalar
    ``(T, 3)``         ``(3,)``           ``(T,)``
    ``(3,)``           ``(N, 3)``         ``(N,)``
    ``(T, 3)``         ``(N, 3)``         ``(T, N)``
    =================  =================  =============

    Parameters
    ----------
    sun_enu : array-like
        Directions toward the sun, ``(3,)`` or ``(T, 3)`` [-].
    normal_enu : array-like
        Outward surface normals in the same frame, ``(3,)`` or ``(N, 3)`` [-].

    Returns
    -------
    numpy.ndarray or float
        ``arccos(clip(s . n, -1, 1))`` of the unit vectors, shaped as in the table [rad].
    """
    sun = _unit_vectors('sun_enu', sun_enu)
    normal = _unit_vectors('normal_enu', normal_enu)
    return np.arccos(np.clip(np.matmul(sun, normal.T), -1.0, 1.0))


def _unit_vectors(name: str, value: npt.ArrayLike) -> FloatArray:
    vectors = real_array(name, value)
    if vectors.ndim not in (1, 2) or vectors.shape[-1] != 3:
        raise ValueError(f'{name} must have shape (3,) or (K, 3), got {vectors.shape}')
    length = np.linalg.norm(vectors, axis=-1, keepdims=True)
    if np.any(length == 0.0):
        raise ValueError(f'{name} contains a zero vector, which has no direction')
    return vectors / length


def _epochs(name: str, value: npt.ArrayLike) -> FloatArray:
    epochs = np.atleast_1d(real_array(name, value))
    if epochs.ndim != 1:
        raise ValueError(f'{name} must be a scalar or a 1-D array, got shape {epochs.shape}')
    try:
        in_range(name, epochs, _SPA_FIRST_S, _SPA_END_S, ' s', high_open=True)
    except ValueError as error:
        raise ValueError(f'{error}: the SPA holds for the years -2000 to 6000 only') from None
    return epochs


def epoch_from_iso(text: str) -> float:
    """POSIX seconds (UTC) of an ISO 8601 timestamp that carries its UTC offset [s].

    Parameters
    ----------
    text : str
        For example ``'2003-10-17T12:30:30-07:00'`` or ``'2026-06-21T05:00:00Z'``.

    Returns
    -------
    float
        Seconds since 1970-01-01T00:00:00Z [s].

    Raises
    ------
    TypeError
        If ``text`` is not a string.
    ValueError
        If ``text`` is not an ISO 8601 timestamp, or has no UTC offset: a local time without
        its offset is ambiguous.
    """
    if not isinstance(text, str):
        raise TypeError(f'text must be an ISO 8601 string, got {type(text).__name__}')
    try:
        moment = datetime.datetime.fromisoformat(text.strip())
    except ValueError:
        raise ValueError(f'text is not an ISO 8601 timestamp: {text!r}') from None
    if moment.utcoffset() is None:
        raise ValueError(
            f'text {text!r} has no UTC offset, so its time zone is ambiguous; append one, '
            f"for example '+02:00' or 'Z'")
    return moment.timestamp()


def day_epochs(date_iso: str, site_utc_offset_h: float, step_s: float) -> FloatArray:
    """POSIX times of one local calendar day, from midnight to the next midnight (exclusive).

    The clock keeps a fixed UTC offset, so the day is always 24 h long: give the offset the
    site's clock has on that date (e.g. 2.0 for CEST, 1.0 for CET).

    Parameters
    ----------
    date_iso : str
        The local date, ``'YYYY-MM-DD'``.
    site_utc_offset_h : float
        Local time minus UTC [h], in ``[-12, 14]``, the offsets in use on Earth.
    step_s : float
        Time between samples [s], in ``(0, 86400]``.

    Returns
    -------
    numpy.ndarray
        ``midnight + k * step_s`` for every ``k >= 0`` with ``k * step_s < 86400`` [s]:
        ``86400 / step_s`` samples when ``step_s`` divides a day.

    Raises
    ------
    TypeError
        If ``date_iso`` is not a string, or the offset or step is not a real number.
    ValueError
        If the date is not a valid ``'YYYY-MM-DD'`` date, or the offset or step is out of range.
    """
    if not isinstance(date_iso, str):
        raise TypeError(f"date_iso must be a 'YYYY-MM-DD' string, got {type(date_iso).__name__}")
    if not _DATE.fullmatch(date_iso):
        raise ValueError(f"date_iso must be a date as 'YYYY-MM-DD', got {date_iso!r}")
    try:
        date = datetime.date.fromisoformat(date_iso)
    except ValueError as error:
        raise ValueError(f'date_iso {date_iso!r} is not a calendar date: {error}') from None
    offset_h = real_scalar('site_utc_offset_h', site_utc_offset_h)
    in_range('site_utc_offset_h', np.asarray(offset_h), -12.0, 14.0, ' h')
    step_s = real_scalar('step_s', step_s)
    in_range('step_s', np.asarray(step_s), 0.0, SECONDS_PER_DAY, ' s', low_open=True)
    midnight_utc = datetime.datetime.combine(date, datetime.time(), datetime.timezone.utc)
    start_s = midnight_utc.timestamp() - offset_h * 3600.0
    count = int(np.ceil(SECONDS_PER_DAY / step_s))
    if (count - 1) * step_s >= SECONDS_PER_DAY:
        count -= 1
    return start_s + np.arange(count, dtype=np.float64) * step_s
