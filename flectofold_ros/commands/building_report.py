"""Run the room behind a facade through a weather file with EnergyPlus, the controller in its loop.

``ros2 run flectofold_ros building_report WEATHER.epw`` (or ``building_report`` in the venv):
a shoebox office (6 x 6 x 3.5 m, a south window of 60 % of the wall) behind the embedded
6 x 6 demonstrator, the file's whole year at EnergyPlus's 10-minute step, for every strategy
(the facade's controller, the other controller, the threshold rule, always open, always
closed) and the room without a facade: cooling, heating and lighting energy, peak cooling,
solar gain, the facade's mean transmittance, moves and air; and by Radiance (matrices per
closure state) the room's daylight and glare: sDA, ASE, UDI, glare hours. An EPW file, or a
TMY3 file rewritten as one for EnergyPlus (``flectofold_model.environment.epw``);
``msg_docs/building.md`` explains every figure.
"""

import argparse
from pathlib import Path
import re
import sys
import tempfile
import time

_DATE = re.compile(r'^(?:\d{4}-)?(\d{2})-(\d{2})$')


def main(args=None):
    from flectofold_ros.runtime.runner import run_command
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('weather_file', type=Path,
                        help='EPW weather file, or a TMY3 file (rewritten as an EPW)')
    parser.add_argument('--facade', default=None,
                        help='facade description YAML or embedded name (default: the 6x6 '
                             'demonstrator)')
    parser.add_argument('--from', dest='first_date', default='01-01',
                        help='first local date, MM-DD (default 01-01)')
    parser.add_argument('--to', dest='last_date', default='12-31',
                        help='last local date, MM-DD, included (default 12-31)')
    parser.add_argument('--rows', default=None,
                        help='comma-separated rows to run (default: all): no facade, '
                             'scheduled, target rule, threshold, always open, always closed, '
                             'predictive, room-aware')
    parser.add_argument('--csv', type=Path, default=None, help='write the table here')
    parser.add_argument('--png', type=Path, default=None,
                        help='write a bar chart of the energies here')
    parser.add_argument('--no-daylight', dest='daylight', action='store_false',
                        help='skip the Radiance daylight and glare (about 2 min of matrices)')
    parser.add_argument('--grid-spacing', type=float, default=0.6,
                        help='work-plane sensor spacing [m] (default 0.6, LM-83: at most '
                             '0.61 m)')
    parser.add_argument('--keep', type=Path, default=None,
                        help='keep EnergyPlus outputs in this folder (one per row)')
    options = parser.parse_args((sys.argv if args is None else args)[1:])
    return run_command('building_report', lambda stop: report(options), interrupted_code=130)


def _period(text, what):
    match = _DATE.match(str(text).strip())
    if match is None:
        raise ValueError(f'{what} date must be MM-DD or YYYY-MM-DD, got {text!r}')
    month, day = int(match.group(1)), int(match.group(2))
    days = (31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31)
    if not 1 <= month <= 12 or not 1 <= day <= days[month - 1]:
        raise ValueError(f'{what} date {text!r} is not a date of a non-leap year')
    return month, day


def grid_spacing_m(value):
    """Return ``value`` if it is a work-plane grid spacing in [0.1, 3] m, else raise."""
    if not 0.1 <= value <= 3.0:
        raise ValueError(f'--grid-spacing must lie in [0.1, 3] m, got {value:g}')
    return value


def report(options):
    """Read the inputs, run every row, print the table, write the CSV and PNG."""
    from flectofold_model.building.building_report import building_report, ROWS
    from flectofold_model.environment import read_weather
    from flectofold_model.environment.epw import tmy3_to_epw
    from flectofold_model.facade import DEFAULT_FACADE, load_facade
    started = time.process_time()
    first, last = _period(options.first_date, 'first'), _period(options.last_date, 'last')
    if last < first:
        raise ValueError(f'last date {options.last_date} is before the first '
                         f'{options.first_date}')
    rows = ROWS if options.rows is None else tuple(r.strip() for r in options.rows.split(','))
    grid_spacing_m(options.grid_spacing)
    for path in (options.csv, options.png):
        if path is not None and not path.parent.is_dir():
            raise ValueError(f'{path}: folder {path.parent} does not exist')
    weather = read_weather(options.weather_file)
    facade = load_facade(DEFAULT_FACADE if options.facade is None else options.facade)
    with tempfile.TemporaryDirectory() as scratch:
        epw = options.weather_file.resolve()
        if epw.suffix.lower() != '.epw':
            epw = tmy3_to_epw(epw, Path(scratch) / (epw.stem + '.epw'))
            print(f'building_report: {options.weather_file.name} rewritten as an EPW for '
                  'EnergyPlus', flush=True)
        result = building_report(
            facade, weather, str(epw), run_period=(first, last), rows=rows,
            workdir=None if options.keep is None else str(options.keep),
            daylight={'spacing_m': options.grid_spacing} if options.daylight else None,
            progress=lambda text: print(f'building_report: {text}', flush=True))
    print('\n'.join(result.lines()))
    if options.csv is not None:
        fields = ('name', 'cooling_kwh_m2', 'heating_kwh_m2', 'lighting_kwh_m2',
                  'peak_cooling_w_m2', 'transmitted_solar_kwh', 'mean_transmittance',
                  'moves_per_panel', 'air_nl')
        light = ('sda', 'ase', 'udi', 'udi_short', 'udi_exceeded', 'mean_lx', 'glare_hours',
                 'glare_autonomy', 'sun_in_view_hours')
        lines = [','.join(fields + light)] + [
            ','.join([str(getattr(r, f)) for f in fields]
                     + [str(getattr(r.daylight, f)) if r.daylight is not None else ''
                        for f in light]) for r in result.rows]
        options.csv.write_text('\n'.join(lines) + '\n')
        print(f'csv: {options.csv.resolve()}')
    if options.png is not None:
        print(f'plot: {plot(result, options.png).resolve()}')
    print(f'cpu time: {time.process_time() - started:.1f} s')
    return 0


def plot(result, path):
    """Write a PNG: energy per strategy and month, and with daylight a map and a glare year.

    Top left the cooling, heating and lighting of each row; top right each row's cooling by
    month; with daylight, bottom left the share of office hours each work-plane sensor has
    300 lx or more under the facade's own controller (``scheduled``; the sDA map), bottom
    right that row's DGP at the eye by day and office hour.
    """
    import matplotlib
    matplotlib.use('Agg')
    from matplotlib import pyplot
    import numpy as np
    names = [r.name for r in result.rows]
    x = np.arange(len(names))
    lit = {r.name: r for r in result.rows if r.daylight is not None}
    figure, axes = pyplot.subplots(2 if lit else 1, 2, figsize=(13, 9 if lit else 4.5),
                                   squeeze=False)
    bottom = np.zeros(len(names))
    for field, colour in (('cooling_kwh_m2', 'tab:blue'), ('heating_kwh_m2', 'tab:red'),
                          ('lighting_kwh_m2', 'gold')):
        values = np.array([getattr(r, field) for r in result.rows])
        axes[0, 0].bar(x, values, 0.6, bottom=bottom, color=colour,
                       label=field.split('_')[0])
        bottom += values
    axes[0, 0].set_ylabel('energy per m2 of floor [kWh/m2]')
    axes[0, 0].set_xticks(x)
    axes[0, 0].set_xticklabels(names, fontsize=7, rotation=20)
    axes[0, 0].legend(fontsize=8)
    (m0, d0), (m1, d1) = result.run_period
    figure.suptitle(f'{result.facade_name} before a shoebox office, {m0:02d}-{d0:02d} to '
                    f'{m1:02d}-{d1:02d}, {result.source}', fontsize=9)
    months = np.arange(1, 13)
    for row in result.rows:
        if row.monthly_kwh_m2:
            axes[0, 1].plot(months, row.monthly_kwh_m2['cooling'], marker='o', markersize=3,
                            label=row.name)
    axes[0, 1].set_xlabel('month')
    axes[0, 1].set_ylabel('cooling per m2 of floor [kWh/m2]')
    axes[0, 1].legend(fontsize=7)
    if lit:
        name = 'scheduled' if 'scheduled' in lit else next(iter(lit))
        figures = lit[name].daylight
        room = result.room
        from flectofold_model.building.daylight import GLARE_DGP
        share = figures.autonomy_by_sensor.reshape(figures.grid_shape)
        image = axes[1, 0].imshow(100 * share, origin='lower', cmap='viridis', vmin=0,
                                  vmax=100, extent=(-room.width_m / 2, room.width_m / 2,
                                                    0.0, room.depth_m), aspect='equal')
        figure.colorbar(image, ax=axes[1, 0], label='office hours at 300 lx or more [%]')
        axes[1, 0].set_xlabel('across the room [m]')
        axes[1, 0].set_ylabel('from the window [m]')
        axes[1, 0].set_title(f'{name}: sDA300/50% {100 * figures.sda:.0f} %', fontsize=9)
        days = figures.hours // 24
        hours = figures.hours % 24
        table = np.full((365, 24), np.nan)
        table[days, hours] = figures.dgp
        shown = table[:, 8:18].T
        image = axes[1, 1].imshow(shown, origin='lower', aspect='auto', cmap='inferno',
                                  vmin=0.2, vmax=0.6, extent=(0, 365, 8, 18))
        figure.colorbar(image, ax=axes[1, 1], label='DGP at the eye [-]')
        axes[1, 1].set_xlabel('day of the year')
        axes[1, 1].set_ylabel('hour (local standard time)')
        axes[1, 1].set_title(f'{name}: {figures.glare_hours} h with DGP >= {GLARE_DGP:g}',
                             fontsize=9)
    figure.tight_layout()
    figure.savefig(path, dpi=100)
    pyplot.close(figure)
    return path


if __name__ == '__main__':
    sys.exit(main())
