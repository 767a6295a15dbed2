"""fold_table --model structural: the structural path beside the reflection model."""

from dataclasses import replace
import math
import re

import numpy as np
import pytest

from flectofold_model import DEMONSTRATOR_MODULE, FoldModel, PanelBatch
from flectofold_model.kinematics.hexagon_panel import HEXAGON_MODULE
from flectofold_model.structure.hexagon import (HEXAGON_CONVERGED_MESH, HEXAGON_REFERENCE_MESH,
                                                HexagonMesh)
from flectofold_model.structure.panel import BANDED_MESH, CONVERGED_MESH, PanelMesh
from flectofold_ros.commands import fold_table

#: One hinge row: the quickest mesh that reaches the closed fold (about 6 s), for the format.
QUICK = PanelMesh(20, 2, 1, 2)
#: The quickest hexagon mesh (a few seconds), for the format.
QUICK_HEXAGON = HexagonMesh(12, 2, 2, 1)


def test_the_structural_table_prints_both_models_at_each_closure():
    lines = fold_table.structural_fold_table(DEMONSTRATOR_MODULE, 5, QUICK)
    assert lines[0].startswith('structural model: panel 1 m x 1 m, fold radius 1 m')
    assert '231 nodes' in lines[0]
    header = lines[1].split('  ')
    assert [name for name in (c.strip() for c in header) if name][:5] == [
        'closure', 'fold [deg]', 'at supports', 'p [kPa]', 'p refl']
    rows = [line.split() for line in lines[2:7]]
    closures = [float(row[0]) for row in rows]
    assert closures == [0.0, 0.25, 0.5, 0.75, 1.0]
    model = FoldModel(PanelBatch.repeat(DEMONSTRATOR_MODULE, 5))
    expected = np.degrees(model.state_from_closure(np.array(closures)).apex_fold_angle_rad)
    assert [float(row[1]) for row in rows] == [round(value, 1) for value in expected]
    pressures = [float(row[3]) for row in rows]
    assert pressures[0] == 0.0 and all(p > 0.0 for p in pressures[1:])
    assert rows[0][-1] == 'yes'
    assert any(line.startswith('pressure maximum ') for line in lines[7:])
    assert any(line.startswith('the path reached the closed fold') for line in lines[7:])
    wind = [line for line in lines if line.startswith("closed, 1 kN/m2 on the flaps' inner")]
    assert len(wind) == 1 and ' N/m per flap; valves shut (air held): ' in wind[0]
    rise = re.search(r'the cushion pressure up (\d+) Pa$', wind[0])
    assert rise is not None and int(rise.group(1)) > 0
    assert any(line.startswith('a mesh coarser than the converged one') for line in lines[7:])
    assert lines[-1].startswith('peak hinge strain on the path ')
    assert 'against an allowable 0.7 %' in lines[-1]


def test_the_hexagon_table_says_where_its_path_ended():
    lines = fold_table.structural_fold_table(HEXAGON_MODULE, 3, QUICK_HEXAGON)
    assert lines[0].startswith('structural model: hexagonal panel, circumradius 0.62 m')
    assert '(12 rays per sector, rows 2 central / 2 hinge / 1 flap)' in lines[0]
    rows = [line.split() for line in lines[2:5]]
    assert [float(row[0]) for row in rows] == [0.0, 0.5, 1.0]
    # The reflection model's pressures are printed at every closure; the structure's only
    # where its path went (it did not close: msg_docs/structure.md).
    assert all(float(row[4]) > 0.0 for row in rows[1:])
    assert rows[2][3] == '-'
    ended = [line for line in lines if line.startswith('the path ended at ')]
    # On this mesh the module unfolds at its apex and the path runs to its air limit
    # (measured); the line says so.
    assert len(ended) == 1 and 'not closed with 38.5 L of air' in ended[0]
    assert any(line.startswith('a mesh coarser than the converged one') for line in lines)


def test_the_hexagon_table_names_the_mode_pair_that_breaks_its_three_fold_turn():
    # Moulded to 20 deg the module folds and its path loses stability in modes odd under its
    # mirror through T_0 (msg_docs/structure.md); the table words that class for the
    # hexagon, not as a quad's.
    panel = replace(HEXAGON_MODULE, prefold_rad=math.radians(20.0))
    lines = fold_table.structural_fold_table(panel, 3, HexagonMesh(12, 4, 2, 2))
    lost = [line for line in lines if line.startswith('stability lost in a mode odd in x')]
    assert len(lost) == 1
    assert '(odd under the mirror through T_0; where the even class loses' in lost[0]
    assert 'one end of the span' not in lost[0]


@pytest.fixture
def tables(monkeypatch):
    """Record what ``fold_table.main`` asks the structural table for instead of tracing it."""
    seen = {}

    def table(panel, steps, mesh, rrd_path):
        seen.update(panel=panel, steps=steps, mesh=mesh, rrd_path=rrd_path)
        return ['table']

    monkeypatch.setattr(fold_table, 'structural_fold_table', table)
    return seen


def test_the_hexagon_takes_the_structural_model_on_the_command_line(capsys, tables):
    seen = tables
    assert fold_table.main(['fold_table', '--panel', 'hexagon', '--model', 'structural',
                            '--mesh', 'coarse', '--steps', '3']) == 0
    assert seen == {'panel': HEXAGON_MODULE, 'steps': 3, 'mesh': HexagonMesh(24, 6, 2, 3),
                    'rrd_path': None}
    assert capsys.readouterr().out == 'table\n'


def test_the_converged_mesh_is_every_panels_default(tables):
    seen = tables
    assert fold_table.main(['fold_table', '--model', 'structural', '--mesh', 'converged']) == 0
    assert seen['mesh'] == CONVERGED_MESH
    assert fold_table.main(['fold_table', '--panel', 'hexagon', '--model', 'structural',
                            '--mesh', 'converged']) == 0
    assert seen['mesh'] == HEXAGON_CONVERGED_MESH
    # Without --mesh: the converged mesh of either kind.
    assert fold_table.main(['fold_table', '--model', 'structural']) == 0
    assert seen['mesh'] == CONVERGED_MESH
    assert fold_table.main(['fold_table', '--panel', 'hexagon', '--model', 'structural']) == 0
    assert seen['mesh'] == HEXAGON_CONVERGED_MESH
    assert fold_table.main(['fold_table', '--panel', 'hexagon', '--model', 'structural',
                            '--mesh', 'fine']) == 0
    assert seen['mesh'] == HEXAGON_REFERENCE_MESH


def test_the_banded_mesh_is_for_quad_panels_and_refused_for_the_hexagon(capsys, tables):
    seen = tables
    assert fold_table.main(['fold_table', '--model', 'structural', '--mesh', 'banded']) == 0
    assert seen['mesh'] == BANDED_MESH
    seen.clear()
    try:
        fold_table.main(['fold_table', '--panel', 'hexagon', '--model', 'structural',
                         '--mesh', 'banded'])
    except SystemExit as stop:
        assert stop.code == 2
    else:
        raise AssertionError('the hexagon was not refused')
    assert seen == {}
    assert ('--mesh banded is for quad panels: the hexagon has no banded mesh'
            in capsys.readouterr().err)


def test_a_graded_mesh_is_named_in_the_heading():
    graded = replace(QUICK, flap_growth=4.0)
    lines = fold_table.structural_fold_table(DEMONSTRATOR_MODULE, 2, graded)
    assert 'rows 2 mid-rib / 1 hinge / 2 flap per side, flap rows 4 x wider at the edge than ' \
        'by the hinge)' in lines[0]
    banded = replace(QUICK, outer_columns=QUICK.columns // 2)
    lines = fold_table.structural_fold_table(DEMONSTRATOR_MODULE, 2, banded)
    assert (f'flap per side, columns halving away from the hinge bands to '
            f'{QUICK.columns // 2})') in lines[0]


def test_help_names_the_structural_columns(capsys):
    try:
        fold_table.main(['fold_table', '--help'])
    except SystemExit as stop:
        assert stop.code == 0
    text = capsys.readouterr().out
    for name, _, _, meaning in fold_table.STRUCTURAL_COLUMNS:
        assert f'{name:<16} {meaning}' in text
    assert '--model {kinematic,structural}' in text


def test_the_table_names_a_symmetry_breaking_mode_and_a_jump(monkeypatch):
    # Neither happens on the quick mesh: the path's findings are set here, the lines read.
    from flectofold_model.structure.panel import StructuralPath
    monkeypatch.setattr(StructuralPath, 'symmetry_breaking',
                        property(lambda path: [(3, 'odd in y')]))
    monkeypatch.setattr(StructuralPath, 'jumps', property(lambda path: np.array([5])))
    lines = fold_table.structural_fold_table(DEMONSTRATOR_MODULE, 5, QUICK)
    broken = [line for line in lines if line.startswith('stability lost in a mode odd in y')]
    assert len(broken) == 1
    assert '(one flap closing ahead of the other)' in broken[0]
    assert broken[0].endswith('the panel leaves the symmetric path this table follows')
    jumped = [line for line in lines if line.startswith('jump to another equilibrium between')]
    assert len(jumped) == 1 and 'the energy balance of that step does not hold' in jumped[0]
