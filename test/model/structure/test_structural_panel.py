"""A quad panel on the structural sheet: its mesh, its moulded pre-fold and its path."""

from dataclasses import replace
import math

import numpy as np
import pytest

from flectofold_model.actuation import DEMONSTRATOR_ACTUATED, PlantParameters
from flectofold_model.kinematics.panel import PanelGeometry
from flectofold_model.structure.comparison import kinematic_rows, structural_rows
from flectofold_model.structure.panel import (apex_fold_angle_rad, build_panel_sheet,
                                              DEAD_VOLUME_M3, equilibrium_system, FLAP,
                                              HINGE, MIDRIB, mould_prefold, PanelMesh,
                                              structural_path, StructuralPath, wind_on_flaps)
from flectofold_model.structure.sheet import SheetSystem, trace_path

COARSE = PanelMesh(20, 2, 2, 2)
#: The path of the tests ends at a 36 deg apex fold (closure 0.36), well before the
#: demonstrator's pressure maximum, so that it is smooth on the coarse mesh.
TARGET_FOLD_RAD = math.radians(36.0)


@pytest.fixture(scope='module')
def panel_sheet():
    return build_panel_sheet(DEMONSTRATOR_ACTUATED, COARSE)


@pytest.fixture(scope='module')
def path():
    return structural_path(DEMONSTRATOR_ACTUATED, COARSE, target_fold_rad=TARGET_FOLD_RAD,
                           steps=48)


def test_the_hinge_bands_lie_between_arcs_concentric_with_the_drawn_fold_line(panel_sheet):
    geometry = DEMONSTRATOR_ACTUATED.geometry
    centre = np.array([0.0, geometry.midrib_width_m / 2 - geometry.fold_radius_m])
    xy = panel_sheet.sheet.reference_xy_m
    for row, radius in ((panel_sheet.inner_row, geometry.fold_radius_m
                         - geometry.hinge_width_m / 2),
                        (panel_sheet.outer_row, geometry.fold_radius_m
                         + geometry.hinge_width_m / 2)):
        distance = np.linalg.norm(xy[panel_sheet.grid[:, row]] - centre, axis=1)
        assert distance == pytest.approx(radius, abs=1e-12)
    zone = panel_sheet.sheet.zone
    assert set(np.unique(zone)) == {MIDRIB, HINGE, FLAP}
    hinge_area = SheetSystem(panel_sheet.sheet).area[zone == HINGE].sum()
    # Two bands of the hinge width along arcs of about the length: the chords of the mesh
    # cut the arcs by a little.
    arc = 2 * geometry.fold_radius_m * math.asin(geometry.length_m / 2
                                                 / geometry.fold_radius_m)
    assert hinge_area == pytest.approx(2 * geometry.hinge_width_m * arc, rel=0.01)


def test_the_mesh_keeps_both_mirror_symmetries(panel_sheet):
    assert_mirror_symmetric(panel_sheet)


def assert_mirror_symmetric(panel_sheet):
    xy = panel_sheet.sheet.reference_xy_m
    points = {tuple(np.round(p, 12)) for p in xy}
    for mirror in ((1, -1), (-1, 1)):
        assert {tuple(np.round(p * mirror, 12)) for p in xy} == points
    zone = panel_sheet.sheet.zone
    centroid = xy[panel_sheet.sheet.triangles].mean(axis=1)
    for kind in (MIDRIB, HINGE, FLAP):
        upper = np.count_nonzero((zone == kind) & (centroid[:, 1] > 0))
        lower = np.count_nonzero((zone == kind) & (centroid[:, 1] < 0))
        assert upper == lower


@pytest.mark.parametrize('field, value', [('columns', 3), ('columns', 2), ('columns', 0),
                                          ('hinge_rows', 0), ('flap_rows', -1),
                                          ('midrib_rows', 1.5)])
def test_a_mesh_refuses_counts_it_cannot_mesh(field, value):
    with pytest.raises(ValueError, match=field):
        replace(PanelMesh(), **{field: value})


def test_the_smallest_mesh_is_accepted():
    assert PanelMesh(4, 1, 1, 1).refined(2) == PanelMesh(8, 2, 2, 2)
    assert PanelMesh() == PanelMesh(80, 8, 4, 8, 1.0)


@pytest.mark.parametrize('growth', [0.0999, 10.001, 0.0, -2.0, math.nan, math.inf, True, '2'])
def test_a_mesh_refuses_a_flap_growth_beyond_its_bounds(growth):
    with pytest.raises(ValueError, match='flap_growth must be a number from 0.1 to 10'):
        PanelMesh(flap_growth=growth)


@pytest.mark.parametrize('growth', [0.1, 1, 4.0, 10.0])
def test_the_flap_rows_grow_geometrically_from_the_hinge_by_the_flap_growth(growth):
    mesh = PanelMesh(8, 2, 1, 5, growth)
    sheet = build_panel_sheet(DEMONSTRATOR_ACTUATED, mesh)
    assert mesh.refined(2).flap_growth == growth
    y = sheet.sheet.reference_xy_m[:, 1].reshape(sheet.grid.shape)
    widths = np.diff(y[:, sheet.outer_row:], axis=1)
    assert widths.shape[1] == 5
    # The flap's edge stays where the panel's is, and each row is the one before times the
    # same factor, the last ``growth`` times the first, at every column.
    assert y[:, -1] == pytest.approx(DEMONSTRATOR_ACTUATED.geometry.width_m / 2, abs=1e-15)
    ratios = widths[:, 1:] / widths[:, :-1]
    assert ratios == pytest.approx(np.full_like(ratios, float(growth) ** 0.25), rel=1e-12)
    assert widths[:, -1] / widths[:, 0] == pytest.approx(np.full(9, float(growth)), rel=1e-12)


def test_hinge_bands_that_meet_on_the_axis_at_the_supports_are_refused():
    geometry = DEMONSTRATOR_ACTUATED.geometry
    narrow = PanelGeometry.with_lens_midrib(
        length_m=geometry.length_m, width_m=geometry.width_m,
        fold_radius_m=geometry.fold_radius_m, end_width_m=0.02, hinge_width_m=0.03)
    with pytest.raises(ValueError, match='hinge bands meet on the axis'):
        build_panel_sheet(replace(DEMONSTRATOR_ACTUATED, geometry=narrow), COARSE)
    wide_enough = PanelGeometry.with_lens_midrib(
        length_m=geometry.length_m, width_m=geometry.width_m,
        fold_radius_m=geometry.fold_radius_m, end_width_m=0.04, hinge_width_m=0.03)
    build_panel_sheet(replace(DEMONSTRATOR_ACTUATED, geometry=wide_enough), COARSE)


def test_the_moulded_open_shape_holds_the_prefold_and_is_stress_free(panel_sheet):
    prefold = DEMONSTRATOR_ACTUATED.geometry.prefold_rad
    sheet, start, off_isometric = mould_prefold(panel_sheet, prefold)
    system = SheetSystem(sheet)
    positions = system.positions(start)
    assert apex_fold_angle_rad(panel_sheet, positions) == pytest.approx(prefold, rel=0.01)
    assert system.energies_j(start) == pytest.approx((0.0, 0.0), abs=1e-15)
    gradient, _ = system.gradients(start)
    assert np.max(np.abs(gradient)) < 1e-7
    # The mould is nearly isometric to the flat pattern: held on the flat metric it would
    # store a few mJ, against about 0.6 J of strain energy at a 40 deg fold.
    assert 0.0 < off_isometric < 5e-3
    assert positions[panel_sheet.tip_node][2] > 0.0


def test_the_path_balances_the_cushion_work_and_the_strain_energy_at_every_step(path):
    assert path.ended == 'closed'
    assert len(path.pressure_pa) >= 21
    steps = np.diff(path.air_m3)
    # Simpson's rule over pairs of equal steps (fourth order): the balance is then limited
    # by the solver's convergence, not by the quadrature.
    pairs = (len(steps) // 2) * 2
    assert steps[:pairs] == pytest.approx(steps[0], rel=1e-9)
    pressure, energy = path.pressure_pa, path.strain_energy_j
    for first in range(0, pairs, 2):
        work = steps[first] / 3 * (pressure[first] + 4 * pressure[first + 1]
                                   + pressure[first + 2])
        stored = energy[first + 2] - energy[first]
        assert stored == pytest.approx(work, rel=1e-3)


def test_the_path_closes_monotonically_and_is_stable_under_either_control(path):
    assert np.all(np.diff(path.apex_fold_rad) > 0.0)
    assert np.all(np.diff(path.pressure_pa) > 0.0)
    assert path.apex_fold_rad[-1] >= TARGET_FOLD_RAD
    assert np.all(path.stable_at_pressure) and np.all(path.stable_at_volume)
    assert len(path.limit_points) == 0


def test_at_the_same_apex_fold_a_flap_tip_travels_as_far_as_in_the_reflection_model(path):
    closures = np.linspace(0.1, 0.3, 3)
    ours = structural_rows(DEMONSTRATOR_ACTUATED, path, closures)
    theirs = kinematic_rows(DEMONSTRATOR_ACTUATED, closures)
    assert ours.tip_travel_m == pytest.approx(theirs.tip_travel_m, rel=0.05)
    assert np.all(np.diff(path.support_travel_m) > 0.0)
    # The hinge bends harder in the structure than the uniform-hinge rule says.
    assert np.all(ours.hinge_strain > theirs.hinge_strain)


def test_closures_beyond_the_path_are_not_invented(path):
    rows = structural_rows(DEMONSTRATOR_ACTUATED, path, [0.0, 0.3, 0.4, 1.0])
    assert np.isfinite(rows.pressure_pa[:2]).all()
    assert np.isnan(rows.pressure_pa[2:]).all()
    assert np.isnan(rows.stable_at_pressure[2:]).all()


def test_a_pressure_maximum_is_the_last_point_held_by_a_regulator():
    flags = np.array([True, True, True, False, False, True])
    zeros = np.zeros(6)

    def path(held):
        return StructuralPath(
            pressure_pa=zeros, air_m3=zeros, apex_fold_rad=zeros, support_fold_rad=zeros,
            fold_along_rad=np.zeros((6, 2)), tip_travel_m=zeros, support_travel_m=zeros,
            peak_strain={},
            strain_energy_j=zeros, stable_at_pressure=flags, stable_at_volume=held,
            ended='closed', node_count=10, moulding_energy_j=0.0)

    # Held with the air held beyond it: a pressure maximum, no bifurcation.
    maximum = path(np.ones(6, dtype=bool))
    assert list(maximum.limit_points) == [2] and list(maximum.bifurcations) == []
    # Lost with the air held too: a bifurcation, not a pressure maximum.
    crossing = path(flags)
    assert list(crossing.limit_points) == [] and list(crossing.bifurcations) == [2]


def _synthetic_path(pressure, air, energy, negatives=None, names=('whole',)):
    count = len(pressure)
    zeros = np.zeros(count)
    flags = np.ones(count, dtype=bool)
    return StructuralPath(
        pressure_pa=np.asarray(pressure, dtype=float), air_m3=np.asarray(air, dtype=float),
        apex_fold_rad=zeros, support_fold_rad=zeros, fold_along_rad=np.zeros((count, 2)),
        tip_travel_m=zeros, support_travel_m=zeros, peak_strain={},
        strain_energy_j=np.asarray(energy, dtype=float), stable_at_pressure=flags,
        stable_at_volume=flags, ended='closed', node_count=10, moulding_energy_j=0.0,
        negative_by_class=None if negatives is None else np.asarray(negatives),
        class_names=names)


def test_a_step_whose_strain_energy_leaves_the_cushions_work_bounds_is_a_jump():
    air = [0.0, 1e-3, 2e-3, 3e-3, 4e-3]
    pressure = [0.0, 1000.0, 2000.0, 1500.0, 1600.0]
    # Work bounds per step: [0, 1], [1, 2], [1.5, 2], [1.5, 1.6] J.
    smooth = [0.0, 0.5, 2.0, 3.9, 5.45]
    assert list(_synthetic_path(pressure, air, smooth).jumps) == []
    # At a bound, and within 1 % of the step's larger bound beyond it: smooth; beyond: a jump.
    for stored, jumps in (([1.0, 2.0, 1.5, 1.6], []), ([1.0, 2.019, 1.481, 1.5], []),
                          ([1.0, 2.021, 1.5, 1.6], [2]), ([1.0, 2.0, 1.479, 1.6], [3])):
        energy = np.concatenate([[0.0], np.cumsum(stored)])
        assert list(_synthetic_path(pressure, air, energy).jumps) == jumps
    released = [0.0, 0.5, 2.0, 0.5, 2.05]  # energy falls over step 3: released in a snap
    assert list(_synthetic_path(pressure, air, released).jumps) == [3]


def test_the_first_unstable_odd_mode_is_where_the_symmetric_path_stops_being_the_panels():
    names = ('even', 'odd in y', 'odd in x', 'odd in x and y')
    negatives = [[0, 0, 0, 0], [0, 0, 0, 0], [1, 0, 0, 0], [1, 1, 0, 0], [0, 2, 0, 1],
                 [0, 2, 0, 1]]
    path = _synthetic_path(np.arange(6.0), np.arange(6.0), np.zeros(6), negatives, names)
    assert path.symmetry_breaking == [(3, 'odd in y'), (4, 'odd in x and y')]
    # The even class losing stability is a pressure maximum or a jump, not a bifurcation.
    assert _synthetic_path(np.arange(3.0), np.arange(3.0), np.zeros(3),
                           [[0, 0, 0, 0], [1, 0, 0, 0], [2, 0, 0, 0]],
                           names).symmetry_breaking == []
    assert _synthetic_path(np.arange(3.0), np.arange(3.0), np.zeros(3),
                           [[0], [1], [1]]).symmetry_breaking == []


def test_wind_on_the_closed_flaps_inner_faces_opens_them_in_proportion(path, panel_sheet,
                                                                       loaded_point):
    wind = path.closed_wind
    assert wind is not None and wind.wind_pressure_pa == 1000.0
    flaps = panel_sheet.sheet.zone == FLAP
    area = SheetSystem(panel_sheet.sheet).area[flaps].sum() / 2.0
    # The flaps' area as they are at closure: the flat pattern's, stretched by at most 1e-4.
    assert wind.flap_force_n == pytest.approx(1000.0 * area, rel=1e-4)
    assert wind.apex_fold_change_rad < 0.0  # the flaps open
    assert wind.stiffness_n_per_m == pytest.approx(wind.flap_force_n / wind.tip_deflection_m)
    # Linear: twice the pressure, twice the travel and the same stiffness.
    sheet, system, last = loaded_point
    single, double = (wind_on_flaps(panel_sheet, sheet, system, last, pressure)
                      for pressure in (1000.0, 2000.0))
    assert double.tip_deflection_m == pytest.approx(2.0 * single.tip_deflection_m, rel=1e-9)
    assert double.stiffness_n_per_m == pytest.approx(single.stiffness_n_per_m, rel=1e-9)


@pytest.fixture(scope='module')
def loaded_point(panel_sheet):
    """Return the moulded sheet, its equations and an equilibrium just above 300 Pa."""
    sheet, start, _ = mould_prefold(panel_sheet, DEMONSTRATOR_ACTUATED.geometry.prefold_rad)
    system = equilibrium_system(panel_sheet, sheet)
    last = trace_path(sheet, 1e-3, lambda point: point.pressure_pa > 300.0,
                      start=system.restrict_sheet(start), system=system)[-1]
    return sheet, system, last


def test_with_the_valves_shut_the_squeezed_air_pushes_back_and_the_flaps_give_less(
        path, panel_sheet, loaded_point):
    wind = path.closed_wind
    assert wind is not None
    assert wind.air_held_pressure_rise_pa > 0.0  # the flaps squeeze the cushion
    assert wind.air_held_volume_change_m3 < 0.0
    assert 0.0 < wind.air_held_tip_deflection_m < wind.tip_deflection_m
    assert wind.air_held_stiffness_n_per_m == pytest.approx(
        wind.flap_force_n / wind.air_held_tip_deflection_m)
    sheet, system, last = loaded_point
    # The air's isothermal compliance (V + V_dead) / p_abs: more tubing, a softer cushion,
    # and the difference of -dV/dp between two dead volumes is theirs over p_abs.
    small, large = (wind_on_flaps(panel_sheet, sheet, system, last, dead_volume_m3=volume)
                    for volume in (0.0, 1e-3))
    assert large.air_held_tip_deflection_m > small.air_held_tip_deflection_m
    assert large.air_held_pressure_rise_pa < small.air_held_pressure_rise_pa
    compliance = [-w.air_held_volume_change_m3 / w.air_held_pressure_rise_pa
                  for w in (small, large)]
    assert compliance[1] - compliance[0] == pytest.approx(1e-3 / (101325.0 + last.pressure_pa),
                                                          rel=1e-9)
    # A reservoir of endless air holds the pressure: the pressure-held response.
    endless = wind_on_flaps(panel_sheet, sheet, system, last, dead_volume_m3=1e6)
    assert endless.air_held_tip_deflection_m == pytest.approx(endless.tip_deflection_m,
                                                              rel=1e-6)
    # Linear: twice the wind, twice the rise and the give.
    double = wind_on_flaps(panel_sheet, sheet, system, last, 2000.0, dead_volume_m3=0.0)
    assert double.air_held_pressure_rise_pa == pytest.approx(
        2.0 * small.air_held_pressure_rise_pa, rel=1e-9)
    assert double.air_held_tip_deflection_m == pytest.approx(
        2.0 * small.air_held_tip_deflection_m, rel=1e-9)


@pytest.mark.parametrize('volume', [-1e-9, math.inf, math.nan])
def test_a_dead_volume_below_zero_or_not_finite_is_refused(panel_sheet, loaded_point, volume):
    sheet, system, last = loaded_point
    with pytest.raises(ValueError, match='dead_volume_m3'):
        wind_on_flaps(panel_sheet, sheet, system, last, dead_volume_m3=volume)


@pytest.mark.parametrize('wind', [0.0, -1.0, math.inf, math.nan])
def test_a_wind_pressure_not_above_zero_or_not_finite_is_refused(panel_sheet, loaded_point,
                                                                 wind):
    sheet, system, last = loaded_point
    with pytest.raises(ValueError, match='wind_pressure_pa'):
        wind_on_flaps(panel_sheet, sheet, system, last, wind)


def test_the_least_wind_above_zero_is_taken(panel_sheet, loaded_point):
    sheet, system, last = loaded_point
    faint = wind_on_flaps(panel_sheet, sheet, system, last, 1e-6)
    assert faint.tip_deflection_m > 0.0 and faint.air_held_pressure_rise_pa > 0.0


def test_the_dead_volume_is_the_plants():
    assert DEAD_VOLUME_M3 == PlantParameters().dead_volume_m3


def test_a_path_that_did_not_close_has_no_wind_figure():
    ended = structural_path(DEMONSTRATOR_ACTUATED, COARSE, target_fold_rad=math.radians(36.0),
                            steps=48, air_estimate_m3=1e-4)
    assert ended.ended.startswith('not closed with')
    assert ended.closed_wind is None


def test_the_flaps_closest_approach_is_the_least_distance_between_their_nodes(
        path, panel_sheet):
    zone, triangles = np.asarray(panel_sheet.sheet.zone), np.asarray(panel_sheet.sheet.triangles)
    nodes = np.unique(triangles[zone == FLAP])
    upper = nodes[panel_sheet.sheet.reference_xy_m[nodes, 1] > 0]
    lower = nodes[panel_sheet.sheet.reference_xy_m[nodes, 1] < 0]
    assert path.flap_gap_m is not None and len(path.flap_gap_m) == len(path.pressure_pa)
    for positions, gap in zip(path.positions_m, path.flap_gap_m):
        # Every pair of nodes, one on each flap (the symmetric shape makes it exact).
        apart = np.linalg.norm(positions[upper][:, None] - positions[lower][None], axis=-1)
        assert gap == pytest.approx(apart.min(), rel=1e-12)
    assert np.all(path.flap_gap_m > 0.0) and path.flap_gap_m[-1] < path.flap_gap_m[0]


def test_a_path_ends_where_the_flaps_would_touch(monkeypatch):
    from flectofold_model.structure import panel as panel_module

    def gap_closing_at_20_deg(self, positions_m):  # as if the flaps met at a 20 deg fold
        fold = float(self.apex_fold_rad(self.fold_angles_rad(positions_m)))
        return 0.1 * (math.radians(20.0) - fold)

    monkeypatch.setattr(panel_module.PanelSheet, 'flap_gap_m', gap_closing_at_20_deg)
    touched = structural_path(DEMONSTRATOR_ACTUATED, COARSE, target_fold_rad=TARGET_FOLD_RAD,
                              steps=48)
    folds = np.degrees(touched.apex_fold_rad)
    assert touched.ended == (f'the flaps touch at {folds[-1]:.1f} deg apex fold (contact '
                             f'between them is not modelled)')
    assert folds[-1] >= 20.0 > folds[-2]
    assert touched.flap_gap_m[-1] <= 0.0 < touched.flap_gap_m[-2]
    assert touched.closed_wind is None


def test_blas_runs_on_one_thread_while_a_path_is_traced_and_as_before_after():
    from threadpoolctl import threadpool_info, threadpool_limits

    def blas_threads():
        return {pool['filepath']: pool['num_threads'] for pool in threadpool_info()
                if pool['user_api'] == 'blas'}

    seen = []
    # Two threads before, whatever the machine has, so that the limit has something to do.
    with threadpool_limits(limits=2, user_api='blas'):
        before = blas_threads()
        structural_path(DEMONSTRATOR_ACTUATED, COARSE, target_fold_rad=math.radians(10.0),
                        steps=4, progress=lambda *_: seen.append(blas_threads()))
        after = blas_threads()
    # (a BLAS built for one thread, as cvxopt's may be, stays at one)
    assert before and max(before.values()) == 2
    # Every BLAS loaded, those the path loads too (CHOLMOD's), on one thread at every step.
    assert seen and all(set(threads.values()) == {1} and set(before) <= set(threads)
                        for threads in seen)
    assert {path: after[path] for path in before} == before


@pytest.mark.parametrize('columns, outer', [(16, 2), (16, 6), (24, 8), (16, 32), (16, -4),
                                            (16, True), (16, 4.0), (16, 5)])
def test_a_mesh_refuses_outer_columns_it_cannot_mesh(columns, outer):
    with pytest.raises(ValueError, match='outer_columns must be 0 or an even count'):
        PanelMesh(columns, 2, 2, 3, 1.0, outer)


def test_a_banded_mesh_halves_its_columns_with_every_line_away_from_the_hinge_bands():
    for outer in (0, 4, 8, 16):  # 4 the fewest; 16 every line as the bands'
        PanelMesh(16, 2, 2, 3, 1.0, outer)
    mesh = PanelMesh(16, 2, 2, 3, 1.0, 4)
    # Lines from the -y edge: flap (3 rows), band (2), mid-rib (2), the axis, and up again.
    assert mesh.line_columns().tolist() == [4, 4, 8, 16, 16, 16, 8, 4, 8, 16, 16, 16, 8, 4, 4]
    assert PanelMesh(16, 2, 2, 3).line_columns().tolist() == [16] * 15
    assert mesh.refined(2).outer_columns == 8
    banded = build_panel_sheet(DEMONSTRATOR_ACTUATED, mesh)
    structured = build_panel_sheet(DEMONSTRATOR_ACTUATED, PanelMesh(16, 2, 2, 3))
    assert banded.sheet.node_count == 4 * 5 + 8 * 4 + 16 * 6 + 15
    geometry = DEMONSTRATOR_ACTUATED.geometry
    for sheet in (banded, structured):
        area = SheetSystem(sheet.sheet).area
        assert np.all(area > 0.0)
        assert area.sum() == pytest.approx(geometry.length_m * geometry.width_m, rel=1e-12)
    # The bands' lines are the structured mesh's: the same hinge, triangle for triangle.
    hinge = [SheetSystem(s.sheet).area[s.sheet.zone == HINGE] for s in (banded, structured)]
    assert np.sort(hinge[0]) == pytest.approx(np.sort(hinge[1]), rel=1e-12)
    assert_mirror_symmetric(banded)
    xy = banded.sheet.reference_xy_m
    assert xy[banded.tip_node] == pytest.approx([0.0, geometry.width_m / 2], abs=1e-15)
    for mirror in banded.mirrors:
        flip = np.where(np.arange(2) == mirror.axis, -1.0, 1.0)
        assert xy[mirror.node_images] == pytest.approx(xy * flip, abs=1e-12)


def test_a_banded_mesh_follows_the_structured_path_of_its_bands_columns():
    # 40 columns in the bands, 10 at the edges and on the axis: the path to 36 deg, at the
    # same air at every step, within 1.5 % in pressure and 0.3 % in tip travel of the
    # structured mesh's (measured 1.1 % and 0.16 %), with half the nodes.
    structured = structural_path(DEMONSTRATOR_ACTUATED, PanelMesh(40, 4, 2, 4),
                                 target_fold_rad=TARGET_FOLD_RAD, steps=24)
    banded = structural_path(DEMONSTRATOR_ACTUATED, PanelMesh(40, 4, 2, 4, 1.0, 10),
                             target_fold_rad=TARGET_FOLD_RAD, steps=24)
    assert banded.node_count < 0.6 * structured.node_count
    assert banded.ended == structured.ended == 'closed'
    assert banded.air_m3 == pytest.approx(structured.air_m3, rel=1e-12, abs=1e-15)
    assert banded.pressure_pa[1:] == pytest.approx(structured.pressure_pa[1:], rel=0.015)
    assert banded.tip_travel_m[1:] == pytest.approx(structured.tip_travel_m[1:], rel=0.003)
    assert banded.fold_along_rad.shape[1] == 20  # read at the columns beside the bands
