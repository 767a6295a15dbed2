"""Print the fold table of a panel: what each closure means for the mid-rib and the flaps.

Run as ``ros2 run flectofold_ros fold_table`` or ``fold_table`` in the venv.
"""

import argparse
import math
import sys

import numpy as np

from flectofold_model import DEMONSTRATOR_MODULE, FoldModel, PanelBatch, PROTOTYPE
from flectofold_model.kinematics import reflection
from flectofold_ros.runner import run_command

PANELS = {'demonstrator': DEMONSTRATOR_MODULE, 'prototype': PROTOTYPE}

COLUMNS = (
    ('closure', '{:>7}', '{:7.2f}'),
    ('fold [deg]', '{:>10}', '{:10.1f}'),
    ('supports [mm]', '{:>13}', '{:13.2f}'),
    ('sag [mm]', '{:>8}', '{:8.1f}'),
    ('end rot [deg]', '{:>13}', '{:13.2f}'),
    ('tip travel [mm]', '{:>15}', '{:15.1f}'),
    ('amplification', '{:>13}', '{:13.1f}'),
    ('local law [deg]', '{:>15}', '{:15.1f}'),
)


def fold_table(panel, steps):
    """Lines of the fold table for ``steps`` closures from open to closed."""
    model = FoldModel(PanelBatch.repeat(panel, steps))
    state = model.state_from_closure(np.linspace(0.0, 1.0, steps))
    local = reflection.local_law_apex_fold_angle(model.batch, state.elastica_k)
    rows = zip(state.closure, np.degrees(state.apex_fold_angle_rad),
               state.support_displacement_m * 1e3, state.midrib_sag_m * 1e3,
               np.degrees(state.midrib_end_rotation_rad), state.tip_travel_m * 1e3,
               state.amplification, np.degrees(local))
    lines = [
        f'panel {panel.length_m:g} m x {panel.width_m:g} m, fold radius {panel.fold_radius_m:g} m,'
        f' mid-rib {panel.midrib_width_m * 1e3:.0f} mm wide ({panel.midrib_end_width_m * 1e3:.0f}'
        f' mm at the supports), hinge {panel.hinge_width_m * 1e3:.0f} mm, pre-fold '
        f'{math.degrees(panel.prefold_rad):.1f} deg',
        f'closed at {math.degrees(model.closed_fold_angle_rad[0]):.1f} deg apex fold after '
        f'{model.max_support_displacement_m[0] * 1e3:.1f} mm of support travel; the reflected '
        f'crease stays within {model.crease_mismatch_m[0] * 1e3:.1f} mm of the drawn fold line',
        '  '.join(header.format(name) for name, header, _ in COLUMNS),
    ]
    for row in rows:
        cells = (cell.format(value) if np.isfinite(value) else header.format('-')
                 for (_, header, cell), value in zip(COLUMNS, row))
        lines.append('  '.join(cells))
    lines.append('fold: three-point-plane apex fold angle (the model); local law: '
                 '2 atan(kappa0 R), for comparison; amplification: tip travel / support travel')
    return lines


def main(args=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--panel', choices=sorted(PANELS), default='demonstrator',
                        help='panel preset (default: a module of the 6x6 demonstrator)')
    parser.add_argument('--steps', type=int, default=11,
                        help='number of closures from open to closed (default 11)')
    options = parser.parse_args((sys.argv if args is None else args)[1:])
    if options.steps < 2:
        parser.error('--steps must be at least 2')
    return run_command('fold_table', lambda stop: print(
        '\n'.join(fold_table(PANELS[options.panel], options.steps))), interrupted_code=130)


if __name__ == '__main__':
    sys.exit(main())
