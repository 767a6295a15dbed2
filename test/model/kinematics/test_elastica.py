"""The closed-form elastica against independent numerical integration."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import fsolve

from flectofold_model.kinematics import elastica


def integrate_pinned_strip(end_rotation_rad, load_factor, length_m, stations):
    """Integrate ``phi'' = -(P/EI) sin(phi)`` from the left pin, where the moment is zero.

    Returns the slope, the curvature, x (from the left pin) and z (above the pin line) at
    ``stations``, arc lengths from the left pin.
    """
    load = load_factor / length_m**2

    def rhs(_s, y):
        phi, curvature, _x, _z = y
        return [curvature, -load * np.sin(phi), np.cos(phi), np.sin(phi)]

    solution = solve_ivp(rhs, (0.0, length_m), [end_rotation_rad, 0.0, 0.0, 0.0],
                         t_eval=stations, rtol=1e-12, atol=1e-14, method='DOP853')
    assert solution.success
    return solution.y


@pytest.mark.parametrize('end_rotation_deg', [5.0, 20.0, 45.0, 60.0, 90.0])
@pytest.mark.parametrize('length_m', [0.52, 1.0])
def test_closed_form_matches_ode_integration(end_rotation_deg, length_m):
    k = np.sin(np.radians(end_rotation_deg) / 2)
    stations = np.linspace(0.0, length_m, 41)
    slope, curvature, x, z = integrate_pinned_strip(
        np.radians(end_rotation_deg), elastica.load_factor_from_k(k), length_m, stations)
    shortening = elastica.shortening_from_k(k, length_m)
    assert x[-1] == pytest.approx(length_m - shortening, abs=1e-6)
    assert z[-1] == pytest.approx(0.0, abs=1e-6)
    assert np.max(z) == pytest.approx(elastica.sag_from_k(k, length_m), abs=1e-6)
    assert curvature[20] == pytest.approx(-elastica.peak_curvature_from_k(k, length_m),
                                          rel=1e-6)

    shape = elastica.elastica_shape(np.array([k]), np.array([length_m]),
                                    stations - length_m / 2)
    chord = length_m - shortening
    np.testing.assert_allclose(shape.x_m[0] + chord / 2, x, atol=1e-6)
    np.testing.assert_allclose(shape.z_m[0], z, atol=1e-6)
    np.testing.assert_allclose(shape.slope_rad[0], slope, atol=1e-6)


@pytest.mark.parametrize('end_rotation_deg, load, chord, sag', [
    (5.0, 9.879, 0.99810, 0.0278),
    (20.0, 10.022, 0.96973, 0.1097),
    (45.0, 10.674, 0.85066, 0.2343),
    (90.0, 13.750, 0.45695, 0.3814),
])
def test_reference_table(end_rotation_deg, load, chord, sag):
    """The check table of ``docs/references.md`` section 4, to its printed digits."""
    k = np.sin(np.radians(end_rotation_deg) / 2)
    assert elastica.load_factor_from_k(k) == pytest.approx(load, abs=1e-3)
    assert 1 - elastica.shortening_from_k(k, 1.0) == pytest.approx(chord, abs=1e-5)
    assert elastica.sag_from_k(k, 1.0) == pytest.approx(sag, abs=1e-4)


@pytest.mark.parametrize('shortening_m', [1e-4, 5e-3, 0.02, 0.08])
def test_inverse_matches_ode_shooting(shortening_m):
    """Find the elastica for a support displacement by shooting, without elliptic integrals."""
    length_m = 0.8

    def residual(unknowns):
        end_rotation, load_factor = unknowns
        _, _, x, z = integrate_pinned_strip(end_rotation, load_factor, length_m,
                                            np.array([0.0, length_m]))
        return [z[-1] / length_m, (x[-1] - (length_m - shortening_m)) / length_m]

    guess_k = np.sqrt(shortening_m / length_m)
    end_rotation, _ = fsolve(residual, [2 * np.arcsin(guess_k), np.pi**2], xtol=1e-13)
    k = elastica.k_from_shortening(shortening_m, length_m)
    assert float(k) == pytest.approx(np.sin(end_rotation / 2), rel=1e-6)


def test_round_trips_and_monotonicity():
    k = np.linspace(0.0, elastica.K_MAX, 200)
    length = np.full_like(k, 0.52)
    shortening = elastica.shortening_from_k(k, length)
    sag = elastica.sag_from_k(k, length)
    curvature = elastica.peak_curvature_from_k(k, length)
    for values in (shortening, sag, curvature):
        assert np.all(np.diff(values) > 0)
    np.testing.assert_allclose(elastica.k_from_shortening(shortening, length), k, atol=1e-9)
    np.testing.assert_allclose(elastica.k_from_sag(sag, length), k, atol=1e-12)
    np.testing.assert_allclose(elastica.k_from_peak_curvature(curvature, length), k, atol=1e-12)


def test_small_k_limits():
    k, length = 1e-3, 0.52
    assert elastica.shortening_from_k(k, length) == pytest.approx(length * k**2, rel=1e-5)
    curvature = elastica.peak_curvature_from_k(k, length)
    assert curvature == pytest.approx(2 * np.pi * k / length, rel=1e-5)
    shape = elastica.elastica_shape(np.array([0.0]), np.array([length]),
                                    np.linspace(-length / 2, length / 2, 11))
    np.testing.assert_allclose(shape.normalized_height[0],
                               np.cos(np.pi * np.linspace(-0.5, 0.5, 11)), atol=1e-15)
    np.testing.assert_allclose(shape.z_m, 0.0)


@pytest.mark.parametrize('function, bad, message', [
    (elastica.k_from_shortening, np.nan, 'finite'),
    (elastica.k_from_shortening, -1e-3, 'must lie in'),
    (elastica.k_from_shortening, 0.3, 'must lie in'),
    (elastica.k_from_sag, np.inf, 'finite'),
    (elastica.k_from_sag, 0.5, 'must lie in'),
    (elastica.k_from_peak_curvature, -0.1, 'must lie in'),
    (elastica.k_from_peak_curvature, 'a lot', 'real number'),
])
def test_inverse_rejects_bad_input(function, bad, message):
    with pytest.raises((ValueError, TypeError), match=message):
        function(bad, 0.52)
