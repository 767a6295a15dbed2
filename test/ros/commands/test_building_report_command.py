"""The building_report command as a user runs it: a TMY3 file, two days, table, CSV, PNG."""

import csv
import os

import pvlib
import pytest

from flectofold_model.building import building_report as model
from flectofold_model.shading.table import ShadingTable
from flectofold_ros.commands import building_report
from flectofold_ros.executables import EXECUTABLES

TMY3 = os.path.join(os.path.dirname(pvlib.__file__), 'data', '723170TYA.CSV')


class CoarseTable(ShadingTable):
    """A quick shading table, so that the command's test does not spend 7 s building one."""

    def __init__(self, panel, closures=None):
        super().__init__(panel, step_deg=15.0, samples=6)


def test_two_days_on_pvlibs_tmy3_print_the_rows_and_write_csv_and_png(
        tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(model, 'ShadingTable', CoarseTable)
    png, table = tmp_path / 'room.png', tmp_path / 'room.csv'
    assert building_report.main(
        ['building_report', TMY3, '--from', '07-01', '--to', '07-02',
         '--rows', 'no facade,always open,scheduled', '--csv', str(table),
         '--png', str(png)]) == 0
    out = capsys.readouterr().out
    assert 'rewritten as an EPW for EnergyPlus' in out
    assert '07-01 to 07-02' in out
    for row in ('no facade ', 'always open ', 'scheduled '):
        assert any(line.startswith(row) for line in out.splitlines())
    with open(table, newline='') as f:
        rows = {row['name']: row for row in csv.DictReader(f)}
    assert float(rows['always open']['transmitted_solar_kwh']) < \
        0.2 * float(rows['no facade']['transmitted_solar_kwh'])
    assert png.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'
    assert EXECUTABLES['building_report'][0] == 'flectofold_ros.commands.building_report'


@pytest.mark.parametrize('arguments, message', [
    (['--from', '02-30'], 'not a date of a non-leap year'),
    (['--from', '07-02', '--to', '07-01'], 'before the first'),
    (['--rows', 'sometimes'], 'unknown rows'),
    (['--csv', '/nonexistent/x.csv'], 'does not exist'),
])
def test_bad_input_is_one_clear_line(arguments, message, capsys):
    assert building_report.main(['building_report', TMY3, *arguments]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith('building_report: ') and message in err[0]
