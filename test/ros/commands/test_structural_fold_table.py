"""fold_table --model structural: the structural path beside the reflection model."""

import numpy as np

from flectofold_model import DEMONSTRATOR_MODULE, FoldModel, PanelBatch
from flectofold_model.structure.panel import PanelMesh
from flectofold_ros.commands import fold_table

#: One hinge row: the quickest mesh that reaches the closed fold (about 6 s), for the format.
QUICK = PanelMesh(20, 2, 1, 2)


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
    assert any(line.startswith('a mesh coarser than the default') for line in lines[7:])
    assert lines[-1].startswith('peak hinge strain on the path ')
    assert 'against an allowable 0.7 %' in lines[-1]


def test_the_hexagon_is_refused_with_the_reason(capsys):
    assert fold_table.main(['fold_table', '--panel', 'hexagon', '--model', 'structural']) == 2
    error = capsys.readouterr().err
    assert error.startswith('fold_table: the structural model is built for quad panels only')


def test_help_names_the_structural_columns(capsys):
    try:
        fold_table.main(['fold_table', '--help'])
    except SystemExit as stop:
        assert stop.code == 0
    text = capsys.readouterr().out
    for name, _, _, meaning in fold_table.STRUCTURAL_COLUMNS:
        assert f'{name:<16} {meaning}' in text
    assert '--model {kinematic,structural}' in text
