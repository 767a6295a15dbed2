"""The building_report command as a user runs it: a TMY3 file, two days, table, CSV, PNG."""

import csv
import os

import pvlib
import pytest

from flectofold_model.building import building_report as model
from flectofold_model.building import daylight
from flectofold_model.shading.table import ShadingTable
from flectofold_ros.commands import building_report
from flectofold_ros.runtime.executables import EXECUTABLES

TMY3 = os.path.join(os.path.dirname(pvlib.__file__), 'data', '723170TYA.CSV')


class CoarseTable(ShadingTable):
    """A quick shading table, so that the command's test does not spend 7 s building one."""

    def __init__(self, panel, closures=None):
        super().__init__(panel, step_deg=15.0, samples=6)


class CoarseDaylight(daylight.DaylightModel):
    """Three closure states, a 2 m grid and three bounces: seconds instead of two minutes."""

    def __init__(self, room, facade=None, spacing_m=0.6, **options):
        options.update(states=(0.0, 0.5, 1.0), params=('-ab', '3', '-ad', '2048', '-lw', '1e-4'))
        super().__init__(room, facade, spacing_m=max(spacing_m, 2.0), **options)


def test_two_days_on_pvlibs_tmy3_print_the_rows_and_write_csv_and_png(
        tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(model, 'ShadingTable', CoarseTable)
    monkeypatch.setattr(daylight, 'DaylightModel', CoarseDaylight)
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
    assert 'daylight and glare, Radiance, 20 office hours' in out
    # without the facade the room is brighter than behind flat panels
    assert float(rows['always open']['mean_lx']) < float(rows['no facade']['mean_lx'])
    assert 0.0 <= float(rows['scheduled']['sda']) <= 1.0
    assert EXECUTABLES['building_report'][0] == 'flectofold_ros.commands.building_report'


@pytest.mark.parametrize('arguments, message', [
    (['--from', '02-30'], 'not a date of a non-leap year'),
    (['--from', '07-02', '--to', '07-01'], 'before the first'),
    (['--rows', 'sometimes'], 'unknown rows'),
    (['--csv', '/nonexistent/x.csv'], 'does not exist'),
    (['--grid-spacing', '0.0999'], 'grid-spacing'),
    (['--grid-spacing', '3.001'], 'grid-spacing'),
    (['--grid-spacing', 'nan'], 'grid-spacing'),
])
def test_bad_input_is_one_clear_line(arguments, message, capsys):
    assert building_report.main(['building_report', TMY3, *arguments]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith('building_report: ') and message in err[0]


def test_the_grid_spacing_is_taken_at_its_bounds():
    assert building_report.grid_spacing_m(0.1) == 0.1
    assert building_report.grid_spacing_m(3.0) == 3.0
