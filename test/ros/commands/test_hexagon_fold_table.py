"""fold_table as a user runs it (hexagon and strains): parsed and checked against the model."""

import math
import re

import numpy as np
import pytest

from flectofold_model.actuation import DEMONSTRATOR_ACTUATED, HEXAGON_ACTUATED
from flectofold_model.actuation.strain import hinge_width_for_allowable_m, panel_strain
from flectofold_model.kinematics.hexagon_closure import HexagonFoldModel
from flectofold_model.kinematics.hexagon_panel import HEXAGON_MODULE, HexagonBatch
from flectofold_ros.commands import fold_table

STEPS = 9


def run(capsys, *arguments):
    assert fold_table.main(['fold_table', *arguments]) == 0
    return capsys.readouterr().out.splitlines()


def rows_of(lines):
    return np.array([[math.nan if cell == '-' else float(cell) for cell in line.split()]
                     for line in lines if line.strip()[:1].isdigit()])


@pytest.fixture(scope='module')
def model():
    return HexagonFoldModel(HexagonBatch.repeat(HEXAGON_MODULE, STEPS))


def test_hexagon_table_is_monotone_and_matches_the_model(capsys, model):
    lines = run(capsys, '--panel', 'hexagon', '--steps', str(STEPS))
    assert 'circumradius 0.62 m' in lines[0]
    header = lines[2]
    for name in ('closure', 'fold [deg]', 'rise [mm]', 'vertex in [mm]', 'spoke tilt [deg]',
                 'tip travel [mm]', 'amplification'):
        assert name in header
    table = rows_of(lines)
    assert table.shape == (STEPS, 11)
    closure, fold, rise, vertex, tilt, cone, travel, amplification = table.T[:8]
    np.testing.assert_allclose(closure, np.linspace(0.0, 1.0, STEPS), atol=0.005)
    for column in (fold, rise, vertex, tilt, travel):
        assert np.all(np.diff(column) > 0.0)
    assert fold[0] == pytest.approx(5.0, abs=0.05)  # the module's 5 degree pre-fold
    state = model.state_from_closure(np.linspace(0.0, 1.0, STEPS))
    np.testing.assert_allclose(fold, np.degrees(state.apex_fold_angle_rad), atol=0.05)
    np.testing.assert_allclose(rise, state.centre_rise_m * 1e3, atol=0.005)
    np.testing.assert_allclose(travel, state.tip_travel_m * 1e3, atol=0.05)
    # Spokes keep their length R: the vertices move in by R - sqrt(R^2 - d^2), from the
    # printed rise (its rounding moves this by under 0.002 mm).
    radius_mm = HEXAGON_MODULE.circumradius_m * 1e3
    np.testing.assert_allclose(vertex, radius_mm - np.sqrt(radius_mm**2 - rise**2), atol=0.002)
    assert math.isnan(amplification[0])  # no rise travelled yet
    # The structural model's verdict is said where the kinematic table is read.
    assert any(line.startswith('mechanics: on the structural sheet (--model structural) this '
                               'panel, moulded with its 5 deg pre-fold, does not fold under its '
                               'cushion') and 'loses stability at 45-65 deg' in line
               for line in lines)
    stroke = rise[1:] - rise[0]
    np.testing.assert_allclose(amplification[1:], travel[1:] / stroke, rtol=0.01, atol=0.05)


@pytest.mark.parametrize('panel, laminates, hinge', [
    ('demonstrator', DEMONSTRATOR_ACTUATED, 3.35), ('hexagon', HEXAGON_ACTUATED, 4.18)])
def test_fold_table_prints_strains_and_the_exceedance_at_closure_1(capsys, panel, laminates,
                                                                   hinge):
    lines = run(capsys, '--panel', panel, '--steps', '5')
    for name in ('hinge [%]', 'mid-rib [%]', 'flap [%]'):
        assert name in lines[2]
    table = rows_of(lines)
    strains = table[:, -3:]
    np.testing.assert_allclose(strains[0], 0.0)  # closure 0: the moulded, stress-free state
    assert np.all(np.diff(strains, axis=0) > 0.0)
    expected = panel_strain([laminates] * 5, np.linspace(0.0, 1.0, 5))
    np.testing.assert_allclose(strains[:, 0], expected.hinge_strain * 100, atol=0.005)
    np.testing.assert_allclose(strains[:, 1], expected.midrib_strain * 100, atol=0.005)
    assert strains[-1, 0] == pytest.approx(hinge, abs=0.01)
    assert 'allowable strain 0.7 % (fatigue of glass-fibre laminates at 1e7 cycles' in lines[-2]
    verdict = lines[-1]
    assert verdict.startswith(f'hinge {hinge:.2f} % at closure 1 exceeds the allowable 0.7 %')
    width = re.search(r'by (\d+\.\d)x; a hinge of this lay-up needs to be at least (\d+) mm wide',
                      verdict)
    assert width and float(width.group(1)) == pytest.approx(hinge / 0.7, abs=0.05)
    assert int(width.group(2)) == round(hinge_width_for_allowable_m(laminates) * 1e3)


def test_the_prototype_table_uses_the_demonstrator_laminates(capsys):
    lines = run(capsys, '--panel', 'prototype', '--steps', '3')
    assert 'lay-up (estimates): hinge 1.2 mm, mid-rib 4 mm, flaps 2 mm' in lines[-2]
    assert lines[-1].startswith('hinge 6.23 % at closure 1 exceeds')


def test_quad_panels_are_printed_as_before(capsys):
    demonstrator = run(capsys, '--panel', 'demonstrator')
    assert run(capsys) == demonstrator
    assert run(capsys, '--panel', 'quad') == demonstrator
    assert 'supports [mm]' in demonstrator[2]


def test_help_names_every_column_with_its_meaning(capsys):
    with pytest.raises(SystemExit) as stop:
        fold_table.main(['fold_table', '--help'])
    assert stop.value.code == 0
    text = capsys.readouterr().out
    assert 'hexagon' in text
    for name, _, _, meaning in fold_table.COLUMNS + fold_table.HEXAGON_COLUMNS:
        assert f'{name:<16} {meaning}' in text
    assert 'R - sqrt(R^2 - rise^2)' in text
