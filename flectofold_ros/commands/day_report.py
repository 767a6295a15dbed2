"""Run a facade through a day and report what its schedule achieved, with a PNG of the day.

``ros2 run flectofold_ros day_report`` (or ``day_report`` in the venv). Without arguments: the
embedded 6 x 6 demonstrator on the June solstice; ``--facade hexagon_6x6`` runs its hexagonal
counterpart (each panel kind is cast against its own meshes). The table holds the facade's
controller (``scheduled``), the other controller, the two static baselines and the limit (the
most view any schedule within the scheduler's limits keeps at scheduled's blocking, the whole
day known), each with the view it gives up against the limit; the PNG adds the frontier of
that limit with every row as a point.
"""

import argparse
from pathlib import Path
import sys
import time

from flectofold_model.facade import DEFAULT_FACADE, load_facade
from flectofold_model.scheduling.day_report import plot, simulate_day
from flectofold_ros.runtime.runner import run_command


def main(args=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--facade', type=Path, default=DEFAULT_FACADE,
                        help='facade description YAML or embedded name, quad or hexagonal '
                             'panels (default: the 6x6 demonstrator; hexagon_6x6: its '
                             'hexagonal counterpart)')
    parser.add_argument('--date', default='2026-06-21', help='local date, YYYY-MM-DD')
    parser.add_argument('--step', type=float, default=600.0, help='time step [s]')
    parser.add_argument('--out', type=Path, default=Path('out'),
                        help='folder for the PNG of the day and its frontier '
                             '(default: ./out)')
    parser.add_argument('--prefold-report', action='store_true',
                        help='also list every panel with its pre-fold')
    options = parser.parse_args((sys.argv if args is None else args)[1:])
    return run_command('day_report', lambda stop: report_day(options), interrupted_code=130)


def report_day(options):
    """Simulate the day, print its figures, write the PNG; return 0."""
    facade = load_facade(options.facade)
    started = time.monotonic()
    report = simulate_day(facade, options.date, step_s=options.step,
                          progress=lambda text: print(f'day_report: {text}', flush=True))
    print(f'day_report: done in {time.monotonic() - started:.0f} s', flush=True)
    lines = facade.report() if options.prefold_report else facade.report()[:1]
    print('\n'.join(lines + report.lines()))
    options.out.mkdir(parents=True, exist_ok=True)
    path = plot(report, options.out / f'day_{facade.name}_{options.date}.png')
    print(f'plot: {path.resolve()}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
