"""The static actuation of hexagonal panels: energy, cushion, pressure map, validation."""

import dataclasses
import math
import warnings

import numpy as np
import pytest

from flectofold_model.actuation import (actuated_like, actuation_model_of, ActuationModel,
                                        DEMONSTRATOR_ACTUATED, DEMONSTRATOR_PLANT,
                                        HEXAGON_ACTUATED, HexagonActuationModel, Laminate,
                                        RoundCushion, UnreachableClosureWarning)
from flectofold_model.actuation.analysis import holding_gauge_pa
from flectofold_model.actuation.hexagon_statics import (d_cone_core_radius_m,
                                                        geodesic_curvature, inner_radius_m)
from flectofold_model.kinematics import DEMONSTRATOR_MODULE, HEXAGON_MODULE, HexagonPanel
from flectofold_model.kinematics.hexagon_reflection import SectorGeometry

NEGLIGIBLE = Laminate(thickness_m=1e-7)


@pytest.fixture(scope='module')
def model():
    return HexagonActuationModel([HEXAGON_ACTUATED])


@pytest.fixture(scope='module')
def quad():
    return ActuationModel([DEMONSTRATOR_ACTUATED])


def path(model, count):
    """Centre rises (count,) from open to closed of the model's one panel."""
    return np.linspace(model.fold.open_shape[0], model.fold.closed_shape[0], count)


def along(model, function, rises):
    """``function(rises, index)`` of the model's one panel at many rises at once."""
    return function(rises, np.zeros(rises.size, dtype=np.intp))


def test_preset_closes_beside_the_quad_demonstrator_within_the_plants_reach(model, quad):
    closed = model.closed_pressure_pa[0]
    assert 4e3 <= closed <= 9e3  # the quad demonstrator's published working range
    assert closed == pytest.approx(quad.closed_pressure_pa[0], rel=0.25)
    assert closed < 0.75 * holding_gauge_pa(DEMONSTRATOR_PLANT)
    assert model.actuation_energy_j[0] > 0


def test_pressure_rises_from_zero_and_inverts(model):
    closures = np.linspace(0.0, 1.0, 41)
    pressures = np.array([model.pressure_from_closure(c)[0] for c in closures])
    assert pressures[0] == pytest.approx(0.0, abs=1e-5)
    assert np.all(np.diff(pressures) > 0)
    back = np.array([model.closure_from_pressure(p)[0] for p in pressures[1:-1]])
    np.testing.assert_allclose(back, closures[1:-1], atol=1e-9)
    assert model.pressure_from_closure(1.0)[0] == pytest.approx(model.closed_pressure_pa[0])


def test_pressure_beyond_the_stops_rests_on_them(model):
    np.testing.assert_allclose(model.closure_from_pressure(-500.0), 0.0, atol=1e-12)
    np.testing.assert_allclose(model.closure_from_pressure(1e6), 1.0, atol=1e-12)
    np.testing.assert_allclose(model.rise_from_pressure(1e6), model.fold.closed_shape)


def test_equilibrium_is_stable_along_the_path(model):
    for closure in np.linspace(0.0, 1.0, 11):
        rise = model.fold.state_from_closure(closure).shape_parameter
        assert np.all(model.stiffness_at_shape(rise, model.pressure_from_shape(rise)) > 0)


def test_cushion_work_equals_stored_energy(model):
    """Virtual work: integral of p dV from open to closed equals the elastic energy stored."""
    rises = path(model, 4001)
    pressure, volume = along(model, model.pressure, rises), along(model, model.volume, rises)
    work = np.sum((pressure[1:] + pressure[:-1]) / 2 * np.diff(volume))
    assert work == pytest.approx(model.actuation_energy_j[0], rel=2e-4)


def test_cushion_volume_grows_with_closure(model):
    rises = path(model, 201)
    volume = along(model, model.volume, rises)
    assert np.all(np.diff(volume) > 0)
    contact = model.cushion_contact_area_m2(model.fold.closed_shape)
    assert 0 < contact[0] < model.cushion_contact_area_m2(model.fold.open_shape)[0]


def test_open_cushion_is_the_parallel_plate_pouch(model):
    """Open, the gap is the mount gap everywhere: a flat pouch with a half-round rim."""
    cushion = HEXAGON_ACTUATED.cushion
    gap = cushion.mount_gap_m
    contact = cushion.flat_radius_m - math.pi * gap / 4
    expected = (math.pi * contact**2 * gap + math.pi**2 * contact * gap**2 / 4
                + math.pi * gap**3 / 6)
    volume = model.cushion_volume_m3(model.fold.open_shape)[0]
    assert volume == pytest.approx(expected, rel=1e-12)


def test_geodesic_curvature_matches_the_spherical_curve_formula(model):
    """Independent check of ``det(g, g', g'')`` against the latitude-longitude formula.

    A unit-speed curve on the sphere at elevation ``e(phi)`` has geodesic curvature
    ``e'' / sqrt(1 - e'**2) + tan(e) sqrt(1 - e'**2)``; the cone's elevation is
    ``-beta + A (1 - cos 3 phi) / 2`` (the kinematic model's ruling profile).
    """
    rise = model.fold.state_from_closure(0.7).shape_parameter
    geometry = SectorGeometry(model.batch, rise)
    phi = np.linspace(0.05, 2 * math.pi / 3 - 0.05, 17)
    beta, amplitude = geometry.tilt_rad[0], geometry.amplitude_rad[0]
    elevation = -beta + amplitude * (1 - np.cos(3 * phi)) / 2
    rate, second = 1.5 * amplitude * np.sin(3 * phi), 4.5 * amplitude * np.cos(3 * phi)
    root = np.sqrt(1 - rate**2)
    expected = second / root + np.tan(elevation) * root
    np.testing.assert_allclose(np.abs(geodesic_curvature(geometry, phi)[0]), np.abs(expected),
                               atol=1e-7)


def isolated(**laminates):
    """Build the preset's model with every laminate but the named ones made negligible."""
    rest = {name: NEGLIGIBLE for name in ('midrib', 'flap', 'hinge') if name not in laminates}
    return HexagonActuationModel([dataclasses.replace(HEXAGON_ACTUATED, **laminates, **rest)])


def test_cone_bending_energy_matches_an_independent_area_integral():
    """``1/2 D integral (dkappa_g / r)**2 dA`` over the cone from the core to the crease.

    Summed by a fine trapezoid rule in ``r`` and ``phi`` over a whole sector (the model uses
    Gauss nodes on a half-sector and the closed-form ``ln`` of the radial integral).
    """
    model = isolated(midrib=HEXAGON_ACTUATED.midrib)
    rise = model.fold.state_from_closure(0.6).shape_parameter
    phi = np.linspace(0.0, 2 * math.pi / 3, 2401)
    opened = SectorGeometry(model.batch, model.fold.open_shape)
    change = (geodesic_curvature(SectorGeometry(model.batch, rise), phi)
              - geodesic_curvature(opened, phi))[0]
    crease = opened.crease_radius_m(phi)[0]
    fraction = np.linspace(0.0, 1.0, 801)
    core = HEXAGON_ACTUATED.core_radius_m
    radius = core + fraction[:, None] * (crease - core)
    radial = np.trapezoid(1.0 / radius, radius, axis=0)
    expected = 3 * 0.5 * HEXAGON_ACTUATED.midrib.plate_stiffness_nm * np.trapezoid(
        change**2 * radial, phi)
    assert model.elastic_energy_j(rise)[0] == pytest.approx(expected, rel=2e-4)


def test_hinge_energy_matches_an_independent_line_integral():
    """``1/2 (D_h / b) integral drho**2 dl`` along the three creases, by polyline length."""
    model = isolated(hinge=HEXAGON_ACTUATED.hinge)
    rise = model.fold.state_from_closure(0.8).shape_parameter
    phi = np.linspace(0.0, 2 * math.pi / 3, 4001)
    opened = SectorGeometry(model.batch, model.fold.open_shape)
    crease = opened.crease_radius_m(phi)[0]
    points = crease[:, None] * np.stack([np.cos(phi), np.sin(phi)], axis=-1)
    length = np.linalg.norm(np.diff(points, axis=0), axis=-1)
    change = (SectorGeometry(model.batch, rise).fold_angle_rad(phi)
              - opened.fold_angle_rad(phi))[0]
    mean_square = (change[1:]**2 + change[:-1]**2) / 2
    stiffness = HEXAGON_ACTUATED.hinge.plate_stiffness_nm / HEXAGON_MODULE.hinge_width_m
    expected = 3 * 0.5 * stiffness * np.sum(mean_square * length)
    assert model.elastic_energy_j(rise)[0] == pytest.approx(expected, rel=1e-4)


def test_open_state_is_stress_free_and_energy_grows(model):
    rises = path(model, 51)
    energy = along(model, model.energy, rises)
    assert energy[0] == pytest.approx(0.0, abs=1e-12)
    assert np.all(np.diff(energy) > 0)


def test_shape_table_agrees_with_the_fold_model(model):
    closures = np.array([0.0, 0.1, 0.55, 0.9, 1.0])
    rise, fold_angle = model.shape_table(closures)
    for column, closure in enumerate(closures):
        state = model.fold.state_from_closure(closure)
        assert rise[0, column] == pytest.approx(state.shape_parameter[0], abs=1e-12)
        assert fold_angle[0, column] == pytest.approx(state.apex_fold_angle_rad[0], abs=1e-12)


def test_supply_short_of_the_closed_pressure_warns(model):
    with pytest.warns(UnreachableClosureWarning, match='closing it needs'):
        reachable = model.reachable_closure(0.5 * model.closed_pressure_pa[0])
    assert 0.0 < reachable[0] < 1.0
    with warnings.catch_warnings():
        warnings.simplefilter('error')
        supply = holding_gauge_pa(DEMONSTRATOR_PLANT)
        np.testing.assert_allclose(model.reachable_closure(supply), 1.0)


def test_actuated_like_and_the_model_factory_follow_the_panel_kind(model):
    assert actuated_like(HEXAGON_MODULE) == HEXAGON_ACTUATED
    assert actuated_like(DEMONSTRATOR_MODULE) == DEMONSTRATOR_ACTUATED
    assert isinstance(actuation_model_of([actuated_like(HEXAGON_MODULE)]),
                      HexagonActuationModel)
    assert isinstance(actuation_model_of([actuated_like(DEMONSTRATOR_MODULE)]), ActuationModel)
    bigger = HexagonPanel(circumradius_m=0.7, fold_line_sag_m=0.06, hinge_width_m=0.03,
                          prefold_rad=math.radians(5.0))
    other = HexagonActuationModel([actuated_like(bigger), HEXAGON_ACTUATED])
    assert other.closed_pressure_pa[1] == pytest.approx(model.closed_pressure_pa[0])
    assert other.actuation_energy_j[0] > other.actuation_energy_j[1]


def build_panel(**changes):
    return dataclasses.replace(HEXAGON_ACTUATED, **changes)


@pytest.mark.parametrize('build, error, message', [
    (lambda: Laminate(thickness_m=float('nan')), ValueError, 'thickness_m must be finite'),
    (lambda: Laminate(thickness_m=-0.002), ValueError, 'thickness_m must be positive'),
    (lambda: RoundCushion(flat_radius_m=-0.1), ValueError, 'flat_radius_m must be positive'),
    (lambda: RoundCushion(flat_radius_m=float('nan')), ValueError,
     'flat_radius_m must be finite'),
    (lambda: RoundCushion(flat_radius_m=0.1, mount_gap_m=0.2), ValueError,
     'mount_gap_m must lie in'),
    (lambda: build_panel(cushion=RoundCushion(0.4)), ValueError,
     'larger than the central part'),
    (lambda: build_panel(core_radius_m=float('nan')), ValueError,
     'core_radius_m must be finite'),
    (lambda: build_panel(core_radius_m=0.0), ValueError, 'core_radius_m must lie in'),
    (lambda: build_panel(core_radius_m=0.5), ValueError, 'core_radius_m must lie in'),
    (lambda: build_panel(core_radius_m='0.1'), TypeError, 'core_radius_m must be a real'),
    (lambda: build_panel(geometry=DEMONSTRATOR_MODULE), TypeError,
     'geometry must be a HexagonPanel'),
    (lambda: build_panel(cushion=DEMONSTRATOR_ACTUATED.cushion), TypeError,
     'cushion must be a RoundCushion'),
    (lambda: HexagonActuationModel([build_panel(cushion=RoundCushion(0.08))]), ValueError,
     'use a larger cushion'),
    (lambda: HexagonActuationModel([DEMONSTRATOR_ACTUATED]), TypeError,
     'not a HexagonActuatedPanel'),
    (lambda: HexagonActuationModel([]), ValueError, 'at least one panel'),
    (lambda: HexagonActuationModel([HEXAGON_ACTUATED], quadrature_points=2), ValueError,
     'quadrature_points'),
    (lambda: actuation_model_of([HEXAGON_ACTUATED, DEMONSTRATOR_ACTUATED]), ValueError,
     'different kinds'),
    (lambda: actuation_model_of([HEXAGON_MODULE]), TypeError, 'not an actuated panel'),
    (lambda: actuated_like(HEXAGON_MODULE, DEMONSTRATOR_ACTUATED), TypeError,
     'must be a HexagonActuatedPanel'),
    (lambda: actuated_like(DEMONSTRATOR_MODULE, HEXAGON_ACTUATED), TypeError,
     'must be an ActuatedPanel'),
    (lambda: actuated_like('hexagon'), TypeError, 'not a panel geometry'),
])
def test_impossible_parameters_are_refused(build, error, message):
    with pytest.raises(error, match=message):
        build()


def test_bad_states_and_pressures_are_refused(model):
    with pytest.raises(ValueError, match='gauge_pressure_pa must be finite'):
        model.closure_from_pressure(float('nan'))
    with pytest.raises(ValueError, match='centre_rise_m must be finite'):
        model.cushion_volume_m3(float('nan'))
    with pytest.raises(ValueError, match='closure must lie in'):
        model.pressure_from_closure(1.5)


def test_core_radius_follows_the_d_cone_scaling():
    assert HEXAGON_ACTUATED.core_radius_m == pytest.approx(
        HEXAGON_ACTUATED.midrib.thickness_m**(1 / 3) * HEXAGON_MODULE.circumradius_m**(2 / 3))
    assert d_cone_core_radius_m(0.008, 0.62) == pytest.approx(
        2 * d_cone_core_radius_m(0.001, 0.62))
    assert HEXAGON_ACTUATED.core_radius_m < HEXAGON_ACTUATED.cushion.flat_radius_m \
        < inner_radius_m(HEXAGON_MODULE)
