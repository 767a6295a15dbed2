"""Run a facade through a weather file's year (or dates) and report what each strategy achieved.

``ros2 run flectofold_ros annual_report WEATHER_FILE`` (or ``annual_report`` in the venv):
an EPW or TMY3 file, the embedded 6 x 6 demonstrator, the file's whole year at its hourly
step. The strategies: ``scheduled`` (the coordinator's controller), the other controller,
``threshold`` (an Al Bahr-like irradiance threshold with hysteresis), ``always open`` (flat),
``always closed`` (folded), and the clairvoyant ``limit``, with each one's gap to it. The
sun is seen from the file's station; the facade keeps its orientation.
"""

import argparse
from pathlib import Path
import sys
import time

FIGURES = """figures (per strategy; energies per m2 of panel footprint, mean over panels):
  blocked direct [kWh/m2]  direct sun on the panel planes, DNI x cos(incidence) x dt, that
                           the panels blocked (shading table of the facade's median panel)
  blocked [-]              that energy over the incident direct energy on the planes
  view [h]                 daylight hours (sun above the horizon) with the panel's view
                           fraction >= 0.5
  view-wtd [h]             daylight hours x view fraction: hours of full view
  moves /panel             moves a panel started in the range; moves/yr: scaled to 365 days
  budget used              moves/yr over the cycle budget, daily_move_cap x 365 (20 x 365 =
                           7300 by default): an assumption, no Flectofold hinge fatigue life
                           is published
  air [NL]                 free air of closing moves, normal litres (static baselines: one
                           full close of every panel for always closed, none for always open)
  storm clos.              mean closure while the storm latch was set (0 open/flat, the
                           vented fail-safe; 1 closed/folded); static baselines never move
  gap [h], gap [%]         view-wtd hours the strategy gives up against the limit (below)
                           at its own blocking, within the scheduler's limits; [%] of the
                           limit; negative only for the static baselines, which ignore the
                           storm latch that the limit obeys
  gap free [h]             the same against the limit without any move limit
rows: scheduled (the facade's controller: predictive unless control.controller says
target), the other controller (target rule or predictive), threshold (Al Bahr-like, 250/150
W/m2), always open, always closed, and limit: the best any schedule within the scheduler's
limits can do with the whole weather known (a clairvoyant dynamic programme per panel), at
scheduled's blocking; the lines below the table give its bracket and the families' best
members (threshold on/off swept, shading_target swept) and whether any dominates scheduled.
header lines: incident direct and diffuse (isotropic sky + ground, albedo 0.2) energy on the
panel planes [kWh/m2]; storm hours: the file's wind x --gust-factor above the storm threshold
wind_on_m_s (10 m/s), and the hours the scheduled run's storm latch was set. Months and dates
are the file's local standard time."""


def main(args=None):
    from flectofold_ros.runtime.runner import run_command
    parser = argparse.ArgumentParser(
        description=__doc__.splitlines()[0], epilog=FIGURES,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('weather_file', type=Path, help='EPW or TMY3 weather file')
    parser.add_argument('--facade', default=None,
                        help='facade description YAML or embedded name (default: the 6x6 '
                             'demonstrator; hexagon_6x6: its hexagonal counterpart)')
    parser.add_argument('--from', dest='first_date', default=None,
                        help='first local date, MM-DD or YYYY-MM-DD, year ignored (default: '
                             'the first day of the file)')
    parser.add_argument('--to', dest='last_date', default=None,
                        help='last local date, included (default: the last day of the file)')
    parser.add_argument('--step-min', type=int, default=60,
                        help='time step [min]: 10, 12, 15, 20, 30 or 60 (default 60, the '
                             'hour of the file); weather between its rows is interpolated')
    parser.add_argument('--gust-factor', type=float, default=1.0,
                        help='hourly mean wind -> storm-latch gust, in [1, 3] (default 1.0; '
                             '1.5-1.7 is the usual open-country ratio)')
    parser.add_argument('--no-families', dest='families', action='store_false',
                        help='skip the threshold and target-rule families (16 extra runs of '
                             "the scheduler, about 1.5 s each for the demonstrator's year)")
    parser.add_argument('--png', type=Path, default=None,
                        help='write the plot (monthly blocked energy and moves) here')
    parser.add_argument('--csv', type=Path, default=None,
                        help='write the monthly figures here (one row per strategy and month)')
    options = parser.parse_args((sys.argv if args is None else args)[1:])
    return run_command('annual_report', lambda stop: report_year(options), interrupted_code=130)


def report_year(options):
    """Read the file and the facade, run the report, print it, write the PNG and CSV."""
    from flectofold_model.environment import read_weather
    from flectofold_model.facade import DEFAULT_FACADE, load_facade
    from flectofold_model.scheduling.annual_report import annual_report, plot
    started = time.process_time()
    weather = read_weather(options.weather_file)
    facade = load_facade(DEFAULT_FACADE if options.facade is None else options.facade)
    for path in (options.png, options.csv):
        if path is not None and not path.parent.is_dir():
            raise ValueError(f'{path}: folder {path.parent} does not exist')
    report = annual_report(facade, weather, options.first_date, options.last_date,
                           step_min=options.step_min, gust_factor=options.gust_factor,
                           families=options.families,
                           progress=lambda text: print(f'annual_report: {text}', flush=True))
    print('\n'.join(report.lines()))
    if options.png is not None:
        print(f'plot: {plot(report, options.png).resolve()}')
    if options.csv is not None:
        print(f'csv: {write_csv(report, options.csv).resolve()}')
    print(f'cpu time: {time.process_time() - started:.1f} s')
    return 0


def write_csv(report, path):
    """Write the monthly figures: strategy, month, blocked and incident direct, moves."""
    rows = ['strategy,month,blocked_direct_kwh_m2,incident_direct_kwh_m2,moves_per_panel']
    for strategy in report.strategies:
        for month in range(12):
            if report.months[month]:
                rows.append(f'{strategy.name},{month + 1},'
                            f'{strategy.monthly_blocked_kwh_m2[month]:.4f},'
                            f'{report.monthly_incident_kwh_m2[month]:.4f},'
                            f'{strategy.monthly_actuations_per_panel[month]:.3f}')
    path.write_text('\n'.join(rows) + '\n')
    return path


if __name__ == '__main__':
    sys.exit(main())
