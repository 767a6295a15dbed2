"""fold_table --panel hexagon as a user runs it: parsed and checked against the model."""

import math

import numpy as np
import pytest

from flectofold_model.kinematics.hexagon import HEXAGON_MODULE, HexagonBatch, HexagonFoldModel
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
    assert table.shape == (STEPS, 8)
    closure, fold, rise, vertex, tilt, cone, travel, amplification = table.T
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
    stroke = rise[1:] - rise[0]
    np.testing.assert_allclose(amplification[1:], travel[1:] / stroke, rtol=0.01, atol=0.05)


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
