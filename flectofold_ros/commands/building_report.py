"""Run the room behind a facade through a weather file with EnergyPlus, the controller in its loop.

``ros2 run flectofold_ros building_report WEATHER.epw`` (or ``building_report`` in the venv):
a shoebox office (6 x 6 x 3.5 m, a south window of 60 % of the wall) behind the embedded
6 x 6 demonstrator, the file's whole year at EnergyPlus's 10-minute step, for every strategy
(the facade's controller, the other controller, the threshold rule, always open, always
closed) and the room without a facade: cooling, heating and lighting energy, peak cooling,
solar gain, the facade's mean transmittance, moves and air. An EPW file, or a TMY3 file
rewritten as one for EnergyPlus (``flectofold_model.environment.epw``);
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
    from flectofold_ros.runner import run_command
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
                             'predictive')
    parser.add_argument('--csv', type=Path, default=None, help='write the table here')
    parser.add_argument('--png', type=Path, default=None,
                        help='write a bar chart of the energies here')
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
            progress=lambda text: print(f'building_report: {text}', flush=True))
    print('\n'.join(result.lines()))
    if options.csv is not None:
        fields = ('name', 'cooling_kwh_m2', 'heating_kwh_m2', 'lighting_kwh_m2',
                  'peak_cooling_w_m2', 'transmitted_solar_kwh', 'mean_transmittance',
                  'moves_per_panel', 'air_nl')
        lines = [','.join(fields)] + [','.join(str(getattr(r, f)) for f in fields)
                                      for r in result.rows]
        options.csv.write_text('\n'.join(lines) + '\n')
        print(f'csv: {options.csv.resolve()}')
    if options.png is not None:
        print(f'plot: {plot(result, options.png).resolve()}')
    print(f'cpu time: {time.process_time() - started:.1f} s')
    return 0


def plot(result, path):
    """Write a PNG: cooling, heating and lighting per strategy, and the solar gain."""
    import matplotlib
    matplotlib.use('Agg')
    from matplotlib import pyplot
    import numpy as np
    names = [r.name for r in result.rows]
    x = np.arange(len(names))
    figure, axes = pyplot.subplots(2, 1, figsize=(10, 7), sharex=True)
    bottom = np.zeros(len(names))
    for field, colour in (('cooling_kwh_m2', 'tab:blue'), ('heating_kwh_m2', 'tab:red'),
                          ('lighting_kwh_m2', 'gold')):
        values = np.array([getattr(r, field) for r in result.rows])
        axes[0].bar(x, values, 0.6, bottom=bottom, color=colour,
                    label=field.split('_')[0])
        bottom += values
    axes[0].set_ylabel('energy per m2 of floor [kWh/m2]')
    axes[0].legend(fontsize=8)
    (m0, d0), (m1, d1) = result.run_period
    axes[0].set_title(f'{result.facade_name} before a shoebox office, {m0:02d}-{d0:02d} to '
                      f'{m1:02d}-{d1:02d}\n{result.source}', fontsize=9)
    axes[1].bar(x, [r.transmitted_solar_kwh for r in result.rows], 0.6, color='tab:orange')
    axes[1].set_ylabel('solar transmitted by the window [kWh]')
    axes[1].set_xticks(x)
    axes[1].set_xticklabels(names, fontsize=8)
    figure.tight_layout()
    figure.savefig(path, dpi=100)
    pyplot.close(figure)
    return path


if __name__ == '__main__':
    sys.exit(main())
