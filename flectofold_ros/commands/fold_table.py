"""Print the fold table of a panel: what each closure means for its actuated part and its flaps.

Run as ``ros2 run flectofold_ros fold_table`` or ``fold_table`` in the venv.
"""

import argparse
import math
import sys

import numpy as np

from flectofold_model import DEMONSTRATOR_MODULE, FoldModel, PanelBatch, PROTOTYPE
from flectofold_model.kinematics import reflection
from flectofold_model.kinematics.hexagon import HEXAGON_MODULE, HexagonBatch, HexagonFoldModel
from flectofold_model.kinematics.hexagon.panel import HexagonPanel
from flectofold_ros.runner import run_command

PANELS = {'demonstrator': DEMONSTRATOR_MODULE, 'prototype': PROTOTYPE,
          'quad': DEMONSTRATOR_MODULE, 'hexagon': HEXAGON_MODULE}

#: (name, header format, cell format, meaning) of the quad panel's columns.
COLUMNS = (
    ('closure', '{:>7}', '{:7.2f}', '0 open (the pre-fold) ... 1 closed'),
    ('fold [deg]', '{:>10}', '{:10.1f}',
     'apex fold angle of the flaps, three-point plane (the model)'),
    ('supports [mm]', '{:>13}', '{:13.2f}', 'travel of the mid-rib supports toward each other'),
    ('sag [mm]', '{:>8}', '{:8.1f}', 'sag of the bent mid-rib'),
    ('end rot [deg]', '{:>13}', '{:13.2f}', 'rotation of the mid-rib at its supports'),
    ('tip travel [mm]', '{:>15}', '{:15.1f}', 'distance a flap tip moved from the open state'),
    ('amplification', '{:>13}', '{:13.1f}', 'tip travel / support travel'),
    ('local law [deg]', '{:>15}', '{:15.1f}', '2 atan(kappa0 R), for comparison'),
)

#: (name, header format, cell format, meaning) of the hexagonal panel's columns.
HEXAGON_COLUMNS = (
    ('closure', '{:>7}', '{:7.2f}', '0 open (the pre-fold) ... 1 closed'),
    ('fold [deg]', '{:>10}', '{:10.1f}', 'fold angle at each crease apex (the model)'),
    ('rise [mm]', '{:>9}', '{:9.2f}', "centre point's rise along the triangle normal (stroke)"),
    ('vertex in [mm]', '{:>14}', '{:14.3f}',
     'inward travel of each triangle vertex, R - sqrt(R^2 - rise^2)'),
    ('spoke tilt [deg]', '{:>16}', '{:16.2f}',
     'downward tilt of the spokes from the centre to the vertices'),
    ('cone amp [deg]', '{:>14}', '{:14.2f}',
     'elevation amplitude of the central cone between spokes'),
    ('tip travel [mm]', '{:>15}', '{:15.1f}', 'distance a flap tip moved from the open state'),
    ('amplification', '{:>13}', '{:13.1f}', 'tip travel / rise travelled since open'),
)


def fold_table(panel, steps):
    """Lines of the fold table for ``steps`` closures from open to closed, either panel kind."""
    if isinstance(panel, HexagonPanel):
        return hexagon_fold_table(panel, steps)
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
    ]
    lines += _table(COLUMNS, rows)
    lines.append('fold: three-point-plane apex fold angle (the model); local law: '
                 '2 atan(kappa0 R), for comparison; amplification: tip travel / support travel')
    return lines


def hexagon_fold_table(panel, steps):
    """Lines of a hexagonal panel's fold table for ``steps`` closures from open to closed."""
    model = HexagonFoldModel(HexagonBatch.repeat(panel, steps))
    state = model.state_from_closure(np.linspace(0.0, 1.0, steps))
    rows = zip(state.closure, np.degrees(state.apex_fold_angle_rad), state.centre_rise_m * 1e3,
               state.vertex_displacement_m * 1e3, np.degrees(state.spoke_tilt_rad),
               np.degrees(state.cone_amplitude_rad), state.tip_travel_m * 1e3,
               state.amplification)
    lines = [
        f'hexagonal panel, circumradius {panel.circumradius_m:g} m ({panel.area_m2:.3f} m2, '
        f'{panel.across_flats_m:.3f} m across flats), fold-line sag '
        f'{panel.fold_line_sag_m * 1e3:.0f} mm, hinge {panel.hinge_width_m * 1e3:.0f} mm, '
        f'pre-fold {math.degrees(panel.prefold_rad):.1f} deg, closed clearance '
        f'{panel.closed_clearance_m * 1e3:.0f} mm',
        f'closed at {math.degrees(model.closed_fold_angle_rad[0]):.1f} deg apex fold after '
        f'{(model.closed_rise_m[0] - model.open_rise_m[0]) * 1e3:.1f} mm of centre rise; the '
        f'reflected crease stays within {model.crease_mismatch_m[0] * 1e3:.1f} mm of the drawn '
        f'fold line',
    ]
    lines += _table(HEXAGON_COLUMNS, rows)
    lines.append('fold: apex fold angle (the model); vertex in: R - sqrt(R^2 - rise^2); '
                 'amplification: tip travel / rise travelled since open')
    return lines


def _table(columns, rows):
    lines = ['  '.join(header.format(name) for name, header, _, _ in columns)]
    for row in rows:
        cells = (cell.format(value) if np.isfinite(value) else header.format('-')
                 for (_, header, cell, _), value in zip(columns, row))
        lines.append('  '.join(cells))
    return lines


def _legend():
    lines = ['columns, quad panels (demonstrator, prototype, quad):']
    lines += [f'  {name:<16} {meaning}' for name, _, _, meaning in COLUMNS]
    lines.append('columns, hexagonal panels (hexagon):')
    lines += [f'  {name:<16} {meaning}' for name, _, _, meaning in HEXAGON_COLUMNS]
    lines.append('a "-" marks a value that is not defined there (amplification at zero travel)')
    return '\n'.join(lines)


def main(args=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], epilog=_legend(),
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--panel', choices=sorted(PANELS), default='demonstrator',
                        help='panel preset (default: a module of the 6x6 demonstrator; quad: '
                             'the same; hexagon: the hexagonal module of about 1 m2)')
    parser.add_argument('--steps', type=int, default=11,
                        help='number of closures from open to closed (default 11)')
    options = parser.parse_args((sys.argv if args is None else args)[1:])
    if options.steps < 2:
        parser.error('--steps must be at least 2')
    return run_command('fold_table', lambda stop: print(
        '\n'.join(fold_table(PANELS[options.panel], options.steps))), interrupted_code=130)


if __name__ == '__main__':
    sys.exit(main())
