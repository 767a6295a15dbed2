"""Peak surface strains of the laminates against the kinematic model and the allowable strain."""

import dataclasses
import math
import warnings

import numpy as np
import pytest

from flectofold_model.actuation import (DEMONSTRATOR_ACTUATED, FLECTOLINE_ACTUATED,
                                        HEXAGON_ACTUATED)
from flectofold_model.actuation.hexagon_statics import HALF_SECTOR_RAD
from flectofold_model.actuation.laminate import FATIGUE_ALLOWABLE_STRAIN, Laminate
from flectofold_model.actuation.strain import (hexagon_panel_strain, hinge_width_for_allowable_m,
                                               panel_strain, quad_panel_strain,
                                               strain_exceedance, StrainLimitWarning,
                                               warn_if_over_allowable)
from flectofold_model.kinematics import elastica
from flectofold_model.kinematics.closure import FoldModel
from flectofold_model.kinematics.hexagon_closure import HexagonFoldModel
from flectofold_model.kinematics.hexagon_panel import HexagonBatch
from flectofold_model.kinematics.hexagon_reflection import SectorGeometry
from flectofold_model.kinematics.panel import PanelBatch
from flectofold_model.kinematics.reflection import fold_angle_along_crease


def test_hinge_strain_is_rho_t_over_2b_at_the_crease_peak():
    panel, closure = DEMONSTRATOR_ACTUATED, 0.7
    geometry = panel.geometry
    fold = FoldModel(PanelBatch.from_panels([geometry]))
    state = fold.state_from_closure(closure)
    stations = geometry.length_m * np.linspace(-0.5, 0.5, 1001)[None, :]

    def rho(k):
        return fold_angle_along_crease(fold.batch, k, elastica.sag_from_k(k, geometry.length_m),
                                       stations)[0]

    change = rho(state.elastica_k) - rho(fold.open_k)
    expected = np.max(change) * panel.hinge.thickness_m / (2.0 * geometry.hinge_width_m)
    strain = quad_panel_strain([panel], closure)
    assert strain.hinge_strain[0] == pytest.approx(expected, rel=1e-9)
    # The fold grows from the apex toward the supports: the peak sits at a support.
    assert abs(stations[0, np.argmax(change)]) == pytest.approx(geometry.length_m / 2)
    radius = geometry.fold_radius_m
    assert strain.hinge_peak_arc_m[0] == pytest.approx(
        radius * math.asin(geometry.length_m / 2 / radius))
    # Mid-rib and flaps: the elastica's curvature change, largest at mid-span.
    curvature = state.midrib_peak_curvature_per_m[0] - elastica.peak_curvature_from_k(
        fold.open_k, geometry.length_m)[0]
    assert strain.midrib_strain[0] == pytest.approx(panel.midrib.surface_strain(curvature))
    assert strain.flap_strain[0] == pytest.approx(panel.flap.surface_strain(curvature))


def test_hexagon_hinge_strain_is_rho_t_over_2b_along_its_crease():
    panel, closure = HEXAGON_ACTUATED, 0.6
    fold = HexagonFoldModel(HexagonBatch.from_panels([panel.geometry]))
    rise = fold.state_from_closure(closure).centre_rise_m
    phi = np.linspace(0.0, 2.0 * HALF_SECTOR_RAD, 2001)  # a whole sector, vertex to vertex
    change = (SectorGeometry(fold.batch, rise).fold_angle_rad(phi)
              - SectorGeometry(fold.batch, fold.open_shape).fold_angle_rad(phi))[0]
    expected = np.max(change) * panel.hinge.thickness_m / (2.0 * panel.geometry.hinge_width_m)
    strain = hexagon_panel_strain([panel], closure)
    assert strain.hinge_strain[0] == pytest.approx(expected, rel=1e-6)
    assert strain.midrib_strain[0] > strain.flap_strain[0] > 0.0  # the core bends most


@pytest.mark.parametrize('panel', [DEMONSTRATOR_ACTUATED, FLECTOLINE_ACTUATED,
                                   HEXAGON_ACTUATED], ids=['demonstrator', 'flectoline',
                                                           'hexagon'])
def test_strain_is_zero_at_closure_0_and_grows_monotonically_with_closure(panel):
    closures = np.linspace(0.0, 1.0, 11)
    strain = panel_strain([panel] * closures.size, closures)
    for zone in (strain.hinge_strain, strain.midrib_strain, strain.flap_strain):
        assert zone[0] == pytest.approx(0.0, abs=1e-12)
        assert np.all(np.diff(zone) > 0.0)
    np.testing.assert_allclose(strain.closure, closures, atol=1e-9)


def test_every_preset_hinge_exceeds_the_fatigue_allowable_when_closed():
    strain = panel_strain([DEMONSTRATOR_ACTUATED, FLECTOLINE_ACTUATED], 1.0)
    assert 0.03 < strain.hinge_strain[0] < 0.04  # 3.35 %: 1.2 mm over a 30 mm hinge
    assert np.all(strain.utilisation > 1.0)
    assert 0.04 < hexagon_panel_strain([HEXAGON_ACTUATED]).hinge_strain[0] < 0.05


def test_the_hinge_width_for_the_allowable_strain_brings_the_hinge_to_it():
    width = hinge_width_for_allowable_m(DEMONSTRATOR_ACTUATED)
    assert 0.12 < width < 0.17
    wider = dataclasses.replace(DEMONSTRATOR_ACTUATED, geometry=dataclasses.replace(
        DEMONSTRATOR_ACTUATED.geometry, hinge_width_m=width))
    strain = quad_panel_strain([wider])
    assert strain.hinge_strain[0] == pytest.approx(FATIGUE_ALLOWABLE_STRAIN, rel=1e-9)
    assert 'stays within the allowable 0.7 %' in strain_exceedance(wider)
    assert 'needs to be at least' in strain_exceedance(DEMONSTRATOR_ACTUATED)


@pytest.mark.parametrize('value, accepted', [
    (0.0, False), (1e-9, True), (0.05, True), (0.0500001, False), (float('nan'), False),
    (-0.007, False), (0.7, False)])
def test_allowable_strain_is_validated_at_its_bounds(value, accepted):
    if accepted:
        assert Laminate(thickness_m=0.002, allowable_strain=value).allowable_strain == value
    else:
        with pytest.raises(ValueError, match='allowable_strain'):
            Laminate(thickness_m=0.002, allowable_strain=value)


def test_the_default_allowable_strain_is_the_fatigue_estimate():
    assert Laminate(thickness_m=0.002).allowable_strain == FATIGUE_ALLOWABLE_STRAIN == 0.007


def test_panels_over_their_allowable_warn_once_naming_the_worst():
    geometries = [DEMONSTRATOR_ACTUATED.geometry, FLECTOLINE_ACTUATED.geometry]
    with pytest.warns(StrainLimitWarning) as record:
        warn_if_over_allowable(geometries, ['first', 'second'], 'a test')
    assert len(record) == 1
    message = str(record[0].message)
    # The FlectoLine outline's 15 mm hinge with the demonstrator's 1.2 mm lay-up is the worst.
    assert '2 of 2 panels' in message and 'panel second' in message and 'hinge' in message


def test_a_high_allowable_strain_emits_no_warning():
    tolerant = Laminate(thickness_m=0.0012, youngs_modulus_pa=2e9, allowable_strain=0.05)
    template = dataclasses.replace(DEMONSTRATOR_ACTUATED, hinge=tolerant)
    with warnings.catch_warnings():
        warnings.simplefilter('error')
        strain = warn_if_over_allowable([DEMONSTRATOR_ACTUATED.geometry], ['one'], 'a test',
                                        template=template)
    assert strain.utilisation[0] < 1.0
