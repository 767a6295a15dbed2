"""The structural path in Rerun: the folded sheet at every equilibrium, coloured by strain."""

import numpy as np
import pytest
from rrd_reading import Rrd

from flectofold_model.actuation import DEMONSTRATOR_ACTUATED
from flectofold_model.structure.panel import PanelMesh, structural_path
from flectofold_ros.commands import fold_table
from flectofold_ros.rerun.structure_scene import (PEAK_HINGE_STRAIN, save_structural_path,
                                                  SHEET, TIMELINE, vertex_strain)
from flectofold_ros.wire.colours import strain_colours, STRAIN_RED_MULTIPLE

QUICK = PanelMesh(20, 2, 1, 2)
ALLOWABLE = 0.007


@pytest.fixture(scope='module')
def path():
    return structural_path(DEMONSTRATOR_ACTUATED, QUICK, target_fold_rad=0.6, steps=8)


def test_strain_colours_run_green_to_amber_at_the_allowable_and_red_at_ten_times_it():
    colours = strain_colours([0.0, 0.5 * ALLOWABLE, ALLOWABLE, STRAIN_RED_MULTIPLE * ALLOWABLE,
                              100 * ALLOWABLE, -ALLOWABLE], ALLOWABLE)
    assert tuple(colours[0]) == (46, 139, 87, 255)
    assert tuple(colours[2]) == (240, 190, 40, 255)
    assert tuple(colours[3]) == (200, 30, 30, 255)
    assert tuple(colours[4]) == (200, 30, 30, 255)
    # Halfway to the allowable is halfway on the first leg; a strain's sign does not matter.
    assert tuple(colours[1]) == (143, 164, 64, 255)
    assert tuple(colours[5]) == tuple(colours[2])
    # Just beyond the allowable the colour leaves amber toward red.
    beyond = strain_colours([1.1 * ALLOWABLE], ALLOWABLE)[0]
    assert beyond[0] < 240 and beyond[1] < 190


@pytest.mark.parametrize('allowable', [0.0, -0.01, float('nan')])
def test_strain_colours_refuse_an_allowable_that_is_not_positive(allowable):
    with pytest.raises(ValueError, match='allowable_strain must be positive'):
        strain_colours([0.01], allowable)


def test_a_vertex_takes_the_largest_strain_of_its_triangles():
    triangles = np.array([[0, 1, 2], [1, 3, 2]])
    strain = np.array([[0.01, 0.03], [0.02, 0.0]])
    assert vertex_strain(triangles, strain, 4).tolist() == [[0.01, 0.03, 0.03, 0.03],
                                                            [0.02, 0.02, 0.02, 0.0]]


def test_the_recording_holds_the_sheet_at_every_equilibrium_coloured_by_strain(path, tmp_path):
    out = tmp_path / 'path.rrd'
    save_structural_path(out, path, ALLOWABLE)
    rrd = Rrd(out, timeline=TIMELINE)
    positions = rrd.arrays(SHEET, 'Mesh3D:vertex_positions', 3)
    assert [index for index, _ in positions] == list(range(len(path.pressure_pa)))
    for (_, logged), expected in zip(positions, path.positions_m):
        assert logged == pytest.approx(expected, abs=1e-6)  # float32 in the recording
    colours = rrd.arrays(SHEET, 'Mesh3D:vertex_colors')
    strain = vertex_strain(path.triangles, path.surface_strain, path.positions_m.shape[1])
    last = strain_colours(strain[-1], ALLOWABLE)
    packed = (last[:, 0].astype(np.uint32) << 24 | last[:, 1].astype(np.uint32) << 16
              | last[:, 2].astype(np.uint32) << 8 | last[:, 3])
    assert colours[-1][1].tolist() == packed.tolist()
    assert rrd.static(SHEET, 'allowable_strain') == [ALLOWABLE]
    assert len(rrd.static(SHEET, 'zone')) == len(path.triangles)
    hinge = [value for _, value in rrd.arrays(PEAK_HINGE_STRAIN, 'Scalars:scalars')]
    assert np.concatenate(hinge) == pytest.approx(path.peak_strain['hinge'])
    # The open state is unstrained and at a 34 deg fold the hinge is past the allowable:
    # the colours go from all green past amber.
    assert np.all(strain[0] < 1e-9)
    assert strain[-1].max() > 2 * ALLOWABLE


def test_fold_table_writes_the_recording_when_asked(tmp_path, capsys):
    out = tmp_path / 'structure.rrd'
    lines = fold_table.structural_fold_table(DEMONSTRATOR_ACTUATED.geometry, 3, QUICK, out)
    assert lines[-1].startswith(f'Rerun recording {out}: the sheet at ')
    count = int(lines[-1].split(' at ')[1].split()[0])
    rrd = Rrd(out, timeline=TIMELINE)
    assert len(rrd.arrays(SHEET, 'Mesh3D:vertex_positions', 3)) == count


def test_fold_table_refuses_a_recording_it_cannot_write_before_tracing_anything(
        tmp_path, capsys):
    missing = tmp_path / 'no' / 'such.rrd'
    assert fold_table.main(['fold_table', '--model', 'structural', '--rrd', str(missing)]) == 2
    assert 'does not exist' in capsys.readouterr().err
    with pytest.raises(SystemExit) as stop:
        fold_table.main(['fold_table', '--rrd', str(tmp_path / 'a.rrd')])
    assert stop.value.code == 2
    assert '--rrd needs --model structural' in capsys.readouterr().err
