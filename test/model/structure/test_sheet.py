"""The structural sheet against beam theory, the elastica and its own energy balance."""

from dataclasses import replace

import numpy as np
import pytest
from scipy.sparse import csc_matrix
from scipy.spatial import Delaunay
from scipy.special import ellipk

from flectofold_model.kinematics import elastica
from flectofold_model.structure import (elements, kernels, Sheet, SheetSystem,
                                        solve_prescribed, trace_path)
from flectofold_model.structure.sheet import (_stability, HERMITE_JUMP_TOLERANCE,
                                              JUMP_TOLERANCE, jumped, tangent_inertia)
from flectofold_model.structure.shell import MidEdgeBending

YOUNGS_PA = 20e9
THICKNESS_M = 0.004


def strip_mesh(length_m, width_m, size_m, jitter=0.0, seed=0):
    """Near-equilateral triangles in rows along x; ``jitter`` moves inner nodes at random."""
    columns = int(round(length_m / size_m))
    rows = max(1, int(round(width_m / (size_m * np.sqrt(3) / 2))))
    points = []
    for row in range(rows + 1):
        y = -width_m / 2 + width_m * row / rows
        if row % 2:
            xs = np.r_[-length_m / 2, -length_m / 2 + length_m * (np.arange(columns) + 0.5)
                       / columns, length_m / 2]
        else:
            xs = np.linspace(-length_m / 2, length_m / 2, columns + 1)
        points += [(x, y) for x in xs]
    points = np.array(points)
    inner = ((np.abs(np.abs(points[:, 0]) - length_m / 2) > 1e-9)
             & (np.abs(np.abs(points[:, 1]) - width_m / 2) > 1e-9))
    points[inner] += jitter * size_m * np.random.default_rng(seed).uniform(
        -1, 1, (inner.sum(), 2))
    faces = Delaunay(points).simplices
    corners = points[faces]
    area = ((corners[:, 1, 0] - corners[:, 0, 0]) * (corners[:, 2, 1] - corners[:, 0, 1])
            - (corners[:, 2, 0] - corners[:, 0, 0]) * (corners[:, 1, 1] - corners[:, 0, 1]))
    return points, np.where((area < 0)[:, None], faces[:, [0, 2, 1]], faces)


def strip_sheet(points, faces, poisson=0.0, roller_slides=True, loaded=True):
    """Build a strip pinned along x = -L/2 and held along x = +L/2 (sliding if asked)."""
    count = len(faces)
    fixed = np.zeros((len(points), 3), dtype=bool)
    left = np.isclose(points[:, 0], points[:, 0].min())
    right = np.isclose(points[:, 0], points[:, 0].max())
    fixed[left] = True
    fixed[right, 0 if not roller_slides else 1:] = True
    return Sheet(points, faces, np.full(count, THICKNESS_M), np.full(count, YOUNGS_PA),
                 np.full(count, poisson), fixed, np.full(count, loaded), -0.005), right


def central_difference(function, corners, step=1e-6):
    gradient = np.zeros_like(corners)
    for index in np.ndindex(corners.shape[1:]):
        plus, minus = corners.copy(), corners.copy()
        plus[(slice(None),) + index] += step
        minus[(slice(None),) + index] -= step
        gradient[(slice(None),) + index] = (function(plus) - function(minus)) / (2 * step)
    return gradient


def test_the_analytic_element_gradients_match_central_differences():
    rng = np.random.default_rng(3)
    hinge = (np.array([[0, 0, 0], [1, 0, 0], [0.4, 1, 0.2], [0.6, -1, 0.3]], float)
             + rng.normal(0, 0.05, (6, 4, 3)))
    compiled = np.empty((len(hinge), 12))
    for corners, gradient in zip(hinge, compiled):
        local = np.concatenate([corners.ravel(), np.zeros(6)])
        angle = kernels._dihedral(local, np.arange(4), gradient)
        assert angle == pytest.approx(elements.dihedral_angle(corners[None])[0], abs=1e-14)
    assert np.allclose(compiled.reshape(hinge.shape),
                       central_difference(elements.dihedral_angle, hinge), atol=1e-8)
    flat = np.array([[0, 0], [1, 0], [0, 1]], float)[None].repeat(6, 0)
    inverse, area = elements.membrane_reference(flat)
    corners = np.concatenate([flat, np.zeros((6, 3, 1))], -1) + rng.normal(0, 0.05, (6, 3, 3))
    modulus, poisson = np.full(6, 1e3), np.full(6, 0.3)
    analytic = elements.membrane_gradient(corners, inverse, area, modulus, poisson)
    numeric = central_difference(
        lambda c: elements.membrane_energy(c, inverse, area, modulus, poisson), corners)
    assert np.max(np.abs(analytic - numeric)) < 1e-7 * np.max(np.abs(analytic))
    assert np.allclose(elements.prism_gradient(corners, -0.1),
                       central_difference(lambda c: elements.prism_volume(c, -0.1), corners),
                       atol=1e-9)
    points, faces = strip_mesh(0.3, 0.2, 0.1, jitter=0.2)
    bending = MidEdgeBending(points, faces, np.full(len(faces), 2.0), np.full(len(faces), 0.2))
    local = np.concatenate([
        np.concatenate([points, np.zeros((len(points), 1))], 1)[bending.stencil]
        .reshape(len(faces), 18), np.zeros((len(faces), 3))], 1)
    local += rng.normal(0, 0.02, local.shape)
    numeric = central_difference(bending.local_energy, local)
    assert np.allclose(bending.local_gradient(local), numeric, atol=1e-7)


@pytest.mark.parametrize('jitter', [0.0, 0.25])
def test_a_simply_supported_strip_deflects_as_beam_theory_under_a_small_pressure(jitter):
    length = 1.0
    points, faces = strip_mesh(length, 0.2, 0.025, jitter=jitter)
    sheet, _ = strip_sheet(points, faces)
    point = trace_path(sheet, 1e-6, lambda point: True, max_steps=1)[-1]
    centre = np.argmin(np.hypot(points[:, 0], points[:, 1]))
    stiffness = YOUNGS_PA * THICKNESS_M**3 / 12
    along = points[centre, 0] + length / 2
    beam = (point.pressure_pa * along * (length**3 - 2 * length * along**2 + along**3)
            / (24 * stiffness))
    assert point.positions_m[centre, 2] == pytest.approx(beam, rel=0.01)
    assert beam > 0.0


@pytest.mark.parametrize('jitter', [0.0, 0.25])
def test_a_strip_pushed_together_between_pins_is_the_closed_form_elastica(jitter):
    length, width = 1.0, 0.05
    points, faces = strip_mesh(length, width, 0.0125, jitter=jitter)
    sheet, right = strip_sheet(points, faces, roller_slides=False, loaded=False)
    modulus = np.sin(np.radians(30.0) / 2)
    shortening = float(elastica.shortening_from_k(modulus, length))
    sag = float(elastica.sag_from_k(modulus, length))
    held = np.column_stack([points, np.zeros(len(points))])
    held[right, 0] -= shortening
    shape = elastica.elastica_shape(modulus, length, points[:, 0])
    guess = held.copy()
    guess[:, 0] = shape.x_m - shape.x_m.min() - length / 2
    guess[:, 2] = shape.z_m
    result = solve_prescribed(sheet, held, guess)
    middle = np.abs(points[:, 0]) < 1e-9 if jitter == 0 else np.abs(points[:, 0]) < 0.004
    axial = -result.reactions_n[right, 0].sum()
    bending = YOUNGS_PA * THICKNESS_M**3 / 12 * width
    assert result.positions_m[middle, 2].mean() == pytest.approx(sag, rel=1e-3)
    assert axial == pytest.approx(bending * (2 * ellipk(modulus**2) / length)**2, rel=1e-3)


def test_the_pressure_work_equals_the_strain_energy_at_every_step_of_a_large_deflection():
    points, faces = strip_mesh(1.0, 0.1, 0.025)
    sheet, _ = strip_sheet(points, faces, poisson=0.13)
    path = trace_path(sheet, 0.006 / 20, lambda point: point.volume_m3 >= 0.0065 - 1e-12,
                      max_steps=60)
    pressure = np.array([p.pressure_pa for p in path])
    volume = np.array([p.volume_m3 for p in path])
    energy = np.array([p.membrane_energy_j + p.bending_energy_j for p in path])
    work = 0.5 * (pressure[1:] + pressure[:-1]) * np.diff(volume)
    assert np.max(path[-1].positions_m[:, 2]) > 0.09
    assert np.all(np.abs(work / np.diff(energy) - 1) < 1e-3)


def test_a_sheet_refuses_laminates_and_triangles_that_cannot_exist():
    points, faces = strip_mesh(0.3, 0.2, 0.1)
    count = len(faces)
    fixed = np.zeros((len(points), 3), dtype=bool)

    def build(thickness=0.004, poisson=0.3, triangles=faces):
        return Sheet(points, triangles, np.full(count, thickness), np.full(count, 2e10),
                     np.full(count, poisson), fixed, np.zeros(count, bool), -0.005)

    build(poisson=0.0)
    build(poisson=0.4999)
    with pytest.raises(ValueError, match='poisson_ratio'):
        build(poisson=0.5)
    with pytest.raises(ValueError, match='poisson_ratio'):
        build(poisson=-1e-9)
    with pytest.raises(ValueError, match='thickness_m'):
        build(thickness=0.0)
    with pytest.raises(ValueError, match='thickness_m'):
        build(thickness=float('nan'))
    flipped = faces.copy()
    flipped[0] = flipped[0, [0, 2, 1]]
    with pytest.raises(ValueError, match='orientation'):
        build(triangles=flipped)


def test_a_moulded_sheet_refuses_rest_shapes_that_cannot_exist():
    points, faces = strip_mesh(0.3, 0.2, 0.1)
    sheet, _ = strip_sheet(points, faces)
    count = len(faces)
    replace(sheet, rest_tilt_sine=np.ones((count, 3)))
    replace(sheet, rest_tilt_sine=-np.ones((count, 3)))
    with pytest.raises(ValueError, match='rest_tilt_sine'):
        replace(sheet, rest_tilt_sine=np.full((count, 3), 1.0 + 1e-12))
    with pytest.raises(ValueError, match='rest_tilt_sine'):
        replace(sheet, rest_tilt_sine=np.zeros((count, 2)))
    with pytest.raises(ValueError, match='rest_tilt_sine'):
        replace(sheet, rest_tilt_sine=np.full((count, 3), np.nan))
    flat = np.column_stack([points, np.zeros(len(points))])
    replace(sheet, rest_positions_m=flat)
    with pytest.raises(ValueError, match='rest_positions_m'):
        replace(sheet, rest_positions_m=flat[:, :2])
    broken = flat.copy()
    broken[3, 2] = np.inf
    with pytest.raises(ValueError, match='rest_positions_m'):
        replace(sheet, rest_positions_m=broken)


def test_a_sheet_moulded_in_a_shape_is_stress_free_there():
    points, faces = strip_mesh(0.4, 0.1, 0.025)
    sheet, _ = strip_sheet(points, faces)
    # Roll the strip onto a cylinder of radius 0.5 m about the y axis: an isometry.
    radius = 0.5
    angle = points[:, 0] / radius
    rolled = np.column_stack([radius * np.sin(angle), points[:, 1],
                              radius * (1.0 - np.cos(angle))])
    everywhere = replace(sheet, fixed=np.ones_like(sheet.fixed))
    bent = solve_prescribed(everywhere, rolled, rolled)
    assert bent.bending_energy_j > 1.0
    moulded = replace(sheet, rest_tilt_sine=bent.tilt_sine, rest_positions_m=rolled)
    held = solve_prescribed(moulded, rolled, rolled)
    assert held.membrane_energy_j + held.bending_energy_j < 1e-12 * bent.bending_energy_j
    assert held.positions_m == pytest.approx(rolled, abs=1e-9)
    assert np.max(np.abs(held.reactions_n)) < 1e-6


def deformed_triangles(seed, count):
    """Random flat triangles and their corners stretched, sheared and turned out of plane.

    Return ``corners (count, 3, 3)``, the reference inverse and area, modulus and Poisson's
    ratio: both the material and the geometric part of the membrane stiffness at work.
    """
    rng = np.random.default_rng(seed)
    flat = rng.normal(0, 1, (count, 3, 2))
    clockwise = np.linalg.det(np.stack([flat[:, 1] - flat[:, 0], flat[:, 2] - flat[:, 0]],
                                       -1)) < 0
    flat[clockwise] = flat[clockwise][:, [0, 2, 1]]
    inverse, area = elements.membrane_reference(flat)
    corners = (np.concatenate([flat, np.zeros((count, 3, 1))], -1)
               + rng.normal(0, 0.3, (count, 3, 3)))
    return (corners, np.ascontiguousarray(inverse), area, rng.uniform(1e5, 1e6, count),
            rng.uniform(0.0, 0.45, count))


def test_the_membrane_hessian_matches_central_differences_of_the_gradient():
    corners, inverse, area, modulus, poisson = deformed_triangles(5, 40)
    analytic = elements.membrane_hessian(corners, inverse, area, modulus, poisson)
    numeric = elements.finite_difference_hessian(
        lambda local: elements.membrane_gradient(local.reshape(-1, 3, 3), inverse, area,
                                                 modulus, poisson).reshape(40, 9),
        corners.reshape(40, 9), step=1e-6)
    assert np.max(np.abs(analytic - numeric)) < 1e-8 * np.max(np.abs(numeric))
    assert np.allclose(analytic, np.swapaxes(analytic, 1, 2), rtol=0, atol=1e-12 * np.max(
        np.abs(analytic)))


def test_the_compiled_membrane_kernels_are_the_numpy_rules():
    corners, inverse, area, modulus, poisson = deformed_triangles(7, 60)
    local = np.ascontiguousarray(corners.reshape(60, 9))
    gradient = elements.membrane_gradient(corners, inverse, area, modulus, poisson)
    compiled = kernels.membrane_gradient(local, inverse, area, modulus, poisson)
    assert np.max(np.abs(compiled - gradient.reshape(60, 9))) < 1e-13 * np.max(np.abs(gradient))
    hessian = elements.membrane_hessian(corners, inverse, area, modulus, poisson)
    compiled = kernels.membrane_hessian(local, inverse, area, modulus, poisson)
    assert np.max(np.abs(compiled - hessian.reshape(60, 81))) < 1e-13 * np.max(np.abs(hessian))


def test_the_dihedral_angles_second_derivatives_are_those_of_its_gradient():
    rng = np.random.default_rng(9)
    slots, step = np.arange(4), 1e-6
    second = np.empty((12, 12))
    work = np.empty((3, 12)), np.empty((3, 12)), np.empty((5, 12))
    plus, minus = np.empty(12), np.empty(12)
    for _ in range(20):
        corners = (np.array([[0, 0, 0], [1, 0, 0], [0.4, 1, 0.2], [0.6, -1, 0.3]], float)
                   + rng.normal(0, 0.2, (4, 3)))
        local = np.concatenate([corners.ravel(), np.zeros(6)])
        kernels._dihedral_hessian(local, slots, *work, second)
        numeric = np.empty((12, 12))
        for column in range(12):
            moved = local.copy()
            moved[column] += step
            kernels._dihedral(moved, slots, plus)
            moved[column] -= 2 * step
            kernels._dihedral(moved, slots, minus)
            numeric[:, column] = (plus - minus) / (2 * step)
        assert np.max(np.abs(second - numeric)) < 1e-8 * np.max(np.abs(numeric))
        assert np.max(np.abs(second - second.T)) < 1e-13 * np.max(np.abs(second))


def test_the_compiled_scatter_sums_as_bincount_does():
    rng = np.random.default_rng(8)
    entries = rng.normal(size=500)
    keep = rng.choice(500, 300, replace=False)
    slot = rng.integers(0, 40, 300)
    weight = rng.choice([-2.0, 2.0, 4.0], 300)
    expected = np.bincount(slot, weights=weight * entries[keep], minlength=45)
    assert np.array_equal(kernels.scatter_add(slot, weight, entries, keep, 45), expected)


def test_the_bending_hessian_matches_central_differences_of_the_gradient():
    points, faces = strip_mesh(0.3, 0.2, 0.05, jitter=0.2)
    rng = np.random.default_rng(3)
    count = len(faces)
    bending = MidEdgeBending(points, faces, np.full(count, 2.0), np.full(count, 0.3),
                             rest_sine=rng.normal(0.0, 0.1, (count, 3)))
    local = np.zeros((count, 21))
    flat = np.column_stack([points, np.zeros(len(points))])
    local[:, :18] = flat[bending.stencil].reshape(count, 18) + rng.normal(0, 0.01, (count, 18))
    local[:, 18:] = rng.normal(0.0, 0.1, (count, 3))
    analytic = bending.local_hessian(local)
    numeric = elements.finite_difference_hessian(bending.local_gradient, local, 1e-6)
    assert np.max(np.abs(analytic - numeric)) <= 1e-6 * np.max(np.abs(numeric))


def test_the_tangent_inertia_counts_the_negative_eigenvalues_of_a_compressed_strip():
    points, faces = strip_mesh(0.5, 0.05, 0.025)
    sheet, right = strip_sheet(points, faces, loaded=False)
    system = SheetSystem(sheet)
    flat = system.reference[system.free].copy()
    assert tangent_inertia(system, flat, 0.0)[0] == 0
    # Squeeze it straight by 1 %: far beyond its Euler load, so it is unstable straight.
    squeezed = np.column_stack([points[:, 0] * 0.99, points[:, 1], np.zeros(len(points))])
    values = system.full(flat)
    values[:3 * len(points)] = squeezed.ravel()
    values = values[system.free]
    negative, _ = tangent_inertia(system, values, 0.0)
    dense = np.linalg.eigvalsh(system.hessians(values, 0.0).toarray())
    assert negative == np.count_nonzero(dense < 0.0)
    assert negative >= 1


class TwoWells:
    """Two unknowns ``(a, b)``, the air ``V = a``, ``E = a^2/2 + b^4/4 - b^2/2 - a b``.

    At a given air ``b`` sits in a double well tilted by ``a``: ``b^3 - b = a``. The branch
    from ``(0, -1)`` ends at a fold, ``a = 2 / (3 sqrt(3))``, ``b = -1 / sqrt(3)``, where it
    loses stability; past it the only equilibrium is on the other branch, ``b > 1``.
    """

    extent_m = 1.0
    FOLD_AIR = 2.0 / (3.0 * np.sqrt(3.0))

    def rest_values(self):
        return np.array([0.0, -1.0])

    def sheet_unknowns(self, values):
        return np.array(values, dtype=float)

    def restrict_sheet(self, sheet_unknowns):
        return np.array(sheet_unknowns, dtype=float)

    def positions(self, values):
        return np.array([[values[0], values[1], 0.0]])

    def volume_m3(self, values):
        return float(values[0])

    def energies_j(self, values):
        a, b = values
        return a * a / 2 + b**4 / 4 - b * b / 2 - a * b, 0.0

    def gradients(self, values):
        a, b = values
        return np.array([a - b, b**3 - b - a]), np.array([1.0, 0.0])

    def hessians(self, values, pressure_pa):
        return csc_matrix(np.array([[1.0, -1.0], [-1.0, 3 * values[1]**2 - 1.0]]))

    def tangent_blocks(self, values, pressure_pa):
        return [self.hessians(values, pressure_pa)]


def test_the_paths_direction_is_the_derivative_of_its_equilibria_along_the_air():
    # On b^3 - b = a, p = a - b: db/da = 1 / (3 b^2 - 1), dp/da = 1 - db/da.
    system = TwoWells()
    for air in (0.0, 0.1, 0.3):
        b = min(root.real for root in np.roots([1.0, 0.0, -1.0, -air]) if abs(root.imag) < 1e-12)
        values = np.array([air, b])
        stability, direction = _stability(system, values, air - b)
        slope = 1.0 / (3.0 * b * b - 1.0)
        assert stability[1] is True  # with the air held
        assert direction.values_per_m3 == pytest.approx([1.0, slope], rel=1e-12)
        assert direction.pressure_per_m3 == pytest.approx(1.0 - slope, rel=1e-12)


def test_from_a_stable_equilibrium_a_step_that_lands_on_another_branch_is_made_shorter():
    # Steps of 0.1 reach 0.3 on the first branch; the next one's only equilibrium is on the
    # other. The step is halved until the path has come to the fold (within the smallest
    # step, 0.1 / 64), and only from there does it jump, as the sheet would. (From beside
    # the fold, where db/da is large, Newton's chords take over a hundred iterations to the
    # far branch: the iterations allowed are raised for this toy.)
    system = TwoWells()
    path = trace_path(None, 0.1, lambda point: point.volume_m3 >= 0.6, start=[0.0, -1.0],
                      system=system, max_iterations=400)
    air = np.array([point.volume_m3 for point in path])
    b = np.array([point.positions_m[0, 1] for point in path])
    [last] = np.flatnonzero((b[:-1] < 0.0) & (b[1:] > 0.0))
    assert TwoWells.FOLD_AIR - 0.1 / 64 <= air[last] <= TwoWells.FOLD_AIR
    assert all(point.stable_at_volume for point in path[:last])
    assert air[-1] >= 0.6 and np.all(b[last + 1:] > 1.0)
    stored = np.diff([point.membrane_energy_j for point in path])
    pressure = np.array([point.pressure_pa for point in path])
    steps = jumped(np.diff(air), pressure[:-1], pressure[1:], stored)
    assert np.flatnonzero(steps).tolist() == [last]


def test_a_step_jumps_when_its_stored_energy_leaves_the_bounds_of_the_cushions_work():
    # 1 mL at 1 to 2 kPa: the work lies between 1 and 2 J, with 1 % of 2 J to spare.
    air, before, after = 1e-3, 1000.0, 2000.0
    low = 1.0 - JUMP_TOLERANCE * 2.0
    high = 2.0 + JUMP_TOLERANCE * 2.0
    for stored, expected in ((low, False), (np.nextafter(low, -np.inf), True),
                             (high, False), (np.nextafter(high, np.inf), True), (1.5, False)):
        assert bool(jumped(air, before, after, stored)) is expected, stored


def test_a_step_jumps_when_its_stored_energy_misses_the_hermite_rule_for_its_work():
    # 1 mL from 1 to 2 kPa, dp/dV 1.5e6 and 0.5e6 Pa/m3 at its ends: the Hermite rule's work
    # is 1.5 J + (1e-3)^2 (1.5e6 - 0.5e6) / 12 = 1.5833 J, within the bounds' 0.98-2.02 J.
    air, before, after, slopes = 1e-3, 1000.0, 2000.0, (1.5e6, 0.5e6)
    work = 1.5 + 1e-6 * 1e6 / 12
    for share, expected in ((0.0, False), (1 - 1e-9, False), (1 + 1e-9, True)):
        for sign in (-1.0, 1.0):
            stored = work * (1.0 + sign * share * HERMITE_JUMP_TOLERANCE)
            assert bool(jumped(air, before, after, stored, *slopes)) is expected, (share, sign)
            # Without the slopes only the bounds are known: inside them, no jump.
            assert not jumped(air, before, after, stored)
    # An unknown slope (NaN) leaves the bounds alone to judge.
    assert not jumped(air, before, after, 1.9, np.nan, 0.5e6)
    assert jumped([air, air], before, after, [1.9, 2.1], *slopes).tolist() == [True, True]
