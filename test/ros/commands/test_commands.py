"""The commands that need no ROS graph, as a user runs them: output and bad input."""

from flectofold_ros.commands import day_report, fold_table


def test_cli_reports_bad_input_clearly(tmp_path, capsys):
    bad = tmp_path / 'bad.yaml'
    bad.write_text('site: [unclosed')
    assert day_report.main(['day_report', '--facade', str(bad), '--out', str(tmp_path)]) == 2
    assert 'malformed YAML' in capsys.readouterr().err
    assert day_report.main(['day_report', '--date', '2026-13-40', '--out', str(tmp_path)]) == 2


def test_fold_table_prints_every_closure_from_open_to_closed(capsys):
    assert fold_table.main(['fold_table', '--panel', 'prototype', '--steps', '5']) == 0
    lines = capsys.readouterr().out.splitlines()
    rows = [line.split() for line in lines if line.strip()[:1].isdigit()]
    assert [float(row[0]) for row in rows] == [0.0, 0.25, 0.5, 0.75, 1.0]
    folds = [float(row[1]) for row in rows]
    assert folds == sorted(folds) and folds[0] == 5.0  # the prototype's 5 degree pre-fold
