"""The actuated central part of a hexagonal panel: a developable cone over its centre point.

The cushion moves the centre point ``C`` along the triangle's normal by the rise ``d``. The
three spokes from ``C`` to the triangle vertices keep their length ``R`` (the sheet does not
stretch), so each vertex moves toward the centre by ``R - sqrt(R**2 - d**2)`` (Pythagoras, as
the paper has it) and every spoke tilts down by ``beta = asin(d / R)``.

The central part bends as a cone with apex ``C``: the flat point at polar angle ``theta`` and
radius ``rho`` goes to ``C + rho g(theta)``, with ``g`` a unit direction. The cone is
developable, and isometric to the flat sheet, exactly when ``g`` runs at unit speed on the unit
sphere, ``|g'(theta)| = 1``. Between two spokes (sector angle ``phi`` from 0 to 2 pi / 3) this
module takes the ruling elevation

    e(phi) = -beta + A (1 - cos 3 phi) / 2

(smooth across the spokes, symmetric about each flap's mid-azimuth) and the azimuth that
unit speed leaves, ``a'(phi) = sqrt(1 - e'(phi)**2) / cos e(phi)``. The amplitude ``A`` is the
one that turns each sector by exactly 2 pi / 3, so the three sectors close around the centre;
:func:`cone_amplitude_rad` finds it by Newton's method (the turn falls strictly as ``A``
grows).

A cone is the shape a thin sheet takes when one point is pushed out of its plane (a
developable cone, Cerda & Mahadevan 1998); its curvature ``kappa_g(phi) / rho`` grows toward the
apex, where a real sheet forms a small core.
"""

import math

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import FloatArray
from flectofold_model.kinematics.hexagon_panel import HexagonBatch, SECTOR_RAD

_NODES, _WEIGHTS = np.polynomial.legendre.leggauss(48)
#: Largest amplitude for which the unit-speed condition can hold (``|e'| <= 1``).
MAX_AMPLITUDE_RAD = 2.0 / 3.0


def spoke_tilt_rad(batch: HexagonBatch, rise_m: npt.ArrayLike) -> FloatArray:
    """Downward tilt ``asin(d / R)`` of the spokes [rad]."""
    return np.arcsin(np.asarray(rise_m, dtype=np.float64) / batch.circumradius_m)


def vertex_displacement_m(batch: HexagonBatch, rise_m: npt.ArrayLike) -> FloatArray:
    """Inward travel ``R - sqrt(R**2 - d**2)`` of each triangle vertex [m] (Pythagoras)."""
    radius = batch.circumradius_m
    return radius - np.sqrt(radius ** 2 - np.square(rise_m))


def _elevation(tilt: FloatArray, amplitude: FloatArray, phi: FloatArray) -> FloatArray:
    return -tilt + amplitude * (1.0 - np.cos(3.0 * phi)) / 2.0


def _elevation_rate(amplitude: FloatArray, phi: FloatArray) -> FloatArray:
    return 1.5 * amplitude * np.sin(3.0 * phi)


def _azimuth_rate(tilt: FloatArray, amplitude: FloatArray, phi: FloatArray) -> FloatArray:
    rate = _elevation_rate(amplitude, phi)
    return np.sqrt(np.clip(1.0 - rate ** 2, 0.0, None)) / np.cos(_elevation(tilt, amplitude, phi))


def sector_turn_rad(tilt: npt.ArrayLike, amplitude: npt.ArrayLike) -> FloatArray:
    """Azimuth one sector turns through for spoke tilts and amplitudes (broadcast) [rad]."""
    phi = (_NODES + 1.0) * SECTOR_RAD / 2.0
    rate = _azimuth_rate(np.asarray(tilt)[..., None], np.asarray(amplitude)[..., None], phi)
    return np.sum(rate * _WEIGHTS, axis=-1) * SECTOR_RAD / 2.0


def _turn_and_slope(tilt: FloatArray, amplitude: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Sector turn [rad] and its derivative in the amplitude, for tilts and amplitudes (N,)."""
    phi = (_NODES + 1.0) * SECTOR_RAD / 2.0
    tilt, amplitude = tilt[:, None], amplitude[:, None]
    elevation = _elevation(tilt, amplitude, phi)
    weight = (1.0 - np.cos(3.0 * phi)) / 2.0
    wobble = 1.5 * np.sin(3.0 * phi)
    root = np.sqrt(np.clip(1.0 - (amplitude * wobble) ** 2, 1e-300, None))
    rate = root / np.cos(elevation)
    slope = (-amplitude * wobble ** 2 / root + root * np.tan(elevation) * weight) \
        / np.cos(elevation)
    scale = SECTOR_RAD / 2.0
    return np.sum(rate * _WEIGHTS, -1) * scale, np.sum(slope * _WEIGHTS, -1) * scale


def cone_amplitude_rad(tilt_rad: npt.ArrayLike) -> FloatArray:
    """Elevation amplitude ``A`` that closes the cone for spoke tilts (N,) [rad].

    Newton's method from ``A = 2 beta / 3`` (the turn falls smoothly and strictly with ``A``);
    bisection takes over for any tilt where Newton does not settle to rounding.
    """
    tilt = np.atleast_1d(np.asarray(tilt_rad, dtype=np.float64))
    if np.any(sector_turn_rad(tilt, np.full_like(tilt, MAX_AMPLITUDE_RAD)) > SECTOR_RAD):
        raise ValueError('the spokes tilt too far for a developable cone to close')
    amplitude = 2.0 * tilt / 3.0
    for _ in range(8):
        turn, slope = _turn_and_slope(tilt, amplitude)
        step = np.where(slope != 0.0, (turn - SECTOR_RAD) / np.where(slope != 0.0, slope, 1.0),
                        0.0)
        amplitude = np.clip(amplitude - step, 0.0, MAX_AMPLITUDE_RAD)
    unsettled = ~(np.abs(_turn_and_slope(tilt, amplitude)[0] - SECTOR_RAD) <= 1e-13)
    if np.any(unsettled):
        amplitude[unsettled] = _bisected_amplitude(tilt[unsettled])
    return amplitude.reshape(np.shape(tilt_rad))


def _bisected_amplitude(tilt: FloatArray, iterations: int = 60) -> FloatArray:
    low, high = np.zeros_like(tilt), np.full_like(tilt, MAX_AMPLITUDE_RAD)
    for _ in range(iterations):
        middle = (low + high) / 2.0
        too_long = sector_turn_rad(tilt, middle) > SECTOR_RAD
        low, high = np.where(too_long, middle, low), np.where(too_long, high, middle)
    return (low + high) / 2.0


def ruling_direction(tilt: npt.ArrayLike, amplitude: npt.ArrayLike,
                     phi: npt.ArrayLike) -> FloatArray:
    """Return the unit ruling directions (N, P, 3) at sector angles ``phi`` (P,) of sector 0.

    Sector 0 starts at the spoke to ``T_0`` (azimuth 90 degrees). The azimuth is integrated by
    Gauss-Legendre quadrature from the spoke to each ``phi``.
    """
    tilt, amplitude = np.asarray(tilt)[:, None], np.asarray(amplitude)[:, None]
    phi = np.asarray(phi, dtype=np.float64)
    nodes = (_NODES[:, None] + 1.0) * phi[None, :] / 2.0
    rate = _azimuth_rate(tilt[..., None], amplitude[..., None], nodes[None])
    azimuth = math.pi / 2 + np.sum(rate * _WEIGHTS[:, None], axis=-2) * phi / 2.0
    elevation = _elevation(tilt, amplitude, phi)
    return _direction(azimuth, elevation)


def ruling_direction_rate(tilt: npt.ArrayLike, amplitude: npt.ArrayLike,
                          phi: FloatArray) -> FloatArray:
    """``dg / dphi`` (N, P, 3), a unit vector along the cone's cross-section."""
    tilt, amplitude = np.asarray(tilt)[:, None], np.asarray(amplitude)[:, None]
    direction = ruling_direction(tilt[:, 0], amplitude[:, 0], phi)
    elevation = _elevation(tilt, amplitude, phi)
    azimuth = np.arctan2(direction[..., 1], direction[..., 0])
    d_elevation = _elevation_rate(amplitude, phi)
    d_azimuth = _azimuth_rate(tilt, amplitude, phi)
    return np.stack([
        -np.sin(elevation) * np.cos(azimuth) * d_elevation
        - np.cos(elevation) * np.sin(azimuth) * d_azimuth,
        -np.sin(elevation) * np.sin(azimuth) * d_elevation
        + np.cos(elevation) * np.cos(azimuth) * d_azimuth,
        np.cos(elevation) * d_elevation], axis=-1)


def _direction(azimuth: FloatArray, elevation: FloatArray) -> FloatArray:
    return np.stack([np.cos(elevation) * np.cos(azimuth), np.cos(elevation) * np.sin(azimuth),
                     np.sin(elevation)], axis=-1)


def discrete_ruling_directions(tilt: npt.ArrayLike, intervals: int) -> FloatArray:
    """Ruling directions (N, intervals + 1, 3) of a polyhedral cone that closes exactly.

    The rulings sit at ``intervals`` equal flat angles across sector 0. Consecutive rulings make
    exactly that flat angle in space (so every mesh triangle keeps its flat edge lengths) and
    the elevations follow the smooth profile, with an amplitude solved for this discretisation
    so the sector turns by exactly 2 pi / 3. It tends to the smooth cone as the rulings get
    denser.
    """
    tilt = np.asarray(tilt, dtype=np.float64)
    phi = np.linspace(0.0, SECTOR_RAD, intervals + 1)
    step = SECTOR_RAD / intervals

    def turns(amplitude: FloatArray) -> tuple[FloatArray, FloatArray]:
        elevation = _elevation(tilt[:, None], amplitude[:, None], phi)
        sin_e, cos_e = np.sin(elevation), np.cos(elevation)
        cosine = (math.cos(step) - sin_e[:, :-1] * sin_e[:, 1:]) / (cos_e[:, :-1] * cos_e[:, 1:])
        return elevation, np.arccos(np.clip(cosine, -1.0, 1.0))

    low, high = np.zeros_like(tilt), np.full_like(tilt, MAX_AMPLITUDE_RAD)
    for _ in range(60):
        middle = (low + high) / 2.0
        too_long = np.sum(turns(middle)[1], axis=-1) > SECTOR_RAD
        low, high = np.where(too_long, middle, low), np.where(too_long, high, middle)
    elevation, turn = turns((low + high) / 2.0)
    azimuth = math.pi / 2 + np.concatenate([np.zeros_like(tilt)[:, None],
                                            np.cumsum(turn, axis=-1)], axis=-1)
    azimuth[:, -1] = math.pi / 2 + SECTOR_RAD
    return _direction(azimuth, elevation)
