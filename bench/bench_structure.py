"""Structural model of the panels: presets against the reflection model, mesh, CPU.

Run with ``.venv/bin/python bench/bench_structure.py [--meshes] [--presets NAME ...
[--mesh converged|banded]] [--converged [NAME ...]] [--hexagon [--prefold DEG]]
[--hexagon-converged] [--trends]
[--cushion-map]``.
Everything printed is computed here; CPU is process time of this process.

* ``--presets``: each preset's structural path on the default mesh (``--mesh converged``: on
  :data:`CONVERGED_MESH`, ``--mesh banded`` on :data:`BANDED_MESH`) beside the reflection
  model (pressure, air, tip travel, hinge strain at closures 0.25 ... 1), where it ends,
  its pressure maximum, and its CPU time against the reflection model's table of the same
  closures.
* ``--meshes``: the demonstrator on the meshes 20 / 40 / 80 columns, every count scaled alike
  (with ``--finest`` also 120 and 160); pressure and tip travel at fixed apex folds and the
  change per refinement; then at fixed air and at fixed apex fold on the last three meshes,
  the observed order of convergence and Richardson's estimate of the limit, and each mesh's
  distance from it.
* ``--converged [NAME ...]``: each preset (default all) on :data:`REFERENCE_MESH`, on
  :data:`CONVERGED_MESH`, on :data:`BANDED_MESH` and on the default mesh; the largest
  distance of tip travel and of pressure from the reference's at the same air, over 5-97 %
  of the reference's air to close, and each path's CPU and equilibria (the reference takes
  about a minute per preset).
* ``--hexagon-converged``: the hexagonal module on :data:`HEXAGON_REFERENCE_MESH`,
  :data:`HEXAGON_CONVERGED_MESH`, 72 rays and the default mesh; the largest distance of tip
  travel (relative where the reference's tip has moved more than 10 mm, in mm elsewhere) and
  of pressure from the reference's at the same air, over 5-97 % of its air (about five
  minutes).
* ``--trends``: the demonstrator's apex fold at a set pressure as hinge width, hinge modulus
  and flap modulus change one at a time (the trends Muehlich et al., Biomimetics 6(3):43,
  2021, state for elastomer-GFRP hinges: the fold rises as material stiffness falls and as
  hinge width grows, and does not depend on flap stiffness).
* ``--cushion-map``: the demonstrator's plant tables from the energy statics and from the
  structure (default mesh, cached): closing pressure, air to close, compliance; the CPU of the
  first (traced) and the second (cached) call.
* ``--hexagon``: the hexagonal module on the coarse and default meshes (and the fine one with
  ``--finest``): where its path goes and ends, against the reflection model at the same air;
  ``--prefold DEG`` moulds it with another pre-fold than the preset's 5 deg.
"""

import argparse
import dataclasses
import math
import os
import tempfile
import time

import numpy as np
from scipy.optimize import brentq

from flectofold_model import PROTOTYPE
from flectofold_model.actuation import (ActuationModel, DEMONSTRATOR_ACTUATED,
                                        FLECTOLINE_ACTUATED, HEXAGON_ACTUATED, radius_study,
                                        StripCushion)
from flectofold_model.actuation.statics import actuated_like
from flectofold_model.structure.comparison import kinematic_rows, structural_rows
from flectofold_model.structure.hexagon import (HEXAGON_CONVERGED_MESH, HEXAGON_REFERENCE_MESH,
                                                hexagon_structural_path, HexagonMesh)
from flectofold_model.structure.panel import (BANDED_MESH, CONVERGED_MESH, PanelMesh,
                                              REFERENCE_MESH, structural_path)

CLOSURES = np.array([0.25, 0.5, 0.75, 1.0])


def prototype():
    geometry = PROTOTYPE
    cushion = StripCushion(flat_width_m=0.8 * geometry.midrib_width_m,
                           length_m=0.8 * geometry.length_m, mount_gap_m=0.003)
    return actuated_like(geometry, dataclasses.replace(DEMONSTRATOR_ACTUATED, cushion=cushion))


def presets():
    study = radius_study((0.5, 0.75, 1.0))
    return {'demonstrator': DEMONSTRATOR_ACTUATED, 'prototype': prototype(),
            'flectoline-like': FLECTOLINE_ACTUATED,
            'radius 500 mm': study.panels[0], 'radius 750 mm': study.panels[1],
            'radius 1000 mm': study.panels[2]}


def cpu_of(function):
    start = time.process_time()
    result = function()
    return result, time.process_time() - start


def compare(name, actuated, mesh):
    path, cpu = cpu_of(lambda: structural_path(actuated, mesh))
    theirs, kinematic_cpu = cpu_of(lambda: kinematic_rows(actuated, CLOSURES))
    ours = structural_rows(actuated, path, CLOSURES)
    print(f'== {name}: {path.node_count} nodes, {len(path.pressure_pa) - 1} equilibria, '
          f'{cpu:.1f} s CPU (reflection model {kinematic_cpu * 1e3:.0f} ms, '
          f'{cpu / max(kinematic_cpu, 1e-9):.0f}x) ==')
    print('closure  fold  p [kPa] refl  air [L] refl  tip [mm] refl  hinge [%] refl  '
          'supports fold  support travel [mm]')
    travel = np.interp(ours.apex_fold_rad, path.apex_fold_rad, path.support_travel_m)
    for i, closure in enumerate(CLOSURES):
        print(f'{closure:7.2f} {math.degrees(ours.apex_fold_rad[i]):5.1f}  '
              f'{ours.pressure_pa[i] / 1e3:7.2f} {theirs.pressure_pa[i] / 1e3:4.2f}  '
              f'{ours.air_m3[i] * 1e3:7.2f} {theirs.air_m3[i] * 1e3:4.2f}  '
              f'{ours.tip_travel_m[i] * 1e3:8.1f} {theirs.tip_travel_m[i] * 1e3:4.0f}  '
              f'{ours.hinge_strain[i] * 100:9.2f} {theirs.hinge_strain[i] * 100:4.2f}  '
              f'{math.degrees(ours.support_fold_rad[i]):13.1f}  '
              f'{travel[i] * 1e3 if np.isfinite(ours.pressure_pa[i]) else math.nan:19.2f}')
    if path.closed_wind is not None:
        wind = path.closed_wind
        statics = ActuationModel([actuated]).wind_response(wind.wind_pressure_pa)
        print(f"closed, {wind.wind_pressure_pa / 1e3:g} kN/m2 on the flaps' inner faces, "
              f'cushion pressure held: tip A gives {wind.tip_deflection_m * 1e3:.1f} mm, '
              f'apex fold {math.degrees(wind.apex_fold_change_rad):+.1f} deg (linear), '
              f'stiffness {wind.stiffness_n_per_m:.0f} N/m per flap (energy statics: '
              f'{float(statics.tip_deflection_m[0]) * 1e3:.1f} mm, '
              f'{float(statics.stiffness_n_per_m[0]):.0f} N/m); valves shut (air held): '
              f'{wind.air_held_tip_deflection_m * 1e3:.1f} mm, '
              f'{wind.air_held_stiffness_n_per_m:.0f} N/m, cushion pressure up '
              f'{wind.air_held_pressure_rise_pa:.0f} Pa, its volume '
              f'{wind.air_held_volume_change_m3 * 1e6:+.1f} mL')
    if path.flap_gap_m is not None:
        print(f'flaps at their closest {path.flap_gap_m[-1] * 1e3:.1f} mm apart at the end '
              f'({path.flap_gap_m[0] * 1e3:.1f} mm open)')
    for index in path.limit_points:
        print(f'pressure maximum {path.pressure_pa[index] / 1e3:.2f} kPa at '
              f'{math.degrees(path.apex_fold_rad[index]):.1f} deg')
    for index in path.bifurcations:
        print(f'bifurcation after {path.pressure_pa[index] / 1e3:.2f} kPa at '
              f'{math.degrees(path.apex_fold_rad[index]):.1f} deg')
    for index, name in path.symmetry_breaking:
        print(f'stability lost in a mode {name} at {path.air_m3[index] * 1e3:.3g} L, '
              f'{path.pressure_pa[index] / 1e3:.2f} kPa, apex fold '
              f'{math.degrees(path.apex_fold_rad[index]):.1f} deg')
    for index in path.jumps:
        print(f'jump to another branch at {path.air_m3[index] * 1e3:.3g} L, apex fold '
              f'{math.degrees(path.apex_fold_rad[index]):.1f} deg')
    print(f'ended: {path.ended}; largest apex fold '
          f'{math.degrees(path.apex_fold_rad.max()):.1f} deg at '
          f'{path.pressure_pa[np.argmax(path.apex_fold_rad)] / 1e3:.2f} kPa; strain energy '
          f'{path.strain_energy_j[-1]:.2f} J; peak strains hinge '
          f'{path.peak_strain["hinge"].max() * 100:.2f} %, mid-rib '
          f'{path.peak_strain["midrib"].max() * 100:.2f} %, flap '
          f'{path.peak_strain["flap"].max() * 100:.2f} %')
    print()


def meshes(factors):
    folds = np.radians([20.0, 40.0, 60.0])
    print('== mesh refinement, demonstrator: at apex folds 20 / 40 / 60 deg ==')
    previous, paths = None, []
    for factor in factors:
        mesh = PanelMesh(20, 2, 1, 2).refined(factor)
        path, cpu = cpu_of(lambda: structural_path(DEMONSTRATOR_ACTUATED, mesh))
        reach = path.apex_fold_rad.max()
        pressure = np.where(folds <= reach, np.interp(folds, path.apex_fold_rad,
                                                      path.pressure_pa), np.nan)
        tip = np.where(folds <= reach, np.interp(folds, path.apex_fold_rad, path.tip_travel_m),
                       np.nan)
        line = (f'{mesh.columns:3d} columns, hinge rows {mesh.hinge_rows}: {path.node_count:5d} '
                f'nodes, {cpu:7.1f} s CPU; p [kPa] '
                + ' / '.join(f'{p / 1e3:.3f}' for p in pressure) + '; tip [mm] '
                + ' / '.join(f'{t * 1e3:.1f}' for t in tip)
                + f'; reached {math.degrees(reach):.1f} deg ({path.ended[:40]})')
        if previous is not None:
            line += '; change in p ' + ' / '.join(
                f'{(p - q) / q * 100:+.2f} %' for p, q in zip(pressure, previous))
        print(line, flush=True)
        previous = pressure
        paths.append((factor, path))
    if len(paths) >= 3:
        at_fixed(paths[-3:], 'air')
        at_fixed(paths[-3:], 'apex fold')


def observed_order(sizes, values):
    """Order ``q`` and limit of ``f(h) = f0 + c h^q`` through three meshes' values.

    ``sizes`` the element sizes (any ratios, decreasing), ``values`` the values on them;
    None where the three are not monotone in ``h`` (no order to read).
    """
    h1, h2, h3 = sizes
    f1, f2, f3 = values
    ratio = (f1 - f2) / (f2 - f3)
    if not np.isfinite(ratio) or ratio <= 0.0:
        return None

    def mismatch(q):
        return (h1**q - h2**q) / (h2**q - h3**q) - ratio

    if mismatch(0.05) * mismatch(10.0) > 0.0:
        return None
    order = brentq(mismatch, 0.05, 10.0)
    return order, f3 + (f3 - f2) / ((h2 / h3)**order - 1.0)


def at_fixed(paths, along):
    """Quantities on the last three meshes at fixed air or apex fold, their order and limit."""
    finest = paths[-1][1]
    sizes = [1.0 / factor for factor, _ in paths]
    if along == 'air':
        places = np.array([0.25, 0.5, 0.75, 0.95]) * finest.air_m3[-1]
        print("== at fixed air (fractions 0.25 / 0.5 / 0.75 / 0.95 of the finest mesh's air to "
              'close: ' + ' / '.join(f'{a * 1e3:.2f}' for a in places) + ' L); order and '
              'limit from the last three meshes (Richardson) ==')
        quantities = (('tip travel', 'tip_travel_m', 1e3, 'mm'),
                      ('pressure', 'pressure_pa', 1e-3, 'kPa'))
        where, unit_of_place = 'air_m3', (1e3, 'L')
    else:
        places = np.radians([20.0, 40.0, 60.0, 80.0])
        print('== at fixed apex fold (20 / 40 / 60 / 80 deg); order and limit from the last '
              'three meshes (Richardson) ==')
        quantities = (('tip travel', 'tip_travel_m', 1e3, 'mm'),
                      ('pressure', 'pressure_pa', 1e-3, 'kPa'), ('air', 'air_m3', 1e3, 'L'))
        where, unit_of_place = 'apex_fold_rad', (180.0 / math.pi, 'deg')
    for label, key, scale, unit in quantities:
        values = np.array([np.interp(places, getattr(path, where), getattr(path, key))
                           for _, path in paths])
        for index, (_, path) in enumerate(paths):
            print(f'{label} [{unit}], {path.node_count:5d} nodes: '
                  + ' / '.join(f'{v * scale:.3f}' for v in values[index]))
        for column, place in enumerate(places):
            at = f'  at {place * unit_of_place[0]:.2f} {unit_of_place[1]}'
            found = observed_order(sizes, values[:, column])
            if found is None:
                print(f'{at}: not monotone under refinement, no order read')
                continue
            order, limit = found
            offs = ' / '.join(f'{(v / limit - 1.0) * 100:+.2f} %' for v in values[:, column])
            print(f'{at}: order {order:.2f}, limit {limit * scale:.3f} {unit}; the meshes off '
                  f'it by {offs}', flush=True)


def against_reference(meshes, trace):
    """Trace ``trace(mesh)`` on each of ``(label, mesh)``, the first the reference.

    Yields label, path, its CPU and the airs to compare it at with the reference's: 5-97 % of
    the reference's air to its end; None for the reference itself and for a path that ends
    short of them.
    """
    reference = None
    for label, mesh in meshes:
        path, cpu = cpu_of(lambda: trace(mesh))
        airs = None
        if reference is None:
            reference = path
        else:
            # Paths count their air from the open state: air_m3[0] is 0.
            airs = np.linspace(0.05, 0.97, 185) * reference.air_m3[-1]
            if path.air_m3[-1] < airs[-1]:
                airs = None
        yield label, path, cpu, reference, airs


def largest_off(airs, path, reference, values, where=None):
    """Return the largest relative distance of ``values(path)`` from the reference's.

    Read at ``airs`` (only where ``where`` is True, if given); with the air it is at.
    """
    off = (np.interp(airs, path.air_m3, values(path))
           / np.interp(airs, reference.air_m3, values(reference)) - 1.0)
    if where is not None:
        off = np.where(where, off, 0.0)
    worst = int(np.argmax(np.abs(off)))
    return off[worst], airs[worst]


def converged(names):
    """Tip travel and pressure of the converged and default meshes against the reference's."""
    chosen = presets()
    meshes = (('reference', REFERENCE_MESH), ('converged', CONVERGED_MESH),
              ('banded', BANDED_MESH), ('default', PanelMesh()))
    print('== meshes against the reference at the same air, 5-97 % of its air to close: '
          + '; '.join(f'{label} {m.columns} columns, rows {m.midrib_rows} / {m.hinge_rows} / '
                      f'{m.flap_rows} (mid-rib / hinge / flap), flap growth {m.flap_growth:g}'
                      + (f', {m.outer_columns} columns away from the bands'
                         if m.outer_columns else '')
                      for label, m in meshes) + ' ==')
    for name in names or chosen:
        for label, path, cpu, reference, airs in against_reference(
                meshes, lambda mesh: structural_path(chosen[name], mesh)):
            line = (f'{name}, {label}: {path.node_count} nodes, {len(path.pressure_pa) - 1} '
                    f'equilibria, {cpu:.1f} s CPU, ended {path.ended[:48]}, air to end '
                    f'{(path.air_m3[-1] - path.air_m3[0]) * 1e3:.2f} L')
            if path is not reference and airs is None:
                line += '; ends short of the reference'
            elif airs is not None:
                for key, word in (('tip_travel_m', 'tip travel'), ('pressure_pa', 'pressure')):
                    off, air = largest_off(airs, path, reference,
                                           lambda p, key=key: getattr(p, key))
                    line += f'; {word} at most {off * 100:+.2f} % off (at {air * 1e3:.2f} L)'
            print(line, flush=True)


def hexagon_converged():
    """Print the hexagonal module's tip travel and pressure on four meshes against the finest."""
    meshes = (('reference', HEXAGON_REFERENCE_MESH), ('converged', HEXAGON_CONVERGED_MESH),
              ('coarser', HexagonMesh(72, 18, 6, 9)), ('default', HexagonMesh()))
    print('== the hexagonal module (preset pre-fold) against the reference at the same air, '
          '5-97 % of its air: the tip relative where it has moved more than 10 mm, else in mm; '
          + '; '.join(f'{label} {m.columns} rays, rows {m.centre_rows} / {m.hinge_rows} / '
                      f'{m.flap_rows} (central / hinge / flap)' for label, m in meshes) + ' ==')
    for label, path, cpu, reference, airs in against_reference(
            meshes, lambda mesh: hexagon_structural_path(HEXAGON_ACTUATED, mesh)):
        line = (f'{label}: {path.node_count} nodes, {len(path.pressure_pa) - 1} equilibria, '
                f'{cpu:.1f} s CPU, ended {path.ended[:48]}; at the end {path.air_m3[-1] * 1e3:.2f}'
                f' L, {path.pressure_pa[-1]:.0f} Pa, tip {path.tip_travel_m[-1] * 1e3:.1f} mm')
        if path is not reference and airs is None:
            line += '; ends short of the reference'
        elif airs is not None:
            theirs = np.interp(airs, reference.air_m3, reference.tip_travel_m)
            moved = theirs > 0.01
            off, air = largest_off(airs, path, reference, lambda p: p.tip_travel_m, moved)
            under = np.abs(np.interp(airs, path.air_m3, path.tip_travel_m) - theirs)[~moved]
            line += (f'; tip at most {off * 100:+.2f} % off (at {air * 1e3:.1f} L), '
                     f'{np.max(under, initial=0.0) * 1e3:.2f} mm where under 10 mm')
            off, air = largest_off(airs, path, reference, lambda p: p.pressure_pa)
            line += f'; pressure at most {off * 100:+.2f} % off (at {air * 1e3:.1f} L)'
        print(line, flush=True)


def trends(pressure_pa=1500.0):
    base = DEMONSTRATOR_ACTUATED
    geometry = base.geometry

    def hinge_width(width):
        return actuated_like(dataclasses.replace(geometry, hinge_width_m=width), base)

    variants = [
        ('baseline (hinge 30 mm, 2 GPa; flaps 20 GPa)', base),
        ('hinge width 20 mm', hinge_width(0.02)), ('hinge width 25 mm', hinge_width(0.025)),
        ('hinge modulus 1 GPa', dataclasses.replace(
            base, hinge=dataclasses.replace(base.hinge, youngs_modulus_pa=1e9))),
        ('hinge modulus 4 GPa', dataclasses.replace(
            base, hinge=dataclasses.replace(base.hinge, youngs_modulus_pa=4e9))),
        ('flap modulus 10 GPa', dataclasses.replace(
            base, flap=dataclasses.replace(base.flap, youngs_modulus_pa=1e10))),
        ('flap modulus 40 GPa', dataclasses.replace(
            base, flap=dataclasses.replace(base.flap, youngs_modulus_pa=4e10))),
    ]
    mesh = PanelMesh(40, 4, 2, 4)
    print(f'== apex fold at {pressure_pa / 1e3:g} kPa, demonstrator, {mesh.columns} columns, '
          f'{mesh.hinge_rows} hinge rows ==')
    for name, actuated in variants:
        path, cpu = cpu_of(lambda: structural_path(actuated, mesh,
                                                   target_fold_rad=math.radians(50.0)))
        rising = path.pressure_pa <= pressure_pa
        fold = (np.interp(pressure_pa, path.pressure_pa, path.apex_fold_rad)
                if path.pressure_pa.max() >= pressure_pa and np.all(np.diff(path.pressure_pa) > 0)
                else math.nan)
        print(f'{name:46s} apex fold {math.degrees(fold):6.2f} deg  ({int(rising.sum())} '
              f'equilibria below, {cpu:.0f} s CPU)', flush=True)


def cushion_map():
    from flectofold_model.actuation import ActuationModel, ATMOSPHERIC_PRESSURE_PA
    from flectofold_model.actuation.cushion_map import CushionMap
    from flectofold_model.structure.cushion_tables import (CACHE_ENVIRONMENT,
                                                           structural_cushion_map)

    print("== the demonstrator's cushion map: energy statics against the structure ==")
    statics, statics_cpu = cpu_of(lambda: CushionMap(ActuationModel([DEMONSTRATOR_ACTUATED])))
    # A cache of its own, empty: the first call traces the path, the second reads it.
    with tempfile.TemporaryDirectory() as directory:
        os.environ[CACHE_ENVIRONMENT] = directory
        first, first_cpu = cpu_of(lambda: structural_cushion_map([DEMONSTRATOR_ACTUATED]))
        again, again_cpu = cpu_of(lambda: structural_cushion_map([DEMONSTRATOR_ACTUATED]))
    assert np.array_equal(first.pressure_pa, again.pressure_pa)
    for name, table, cpu in (('energy statics', statics, statics_cpu),
                             ('structure', first, first_cpu), ('structure, cached', again,
                                                               again_cpu)):
        pressure, volume = table.pressure_pa[0], table.volume_m3[0]
        # Free air to close from open: the air mass added, at atmospheric pressure [L].
        free_air = ((pressure[-1] + ATMOSPHERIC_PRESSURE_PA) * volume[-1]
                    - ATMOSPHERIC_PRESSURE_PA * volume[0]) / ATMOSPHERIC_PRESSURE_PA
        half = len(pressure) // 2
        print(f'{name:18s} p at closure 0.5 / 1: {pressure[half] / 1e3:.2f} / '
              f'{pressure[-1] / 1e3:.2f} kPa; volume open / closed {volume[0] * 1e3:.2f} / '
              f'{volume[-1] * 1e3:.2f} L; free air to close {free_air * 1e3:.1f} NL; '
              f'compliance at 0.5 {table.compliance_m3_per_pa[0, half] * 1e6:.3f} mL/Pa; '
              f'{cpu:.3f} s CPU', flush=True)

    # The simulated plant and pressure loop of the package on each map: one panel from open
    # to closure 0.5 and then to 1; time to within 0.01 of the setpoint and free air used.
    from flectofold_model.control.panel_loops import facade_plant, PanelLoops, SimulatedCushions
    for name, table in (('energy statics', statics), ('structure', first)):
        model = ActuationModel([DEMONSTRATOR_ACTUATED])
        loops = PanelLoops(model, SimulatedCushions(facade_plant(model, table)), 0.1,
                           cushion_map=table)
        loops.advance_to(0.0)
        line, now, start = [], 0.0, 0.0
        for target in (0.5, 1.0):
            loops.set_setpoints(np.array([target]))
            air = float(loops.free_air_used_nl[0])
            while abs(float(loops.closure[0]) - target) > 0.01 and now - start < 600.0:
                now += 0.1
                loops.advance_to(now)
            line.append(f'to {target:g}: {now - start:.1f} s, '
                        f'{float(loops.free_air_used_nl[0]) - air:.1f} NL')
            start = now
        print(f'{name:18s} plant on the demonstrator circuit: ' + '; '.join(line), flush=True)


def hexagon(finest, prefold_deg=None):
    panel = HEXAGON_ACTUATED
    if prefold_deg is not None:
        panel = dataclasses.replace(panel, geometry=dataclasses.replace(
            panel.geometry, prefold_rad=math.radians(prefold_deg)))
    print(f'== the hexagonal module under its round cushion, moulded pre-fold '
          f'{math.degrees(panel.geometry.prefold_rad):g} deg ==')
    closures = np.linspace(0.0, 1.0, 201)
    theirs = kinematic_rows(HEXAGON_ACTUATED, closures)
    meshes = [HexagonMesh(24, 6, 2, 3), HexagonMesh()]
    if finest:
        meshes.append(HEXAGON_CONVERGED_MESH)
    for mesh in meshes:
        path, cpu = cpu_of(lambda: hexagon_structural_path(panel, mesh))
        print(f'{mesh.columns} rays per sector, hinge rows {mesh.hinge_rows}: '
              f'{path.node_count} nodes, {len(path.pressure_pa) - 1} equilibria, '
              f'{cpu:.1f} s CPU', flush=True)
        print('   air [L]  p [Pa]  apex fold [deg]  at vertices [deg]  tip [mm]  '
              'vertex in [mm]  held | reflection model at that air: closure  fold [deg]  '
              'p [Pa]  tip [mm]')
        for i in range(0, len(path.pressure_pa), max(1, len(path.pressure_pa) // 10)):
            air = path.air_m3[i]
            closure = np.interp(air, theirs.air_m3, closures)
            at = (lambda values: np.interp(air, theirs.air_m3, values))
            print(f'   {air * 1e3:7.2f} {path.pressure_pa[i]:7.1f} '
                  f'{math.degrees(path.apex_fold_rad[i]):16.2f} '
                  f'{math.degrees(path.support_fold_rad[i]):18.2f} '
                  f'{path.tip_travel_m[i] * 1e3:9.1f} {path.support_travel_m[i] * 1e3:15.3f}  '
                  f'{"yes" if path.stable_at_pressure[i] else "no ":>4} | '
                  f'{closure:38.3f} {math.degrees(at(theirs.apex_fold_rad)):10.1f} '
                  f'{at(theirs.pressure_pa):7.0f} {at(theirs.tip_travel_m) * 1e3:9.1f}')
        for name, indices in (('pressure maximum', path.limit_points),
                              ('bifurcation after', path.bifurcations),
                              ('jump to another branch at', np.asarray(path.jumps))):
            for index in indices:
                print(f'   {name} {path.pressure_pa[index]:.1f} Pa at '
                      f'{path.air_m3[index] * 1e3:.2f} L, apex fold '
                      f'{math.degrees(path.apex_fold_rad[index]):.2f} deg')
        for index, name in path.symmetry_breaking:
            after = path.negative_by_class[index]
            before = path.negative_by_class[index - 1] if index else 0 * after
            print(f'   stability lost in a mode {name} at {path.air_m3[index] * 1e3:.2f} L, '
                  f'apex fold {math.degrees(path.apex_fold_rad[index]):.2f} deg; negative '
                  f'eigenvalues per class {before.tolist()} -> {after.tolist()} '
                  f'({", ".join(path.class_names)})')
        print(f'   largest apex fold {math.degrees(path.apex_fold_rad.max()):.1f} deg; '
              f'ended: {path.ended}; peak strains hinge '
              f'{path.peak_strain["hinge"].max() * 100:.2f} %, central part '
              f'{path.peak_strain["midrib"].max() * 100:.2f} %, flap '
              f'{path.peak_strain["flap"].max() * 100:.2f} %', flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--meshes', action='store_true')
    parser.add_argument('--finest', action='store_true',
                        help='with --meshes, also 120 and 160 columns (6 and 8 hinge rows; '
                        'minutes)')
    parser.add_argument('--presets', nargs='*')
    parser.add_argument('--mesh', choices=('default', 'converged', 'banded'), default='default',
                        help='with --presets, the mesh the paths are traced on')
    parser.add_argument('--hexagon', action='store_true')
    parser.add_argument('--prefold', type=float, metavar='DEG',
                        help="with --hexagon, the module's moulded pre-fold (preset: 5 deg)")
    parser.add_argument('--converged', nargs='*', metavar='NAME')
    parser.add_argument('--hexagon-converged', action='store_true')
    parser.add_argument('--trends', action='store_true')
    parser.add_argument('--cushion-map', action='store_true')
    options = parser.parse_args()
    if options.presets is not None:
        chosen = presets()
        for name in options.presets or chosen:
            compare(name, chosen[name],
                    {'converged': CONVERGED_MESH, 'banded': BANDED_MESH}.get(options.mesh,
                                                                             PanelMesh()))
    if options.converged is not None:
        converged(options.converged)
    if options.hexagon_converged:
        hexagon_converged()
    if options.meshes:
        meshes((1, 2, 4, 6, 8) if options.finest else (1, 2, 4))
    if options.trends:
        trends()
    if options.cushion_map:
        cushion_map()
    if options.hexagon:
        hexagon(options.finest, options.prefold)


if __name__ == '__main__':
    main()
