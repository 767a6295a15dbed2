"""Print the fold table of a panel: what each closure means for its actuated part and its flaps.

Run as ``ros2 run flectofold_ros fold_table`` or ``fold_table`` in the venv.
"""

import argparse
import dataclasses
import math
import sys

import numpy as np

from flectofold_model import DEMONSTRATOR_MODULE, FoldModel, PanelBatch, PROTOTYPE
from flectofold_model.actuation import actuated_like, DEMONSTRATOR_ACTUATED, StripCushion
from flectofold_model.actuation.laminate import FATIGUE_ALLOWABLE_STRAIN
from flectofold_model.actuation.statics import FLECTOLINE_ACTUATED
from flectofold_model.actuation.strain import panel_strain, strain_exceedance
from flectofold_model.kinematics import reflection
from flectofold_model.kinematics.hexagon_closure import HexagonFoldModel
from flectofold_model.kinematics.hexagon_panel import HEXAGON_MODULE, HexagonBatch
from flectofold_model.kinematics.hexagon_panel import HexagonPanel
from flectofold_model.structure.comparison import kinematic_rows, structural_rows
from flectofold_model.structure.hexagon import (HEXAGON_CONVERGED_MESH, HEXAGON_REFERENCE_MESH,
                                                hexagon_structural_path, HexagonMesh)
from flectofold_model.structure.panel import (BANDED_MESH, CONVERGED_MESH, PanelMesh,
                                              REFERENCE_MESH, structural_path)
from flectofold_ros.runtime.runner import run_command

PANELS = {'demonstrator': DEMONSTRATOR_MODULE, 'prototype': PROTOTYPE,
          'quad': DEMONSTRATOR_MODULE, 'hexagon': HEXAGON_MODULE,
          'flectoline': FLECTOLINE_ACTUATED.geometry}

#: (name, header format, cell format, meaning) of the strain columns both panel kinds print.
STRAIN_COLUMNS = (
    ('hinge [%]', '{:>9}', '{:9.2f}',
     'peak hinge surface strain, (rho - rho_open) t_h / (2 b), largest along the crease'),
    ('mid-rib [%]', '{:>11}', '{:11.2f}',
     'peak mid-rib surface strain, |kappa - kappa_open| t_m / 2 (hexagon: at the cone core)'),
    ('flap [%]', '{:>8}', '{:8.2f}',
     'peak flap surface strain, |kappa - kappa_open| t_f / 2 (the flaps bend as the mid-rib)'),
)

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
) + STRAIN_COLUMNS

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
) + STRAIN_COLUMNS


def actuated_preset(panel):
    """Return the actuated panel whose laminates the table's strains use, for a geometry.

    The demonstrator module gets ``DEMONSTRATOR_ACTUATED``, the FlectoLine-like flap
    ``FLECTOLINE_ACTUATED`` and a hexagonal panel the hexagonal preset's build
    (``HEXAGON_ACTUATED``); any other quad panel (the prototype) the
    demonstrator's laminates with a cushion sized to it as in ``radius_study`` (80 % of the
    mid-rib wide and long; the cushion does not enter the strains).
    """
    if isinstance(panel, HexagonPanel) or panel == DEMONSTRATOR_MODULE:
        return actuated_like(panel)
    if panel == FLECTOLINE_ACTUATED.geometry:
        return FLECTOLINE_ACTUATED
    cushion = StripCushion(flat_width_m=0.8 * panel.midrib_width_m,
                           length_m=0.8 * panel.length_m, mount_gap_m=0.003)
    return actuated_like(panel, dataclasses.replace(DEMONSTRATOR_ACTUATED, cushion=cushion))


def fold_table(panel, steps):
    """Lines of the fold table for ``steps`` closures from open to closed, either panel kind."""
    if isinstance(panel, HexagonPanel):
        return hexagon_fold_table(panel, steps)
    model = FoldModel(PanelBatch.repeat(panel, steps))
    state = model.state_from_closure(np.linspace(0.0, 1.0, steps))
    local = reflection.local_law_apex_fold_angle(model.batch, state.elastica_k)
    actuated = actuated_preset(panel)
    rows = zip(state.closure, np.degrees(state.apex_fold_angle_rad),
               state.support_displacement_m * 1e3, state.midrib_sag_m * 1e3,
               np.degrees(state.midrib_end_rotation_rad), state.tip_travel_m * 1e3,
               state.amplification, np.degrees(local), *_strain_columns(actuated, steps))
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
    return lines + _strain_lines(actuated)


#: (name, header format, cell format, meaning) of the structural table's columns.
STRUCTURAL_COLUMNS = (
    ('closure', '{:>7}', '{:7.2f}', '0 open (the pre-fold) ... 1 closed, by apex fold angle'),
    ('fold [deg]', '{:>10}', '{:10.1f}', 'apex fold angle across the hinge band'),
    ('at supports', '{:>11}', '{:11.1f}',
     "fold angle across the hinge band next to the supports (hexagon: the triangle's "
     'vertices) [deg] (structure)'),
    ('p [kPa]', '{:>7}', '{:7.2f}', 'cushion pressure holding the closure (structure)'),
    ('p refl', '{:>6}', '{:6.2f}', 'the same, energy statics on the reflection model [kPa]'),
    ('air [L]', '{:>7}', '{:7.2f}', 'cushion volume added since open (structure)'),
    ('air refl', '{:>8}', '{:8.2f}',
     'the same, reflection model and its cushion (strip; hexagon: round) [L]'),
    ('tip [mm]', '{:>8}', '{:8.1f}',
     'travel of flap tip A (hexagon: H_0) since open (structure)'),
    ('tip refl', '{:>8}', '{:8.1f}', 'the same, reflection model [mm]'),
    ('hinge [%]', '{:>9}', '{:9.2f}', 'peak hinge surface strain (structure)'),
    ('refl', '{:>5}', '{:5.2f}', 'the same, reflection model on the drawn line [%]'),
    ('mid-rib [%]', '{:>11}', '{:11.2f}', 'peak mid-rib surface strain (structure)'),
    ('flap [%]', '{:>8}', '{:8.2f}', 'peak flap surface strain (structure)'),
    ('held', '{:>4}', '{:>4}',
     'yes where a pressure regulator holds the closure; no beyond a pressure maximum'),
)


#: The structural meshes of ``--mesh``, per panel kind.
STRUCTURAL_MESHES = {
    'coarse': (PanelMesh(40, 4, 2, 4), HexagonMesh(24, 6, 2, 3)),
    'default': (PanelMesh(), HexagonMesh()),
    'fine': (REFERENCE_MESH, HEXAGON_REFERENCE_MESH),
    # Shown converged to 1 % in tip travel against the fine ones (msg_docs/structure.md).
    'converged': (CONVERGED_MESH, HEXAGON_CONVERGED_MESH),
    # The quad's converged mesh with its columns only in the hinge bands; no hexagon one.
    'banded': (BANDED_MESH, None),
}
#: The name in :data:`STRUCTURAL_MESHES` of the mesh taken when none is asked for (either kind).
UNASKED_MESH = 'converged'


def structural_fold_table(panel, steps, mesh=None, rrd_path=None):
    """Lines of the structural model's table beside the reflection model's, either kind.

    ``mesh`` is a :class:`PanelMesh` for a quad panel, a :class:`HexagonMesh` for a hexagonal
    one; default :data:`CONVERGED_MESH` for a quad panel, :data:`HEXAGON_CONVERGED_MESH` for
    the hexagon.
    ``rrd_path``: also write the path to a Rerun recording there
    (:mod:`flectofold_ros.rerun.structure_scene`), checked before the path is traced.
    """
    if rrd_path is not None:
        # Rerun only when asked: importing it costs the table half a second.
        from flectofold_ros.rerun.sinks import check_rrd_path
        from flectofold_ros.rerun.structure_scene import save_structural_path
        rrd_path = check_rrd_path(rrd_path)
    hexagon = isinstance(panel, HexagonPanel)
    default = STRUCTURAL_MESHES[UNASKED_MESH][hexagon]
    mesh = default if mesh is None else mesh
    actuated = actuated_preset(panel)

    def progress(pressure_pa, apex_fold_rad):
        print(f'fold_table: equilibrium at {pressure_pa / 1e3:.2f} kPa, apex fold '
              f'{math.degrees(apex_fold_rad):.1f} deg', file=sys.stderr, flush=True)

    trace = hexagon_structural_path if hexagon else structural_path
    path = trace(actuated, mesh, progress=progress)
    closures = np.linspace(0.0, 1.0, steps)
    ours, theirs = structural_rows(actuated, path, closures), kinematic_rows(actuated, closures)
    held = ['-' if np.isnan(value) else ('yes' if value else 'no')
            for value in ours.stable_at_pressure]
    rows = zip(closures, np.degrees(ours.apex_fold_rad), np.degrees(ours.support_fold_rad),
               ours.pressure_pa / 1e3, theirs.pressure_pa / 1e3, ours.air_m3 * 1e3,
               theirs.air_m3 * 1e3, ours.tip_travel_m * 1e3, theirs.tip_travel_m * 1e3,
               ours.hinge_strain * 100, theirs.hinge_strain * 100, ours.midrib_strain * 100,
               ours.flap_strain * 100, held)
    lines = [_structural_heading(panel, mesh, path)]
    lines += _table(STRUCTURAL_COLUMNS, rows)
    for index in path.limit_points:
        lines.append(f'pressure maximum {path.pressure_pa[index] / 1e3:.2f} kPa at '
                     f'{math.degrees(path.apex_fold_rad[index]):.1f} deg apex fold: beyond it a '
                     f'pressure regulator snaps the panel through')
    if path.closed_wind is not None:
        wind = path.closed_wind
        lines.append(f"closed, {wind.wind_pressure_pa / 1e3:g} kN/m2 on the flaps' inner faces "
                     f'(cushion pressure held): tip A gives {wind.tip_deflection_m * 1e3:.1f} '
                     f'mm to first order, a stiffness of {wind.stiffness_n_per_m:.0f} N/m per '
                     f'flap; valves shut (air held): {wind.air_held_tip_deflection_m * 1e3:.1f} '
                     f'mm, {wind.air_held_stiffness_n_per_m:.0f} N/m, the cushion pressure up '
                     f'{wind.air_held_pressure_rise_pa:.0f} Pa')
    if path.flap_gap_m is not None:
        lines.append(f'flaps at their closest {path.flap_gap_m[-1] * 1e3:.1f} mm apart at the '
                     f'end ({path.flap_gap_m[0] * 1e3:.1f} mm open; contact between them is '
                     f'not modelled, a path ends where they would touch)')
    for index in path.bifurcations:
        lines.append(f'bifurcation after {path.pressure_pa[index] / 1e3:.2f} kPa at '
                     f'{math.degrees(path.apex_fold_rad[index]):.1f} deg apex fold: stability '
                     f'lost with the air held too, the panel leaves this path')
    words = HEXAGON_MODE_WORDS if hexagon else MODE_WORDS
    for index, name in path.symmetry_breaking:
        lines.append(f'stability lost in a mode {name} ({words.get(name, name)}) at '
                     f'{path.air_m3[index] * 1e3:.3g} L of air, '
                     f'{path.pressure_pa[index] / 1e3:.2f} kPa, '
                     f'{math.degrees(path.apex_fold_rad[index]):.1f} deg apex fold: beyond it '
                     f'the panel leaves the symmetric path this table follows')
    for index in path.jumps:
        lines.append(f'jump to another equilibrium between {path.air_m3[index - 1] * 1e3:.3g} '
                     f'and {path.air_m3[index] * 1e3:.3g} L of air (apex fold '
                     f'{math.degrees(path.apex_fold_rad[index - 1]):.1f} -> '
                     f'{math.degrees(path.apex_fold_rad[index]):.1f} deg): the panel snaps '
                     f'there, the energy balance of that step does not hold')
    reached = math.degrees(float(np.max(path.apex_fold_rad)))
    if path.ended == 'closed':
        lines.append(f'the path reached the closed fold ({reached:.1f} deg)')
    else:
        lines.append(f'the path ended at {reached:.1f} deg apex fold: {path.ended}')
    if mesh.columns < default.columns or mesh.hinge_rows < default.hinge_rows:
        lines.append(f'a mesh coarser than the {UNASKED_MESH} one: '
                     'its pressures, pressure maxima and strains are not converged, and too few '
                     'hinge rows make pressure maxima that finer meshes do not have '
                     '(msg_docs/structure.md)')
    allowable = actuated.hinge.allowable_strain
    worst = float(np.max(path.peak_strain['hinge']))
    lines.append(f'peak hinge strain on the path {worst * 100:.2f} % against an allowable '
                 f'{allowable * 100:.1f} % ({worst / allowable:.1f} x)')
    if rrd_path is not None:
        save_structural_path(rrd_path, path, allowable)
        lines.append(f'Rerun recording {rrd_path}: the sheet at {len(path.pressure_pa)} '
                     f'equilibria, coloured by strain against the allowable')
    return lines


#: The quad panel's symmetry classes in words (``StructuralPath.symmetry_breaking``).
MODE_WORDS = {'odd in y': 'one flap closing ahead of the other',
              'odd in x': 'one end of the span ahead of the other',
              'odd in x and y': 'the flaps twisting in opposite senses'}
#: The hexagonal panel's one mirror class in words: of its symmetry group (three mirrors and
#: the three-fold turn) a mode that breaks the turn comes as a pair, one even and one odd
#: under the mirror through T_0, so both classes lose stability at the same equilibrium.
HEXAGON_MODE_WORDS = {'odd in x': 'odd under the mirror through T_0; where the even class '
                                  'loses stability at the same air, the two are one pair that '
                                  'breaks the three-fold turn: the flaps folding unequally'}


def _structural_heading(panel, mesh, path):
    """Return the structural table's first line: the panel, its mesh, the path's length."""
    count = f'{path.node_count} nodes'
    if isinstance(panel, HexagonPanel):
        return (f'structural model: hexagonal panel, circumradius {panel.circumradius_m:g} m, '
                f'fold-line sag {panel.fold_line_sag_m * 1e3:.0f} mm, hinge '
                f'{panel.hinge_width_m * 1e3:.0f} mm; mesh {count} ({mesh.columns} rays per '
                f'sector, rows {mesh.centre_rows} central / {mesh.hinge_rows} hinge / '
                f'{mesh.flap_rows} flap), {len(path.pressure_pa) - 1} equilibria')
    return (f'structural model: panel {panel.length_m:g} m x {panel.width_m:g} m, fold radius '
            f'{panel.fold_radius_m:g} m, hinge {panel.hinge_width_m * 1e3:.0f} mm; mesh '
            f'{count} ({mesh.columns} columns, rows {mesh.midrib_rows} mid-rib / '
            f'{mesh.hinge_rows} hinge / {mesh.flap_rows} flap per side'
            + (f', flap rows {mesh.flap_growth:g} x wider at the edge than by the hinge'
               if mesh.flap_growth != 1.0 else '')
            + (f', columns halving away from the hinge bands to {mesh.outer_columns}'
               if mesh.outer_columns else '')
            + f'), {len(path.pressure_pa) - 1} equilibria')


def hexagon_fold_table(panel, steps):
    """Lines of a hexagonal panel's fold table for ``steps`` closures from open to closed."""
    model = HexagonFoldModel(HexagonBatch.repeat(panel, steps))
    state = model.state_from_closure(np.linspace(0.0, 1.0, steps))
    actuated = actuated_preset(panel)
    rows = zip(state.closure, np.degrees(state.apex_fold_angle_rad), state.centre_rise_m * 1e3,
               state.vertex_displacement_m * 1e3, np.degrees(state.spoke_tilt_rad),
               np.degrees(state.cone_amplitude_rad), state.tip_travel_m * 1e3,
               state.amplification, *_strain_columns(actuated, steps))
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
    lines.append('mechanics: on the structural sheet (--model structural) this panel, moulded '
                 'with its 5 deg pre-fold, does not fold under its cushion: it rises as one '
                 'cone and its creases stay nearly flat at the apexes; moulded with 15 deg or '
                 'more it folds but loses stability at 45-65 deg (msg_docs/structure.md)')
    return lines + _strain_lines(actuated)


def _strain_columns(actuated, steps):
    """Hinge, mid-rib and flap strains [%] of ``actuated`` at ``steps`` closures."""
    strain = panel_strain([actuated] * steps, np.linspace(0.0, 1.0, steps))
    return strain.hinge_strain * 100, strain.midrib_strain * 100, strain.flap_strain * 100


def _strain_lines(actuated):
    """Return the lay-up the strains assume, the allowable strain, its source, the verdict."""
    allowable = actuated.hinge.allowable_strain
    source = ('fatigue of glass-fibre laminates at 1e7 cycles, after Mandell & Samborsky, '
              'an estimate' if allowable == FATIGUE_ALLOWABLE_STRAIN else 'set on the laminate')
    return [
        f'strains from the open state (the pre-fold is moulded in), beam theory kappa t / 2; '
        f'lay-up (estimates): hinge {actuated.hinge.thickness_m * 1e3:g} mm, mid-rib '
        f'{actuated.midrib.thickness_m * 1e3:g} mm, flaps {actuated.flap.thickness_m * 1e3:g} '
        f'mm; allowable strain {allowable * 100:.1f} % ({source})',
        strain_exceedance(actuated, 1.0),
    ]


def _table(columns, rows):
    lines = ['  '.join(header.format(name) for name, header, _, _ in columns)]
    for row in rows:
        # A zero computed as -1e-12 prints as 0.00, not -0.00.
        cells = (cell.format(value if isinstance(value, str) or abs(value) > 1e-9 else 0.0)
                 if isinstance(value, str) or np.isfinite(value)
                 else header.format('-') for (_, header, cell, _), value in zip(columns, row))
        lines.append('  '.join(cells))
    return lines


def _legend():
    lines = ['columns, quad panels (demonstrator, prototype, quad):']
    lines += [f'  {name:<16} {meaning}' for name, _, _, meaning in COLUMNS]
    lines.append('columns, hexagonal panels (hexagon):')
    lines += [f'  {name:<16} {meaning}' for name, _, _, meaning in HEXAGON_COLUMNS]
    lines.append('columns, --model structural (either kind):')
    lines += [f'  {name:<16} {meaning}' for name, _, _, meaning in STRUCTURAL_COLUMNS]
    lines.append('a "-" marks a value that is not defined there (amplification at zero travel, '
                 'closures the structural path did not reach)')
    lines.append(f'strains are peak surface strains from the open state, for the laminates of '
                 f'the presets; the line after the table compares the closed state with the '
                 f'allowable strain ({FATIGUE_ALLOWABLE_STRAIN * 100:.1f} %, fatigue of '
                 f'glass-fibre laminates at 1e7 cycles) and gives the hinge width it would need')
    return '\n'.join(lines)


def main(args=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], epilog=_legend(),
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--panel', choices=sorted(PANELS), default='demonstrator',
                        help='panel preset (default: a module of the 6x6 demonstrator; quad: '
                             'the same; hexagon: the hexagonal module of about 1 m2)')
    parser.add_argument('--steps', type=int, default=11,
                        help='number of closures from open to closed (default 11)')
    parser.add_argument('--model', choices=('kinematic', 'structural'), default='kinematic',
                        help='kinematic: the reflection model (default); structural: the '
                             'equilibrium path of the GFRP sheet under the cushion beside the '
                             'reflection model (seconds to minutes, see --mesh)')
    parser.add_argument('--mesh', choices=tuple(STRUCTURAL_MESHES),
                        help='structural mesh: converged (the default; tip travel within 1 %% '
                             'of the fine mesh at every air; quad: 160 columns, 8 hinge rows, '
                             'graded flap rows, about 15 s; hexagon: 96 rays, 8 hinge rows, '
                             'about a minute), banded (quad panels: the converged mesh with its '
                             '160 columns only in the hinge bands, 20 away from them; as close '
                             'to the fine mesh, about 6 s), default (80 columns / 48 rays, 4 '
                             'hinge rows: seconds; pressures up to 14 %% low), coarse (40 '
                             'columns / 24 rays, 2 hinge rows: not converged), fine (quad: 320 '
                             'columns, 16 graded flap rows, about a minute; hexagon: 144 rays, '
                             '12 hinge rows, minutes)')
    parser.add_argument('--rrd', metavar='OUT.rrd',
                        help='with --model structural: also write the path to a Rerun '
                             'recording, the sheet at every equilibrium coloured by its '
                             'surface strain against the allowable (msg_docs/structure.md)')
    options = parser.parse_args((sys.argv if args is None else args)[1:])
    if options.steps < 2:
        parser.error('--steps must be at least 2')
    if options.rrd is not None and options.model != 'structural':
        parser.error('--rrd needs --model structural')
    panel = PANELS[options.panel]
    if options.model == 'structural':
        hexagon = isinstance(panel, HexagonPanel)
        chosen = options.mesh or UNASKED_MESH
        mesh = STRUCTURAL_MESHES[chosen][hexagon]
        if mesh is None:
            parser.error(f'--mesh {chosen} is for quad panels: the hexagon has no banded mesh '
                         '(msg_docs/structure.md); --mesh converged is its converged one')
        return run_command('fold_table', lambda stop: print(
            '\n'.join(structural_fold_table(panel, options.steps, mesh, options.rrd))),
            interrupted_code=130)
    return run_command('fold_table', lambda stop: print(
        '\n'.join(fold_table(panel, options.steps))), interrupted_code=130)


if __name__ == '__main__':
    sys.exit(main())
