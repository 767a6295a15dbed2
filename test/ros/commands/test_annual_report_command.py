"""The annual_report command as a user runs it: table, progress, PNG, CSV, help, bad input."""

import csv

import pytest

from flectofold_model.scheduling import annual_report as model
from flectofold_model.shading.table import ShadingTable
from flectofold_ros.commands import annual_report
from flectofold_ros.runtime.executables import EXECUTABLES

EPW_HEADER = [
    'LOCATION,Stuttgart,BW,DEU,TEST,107380,48.83,9.20,1.0,318.0',
    'DESIGN CONDITIONS,0', 'TYPICAL/EXTREME PERIODS,0', 'GROUND TEMPERATURES,0',
    'HOLIDAYS/DAYLIGHT SAVINGS,No,0,0,0', 'COMMENTS 1,test', 'COMMENTS 2,test',
    'DATA PERIODS,1,1,Data,Sunday, 3/20,3/21',
]


class CoarseTable(ShadingTable):
    """A quick shading table, so that the command's test does not spend 7 s building one."""

    def __init__(self, panel, closures):
        super().__init__(panel, closures=closures, step_deg=15.0, samples=6)


@pytest.fixture
def epw(tmp_path):
    rows = []
    for day in range(2):
        for hour in range(1, 25):
            sun = max(0, 6 - abs(hour - 12.5))
            wind = 14.0 if (day, hour) == (1, 15) else 3.0
            fields = [1995, 3, 20 + day, hour, 60, 'A7A7', 8.0, 2.0, 70, 98000, 0, 1400, 350,
                      int(120 * sun), int(140 * sun), int(30 * sun), 0, 0, 0, 0, 200, wind,
                      5, 5, 20.0, 77777, 9, '999999999', 10, 0.1, 0, 88, 0.2, 0, 1.0]
            rows.append(','.join(str(f) for f in fields))
    path = tmp_path / 'site.epw'
    path.write_text('\n'.join(EPW_HEADER + rows) + '\n')
    return path


def test_report_prints_the_table_and_writes_png_and_csv(epw, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(model, 'ShadingTable', CoarseTable)
    png, table = tmp_path / 'annual.png', tmp_path / 'annual.csv'
    assert annual_report.main(['annual_report', str(epw), '--png', str(png),
                               '--csv', str(table)]) == 0
    out = capsys.readouterr().out
    lines = out.splitlines()
    assert any(line.startswith('annual_report: sun: 48 steps') for line in lines)
    assert any('scheduler over 48 steps' in line for line in lines)
    assert 'local dates 03-20 to 03-21 (2 days, step 60 min)' in out
    assert 'wind x 1 above 10 m/s for 1 h' in out
    rows = {line.split()[0]: line for line in lines
            if line.split()[:1] in (['scheduled'], ['threshold'], ['limit'])}
    assert set(rows) == {'scheduled', 'threshold', 'limit'}
    assert any(line.startswith('target rule ') for line in lines)
    assert any(line.startswith('always open ') for line in lines)
    assert any(line.startswith('always closed ') for line in lines)
    for unit in ('[kWh/m2]', '[NL]', 'normal litres', 'budget used'):
        assert unit in out
    assert png.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'
    with open(table, newline='') as f:
        written = list(csv.DictReader(f))
    assert sorted(row['strategy'] for row in written) == sorted(model.STRATEGIES)
    assert {row['month'] for row in written} == {'3'}
    scheduled = next(row for row in written if row['strategy'] == 'scheduled')
    printed = float(rows['scheduled'].split()[1])
    assert float(scheduled['blocked_direct_kwh_m2']) == pytest.approx(printed, abs=0.05)
    assert 'cpu time:' in lines[-1]


def test_help_explains_every_figure(capsys):
    with pytest.raises(SystemExit) as stop:
        annual_report.main(['annual_report', '--help'])
    assert stop.value.code == 0
    text = capsys.readouterr().out
    for words in ('blocked direct [kWh/m2]', 'view [h]', 'view-wtd [h]', 'moves /panel',
                  'budget used', 'air [NL]', 'storm clos.', '--step-min', '--from', '--png',
                  '--csv', 'hexagon_6x6', 'local standard time'):
        assert words in text
    assert EXECUTABLES['annual_report'][0] == 'flectofold_ros.commands.annual_report'


@pytest.mark.parametrize('arguments, message', [
    (['--facade', 'no_such_facade'], 'embedded descriptions'),
    (['--from', '03-21', '--to', '04-02'], 'covers local dates 03-20 to 03-21'),
    (['--step-min', '7'], 'step must be one of'),
    (['--from', '2026-13-40'], 'not a date'),
    (['--png', '/no/such/folder/a.png'], 'does not exist'),
])
def test_bad_input_is_one_clear_line(epw, capsys, arguments, message):
    assert annual_report.main(['annual_report', str(epw), *arguments]) == 2
    error = capsys.readouterr().err
    assert error.startswith('annual_report: ') and message in error
    assert 'Traceback' not in error


def test_missing_weather_file_is_refused(tmp_path, capsys):
    assert annual_report.main(['annual_report', str(tmp_path / 'none.epw')]) == 2
    assert 'weather file not found' in capsys.readouterr().err
