"""The mid-rib as a pinned Euler elastica driven by its support displacement.

An inextensible strip of length ``L`` pinned at both ends buckles into an elastica when the
supports B and C move toward each other. Everything follows in closed form from the elliptic
modulus ``k = sin(alpha / 2)``, with ``alpha`` the end rotation, ``K = K(k)`` and ``E = E(k)``
the complete elliptic integrals (scipy takes the parameter ``m = k**2``):

========================  ==============================
end shortening            ``Delta = 2 L (1 - E / K)``
mid-span sag              ``delta = k L / K``
peak curvature            ``kappa0 = 4 k K / L``
axial load / EI           ``P / EI = (2 K / L)**2``
========================  ==============================

The shape, with ``s`` the arc length from mid-span and ``lambda = 2 K / L``:
``x(s) = 2 E(am(lambda s) | m) / lambda - s`` along the chord,
``z(s) = (2 k / lambda) cn(lambda s | m)`` above the chord and the slope angle
``phi(s) = -2 asin(k sn(lambda s | m))``.
References: Levien, "The elastica: a mathematical history", UCB/EECS-2008-103;
Timoshenko & Gere, *Theory of Elastic Stability*.

All functions take and return numpy arrays that broadcast together (one value per panel, or
per panel and station); lengths in metres, angles in radians.
"""

from dataclasses import dataclass
from typing import Callable

import numpy as np
import numpy.typing as npt
from scipy.optimize.elementwise import find_root
from scipy.special import ellipe, ellipj, ellipk, elliprd, elliprf

from flectofold_model._validate import FloatArray, FloatOrArray, in_range, real_array

#: Largest end rotation the model accepts: beyond 90 degrees the strip is no longer a mid-rib.
MAX_END_ROTATION_RAD = np.pi / 2
#: Elliptic modulus at :data:`MAX_END_ROTATION_RAD`.
K_MAX = float(np.sin(MAX_END_ROTATION_RAD / 2))

_ROOT_TOLERANCES = {'xatol': 1e-15, 'xrtol': 4 * np.finfo(float).eps}
#: A forward map ``f(k, length_m)`` of the elastica.
_Forward = Callable[[FloatOrArray, FloatOrArray], FloatArray]


@dataclass(frozen=True)
class ElasticaShape:
    """The shape of pinned elasticas sampled at stations; arrays broadcast over panels."""

    x_m: np.ndarray
    """Position along the chord, from mid-span [m]."""
    z_m: np.ndarray
    """Height above the chord through the pins [m]."""
    slope_rad: np.ndarray
    """Slope angle ``phi`` of the tangent against the chord [rad]."""
    normalized_height: np.ndarray
    """``z / sag``, which stays defined at zero sag (``cos(pi s / L)`` there)."""


def shortening_from_k(k: FloatOrArray, length_m: FloatOrArray) -> FloatArray:
    """Support displacement ``Delta = 2 L (1 - E/K)`` [m] for elliptic modulus ``k``."""
    m = np.square(k)
    return 2.0 * length_m * (1.0 - ellipe(m) / ellipk(m))


def sag_from_k(k: FloatOrArray, length_m: FloatOrArray) -> FloatArray:
    """Mid-span sag ``delta = k L / K`` [m]."""
    return k * length_m / ellipk(np.square(k))


def peak_curvature_from_k(k: FloatOrArray, length_m: FloatOrArray) -> FloatArray:
    """Mid-span curvature ``kappa0 = 4 k K / L`` [1/m]; the curvature is zero at the pins."""
    return 4.0 * k * ellipk(np.square(k)) / length_m


def end_rotation_from_k(k: FloatOrArray) -> FloatArray:
    """End rotation ``alpha = 2 asin(k)`` [rad] of the strip at the pins."""
    return 2.0 * np.arcsin(k)


def load_factor_from_k(k: FloatOrArray) -> FloatArray:
    """``P L**2 / EI = 4 K**2``, the dimensionless axial load (``pi**2`` at first buckling)."""
    return 4.0 * np.square(ellipk(np.square(k)))


def k_from_shortening(shortening_m: npt.ArrayLike, length_m: npt.ArrayLike) -> FloatArray:
    """Invert :func:`shortening_from_k`: the modulus for a support displacement [m]."""
    return _checked_inverse(shortening_from_k, 'shortening_m', shortening_m, length_m)


def k_from_sag(sag_m: npt.ArrayLike, length_m: npt.ArrayLike) -> FloatArray:
    """Invert :func:`sag_from_k`: the modulus for a mid-span sag [m]."""
    return _checked_inverse(sag_from_k, 'sag_m', sag_m, length_m)


def k_from_peak_curvature(curvature_per_m: npt.ArrayLike,
                          length_m: npt.ArrayLike) -> FloatArray:
    """Invert :func:`peak_curvature_from_k`: the modulus for a mid-span curvature [1/m]."""
    return _checked_inverse(peak_curvature_from_k, 'curvature_per_m', curvature_per_m,
                            length_m)


def _checked_inverse(forward: _Forward, name: str, value: npt.ArrayLike,
                     length_m: npt.ArrayLike) -> FloatArray:
    """Check ``value`` lies within what ``forward`` reaches at ``K_MAX``, then invert it."""
    length_m = real_array('length_m', length_m)
    value = real_array(name, value)
    in_range(f'{name} / its limit', value / forward(K_MAX, length_m), 0.0, 1.0)
    return _invert(forward, value, length_m)


def _invert(forward: _Forward, target: FloatArray, length_m: FloatArray) -> FloatArray:
    """Solve ``forward(k, L) = target`` elementwise; every forward map is monotone in k."""
    target, length_m = np.broadcast_arrays(target, length_m)
    result = find_root(
        lambda k, t, length: forward(k, length) - t,
        (np.zeros_like(target), np.full_like(target, K_MAX)),
        args=(target, length_m),
        tolerances=_ROOT_TOLERANCES,
    )
    if not np.all(result.success):
        raise ArithmeticError('elastica inversion did not converge')
    return np.clip(result.x, 0.0, K_MAX)


def elastica_shape(k: npt.ArrayLike, length_m: npt.ArrayLike,
                   arc_length_m: npt.ArrayLike) -> ElasticaShape:
    """Sample pinned elasticas at arc lengths ``s`` measured from mid-span.

    ``k`` and ``length_m`` have one value per panel, shape ``(N,)``; ``arc_length_m`` has
    shape ``(N, n)`` or ``(n,)`` with values in ``[-L/2, L/2]``. Returns an
    :class:`ElasticaShape` of ``(N, n)`` arrays. The pins sit at ``z = 0`` and the strip bulges
    toward ``+z``.
    """
    k = np.asarray(k, dtype=np.float64)[..., None]
    length_m = np.asarray(length_m, dtype=np.float64)[..., None]
    m = np.square(k)
    wavenumber = 2.0 * ellipk(m) / length_m
    sn, cn, _dn, _amplitude = ellipj(wavenumber * arc_length_m, m)
    x_m = 2.0 * _incomplete_e_of_amplitude(sn, cn, m) / wavenumber - arc_length_m
    z_m = (2.0 * k / wavenumber) * cn
    slope_rad = -2.0 * np.arcsin(k * sn)
    return ElasticaShape(x_m=x_m, z_m=z_m, slope_rad=slope_rad, normalized_height=cn)


def _incomplete_e_of_amplitude(sn: FloatArray, cn: FloatArray, m: FloatArray) -> FloatArray:
    """``E(am(u) | m)`` from ``sn(u)`` and ``cn(u)`` for ``|u| <= K``, in Carlson's form.

    ``E(phi | m) = sin(phi) R_F(c, d, 1) - m sin(phi)**3 R_D(c, d, 1) / 3`` with
    ``c = cos(phi)**2`` and ``d = 1 - m sin(phi)**2`` (DLMF 19.25.9). Used instead of
    ``scipy.special.ellipeinc``, which jumps at isolated arguments (scipy issue 19498).
    """
    cos_squared = np.square(cn)
    delta_squared = 1.0 - m * np.square(sn)
    return (sn * elliprf(cos_squared, delta_squared, 1.0)
            - m * sn**3 * elliprd(cos_squared, delta_squared, 1.0) / 3.0)
