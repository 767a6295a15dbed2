"""Panels on their symmetry cells: the same path as the whole sheet, the whole stability."""

from dataclasses import replace
import math

import numpy as np
import pytest

from flectofold_model.actuation import HEXAGON_ACTUATED
from flectofold_model.actuation.statics import DEMONSTRATOR_ACTUATED
from flectofold_model.structure import elements
from flectofold_model.structure import panel as panel_module
from flectofold_model.structure.hexagon import hexagon_structural_path, HexagonMesh
from flectofold_model.structure.panel import (build_panel_sheet, mould_prefold, PanelMesh,
                                              structural_path)
from flectofold_model.structure.sheet import SheetSystem, tangent_inertia
from flectofold_model.structure.symmetry import Mirror, MirroredSystem, symmetry_group

MESH = PanelMesh(20, 2, 2, 2)
PREFOLD = DEMONSTRATOR_ACTUATED.geometry.prefold_rad


@pytest.fixture(scope='module')
def panel_sheet():
    return build_panel_sheet(DEMONSTRATOR_ACTUATED, MESH)


@pytest.fixture(scope='module')
def moulded(panel_sheet):
    return mould_prefold(panel_sheet, PREFOLD)


def _whole_sheet_only(monkeypatch):
    monkeypatch.setattr(panel_module, 'equilibrium_system',
                        lambda panel_sheet, sheet, like=None: SheetSystem(sheet))


def _energy_of_all_unknowns(system, unknowns):
    positions = unknowns[:3 * system.sheet.node_count].reshape(-1, 3)
    membrane = elements.membrane_energy(positions[system.triangles], system.inverse,
                                        system.area, system.membrane_modulus, system.poisson)
    return membrane.sum(), system.bending.local_energy(unknowns[system._groups[1].dofs]).sum()


def test_every_mirror_image_of_any_shape_has_its_energy(panel_sheet, moulded):
    sheet = moulded[0]  # moulded: rest curvatures and rest triangles of its own
    system = SheetSystem(sheet)
    rng = np.random.default_rng(5)
    unknowns = system.reference.copy()
    nodes = sheet.node_count
    unknowns[:3 * nodes] += 0.01 * rng.standard_normal(3 * nodes)
    unknowns[3 * nodes:] += 0.1 * rng.standard_normal(system.bending.edge_count)
    energy = _energy_of_all_unknowns(system, unknowns)
    group = symmetry_group(sheet, system.bending, panel_sheet.mirrors)
    assert len(group) == 4
    for element, _ in group:
        image = np.zeros_like(unknowns)
        image[element.image] = element.sign * unknowns
        assert _energy_of_all_unknowns(system, image) == pytest.approx(energy, rel=1e-12)
    # Without the edge rotations' signs the bending energy of the image is another.
    flipped = group[1][0]
    image = np.zeros_like(unknowns)
    image[flipped.image] = np.abs(flipped.sign) * unknowns
    assert _energy_of_all_unknowns(system, image)[1] != pytest.approx(energy[1], rel=1e-3)


def test_the_mould_is_mirror_symmetric_on_the_whole_sheet(panel_sheet, monkeypatch):
    # The hinge's rest curvature is laid on each triangle's own edge vectors; laid on x and y
    # as if they were its edges (before 2026-12-07) the whole sheet moulded 5 mm out of
    # symmetry on this mesh.
    _whole_sheet_only(monkeypatch)
    sheet, start, _ = mould_prefold(panel_sheet, PREFOLD)
    positions = SheetSystem(sheet).positions(start)
    for mirror in panel_sheet.mirrors:
        image = positions[mirror.node_images].copy()
        image[:, mirror.axis] *= -1.0
        if mirror.axis == 0:  # the pin at B: the image is shifted along the axis
            image[:, 0] += np.mean(positions[:, 0] - image[:, 0])
        assert np.max(np.abs(image - positions)) < 1e-9


def test_the_cell_gives_the_whole_sheets_energy_gradient_and_tangent(panel_sheet, moulded):
    sheet = moulded[0]
    mirrored = MirroredSystem(sheet, panel_sheet.mirrors)
    whole = SheetSystem(mirrored.cell.sheet)  # the whole sheet with the symmetric supports
    rng = np.random.default_rng(7)
    values = mirrored.rest_values() + 0.003 * rng.standard_normal(mirrored.free_count)
    expanded = np.asarray(mirrored.basis @ values)
    assert mirrored.energies_j(values) == pytest.approx(whole.energies_j(expanded), rel=1e-12)
    assert mirrored.volume_m3(values) == pytest.approx(whole.volume_m3(expanded), rel=1e-12)
    energy, volume = whole.gradients(expanded)
    ours = mirrored.gradients(values)
    assert np.max(np.abs(mirrored.basis.T @ energy - ours[0])) < 1e-12 * np.max(np.abs(energy))
    assert np.max(np.abs(mirrored.basis.T @ volume - ours[1])) < 1e-12 * np.max(np.abs(volume))
    tangent = whole.hessians(expanded, 800.0)
    for basis, block in zip(mirrored.blocks, mirrored.tangent_blocks(values, 800.0)):
        projected = basis.T @ tangent @ basis
        assert abs(projected - block).max() < 1e-10 * abs(projected).max()


def test_the_classes_inertia_is_the_whole_tangents(panel_sheet, moulded):
    # At a symmetric shape that is no equilibrium, under a pressure that makes the tangent
    # indefinite: the negative eigenvalues of the four blocks add up to the whole sheet's
    # with its own supports (the pin holds the translation the blocks leave out).
    sheet = moulded[0]
    mirrored = MirroredSystem(sheet, panel_sheet.mirrors)
    whole = SheetSystem(sheet)
    rng = np.random.default_rng(11)
    values = mirrored.rest_values() + 0.002 * rng.standard_normal(mirrored.free_count)
    unknowns = mirrored.sheet_unknowns(values)
    for pressure in (0.0, 3e4):
        ours = tangent_inertia(mirrored, values, pressure)
        assert ours is not None
        matrix = whole.hessians(unknowns, pressure).toarray()
        eigenvalues = np.linalg.eigvalsh(0.5 * (matrix + matrix.T))
        assert ours[0] == np.count_nonzero(eigenvalues < 0.0)
    assert ours[0] > 0


def test_the_quad_path_on_its_cell_is_the_whole_sheets_path(monkeypatch):
    ours = structural_path(DEMONSTRATOR_ACTUATED, MESH, steps=12,
                           target_fold_rad=np.radians(60.0))
    _whole_sheet_only(monkeypatch)
    whole = structural_path(DEMONSTRATOR_ACTUATED, MESH, steps=12,
                            target_fold_rad=np.radians(60.0))
    assert ours.ended == whole.ended == 'closed'
    assert len(ours.pressure_pa) == len(whole.pressure_pa) >= 10
    assert ours.pressure_pa == pytest.approx(whole.pressure_pa, rel=1e-7, abs=1e-6)
    assert np.max(np.abs(ours.positions_m - whole.positions_m)) < 1e-9
    assert ours.peak_strain['hinge'] == pytest.approx(whole.peak_strain['hinge'], rel=1e-6)
    assert np.array_equal(ours.stable_at_pressure, whole.stable_at_pressure)
    assert np.array_equal(ours.stable_at_volume, whole.stable_at_volume)
    # The wind on the closed flaps, loaded through either system's unknowns.
    assert ours.closed_wind.tip_deflection_m == pytest.approx(
        whole.closed_wind.tip_deflection_m, rel=1e-6)
    assert ours.closed_wind.apex_fold_change_rad == pytest.approx(
        whole.closed_wind.apex_fold_change_rad, rel=1e-5)


def test_the_hexagon_path_on_its_half_is_the_whole_sheets_and_finds_the_pair_that_breaks_its_turn(
        monkeypatch):
    # Moulded to 20 deg the module folds (msg_docs/structure.md), and near 55 deg loses
    # stability in a pair of modes, one even and one odd under the mirror through T_0: the
    # pair of its symmetry group that breaks the three-fold turn.
    panel = replace(HEXAGON_ACTUATED, geometry=replace(HEXAGON_ACTUATED.geometry,
                                                       prefold_rad=math.radians(20.0)))
    mesh = HexagonMesh(12, 4, 2, 2)
    # Steps of 0.75 L: the pair shows before the even class loses a second mode.
    ours = hexagon_structural_path(panel, mesh, steps=24)
    assert ours.class_names == ('even', 'odd in x')
    _whole_sheet_only(monkeypatch)
    whole = hexagon_structural_path(panel, mesh, steps=24)
    assert ours.ended == whole.ended
    assert len(ours.pressure_pa) == len(whole.pressure_pa) >= 12
    assert ours.pressure_pa == pytest.approx(whole.pressure_pa, rel=1e-7, abs=1e-6)
    # Within Newton's tolerance, 1e-8 of the sheet's extent (1.24 m): 12 nm.
    assert np.max(np.abs(ours.positions_m - whole.positions_m)) < 6e-9
    assert np.array_equal(ours.negative_by_class.sum(axis=1), whole.negative_by_class[:, 0])
    folds = np.degrees(ours.apex_fold_rad)
    pair = [i for i in range(1, len(folds))
            if list(ours.negative_by_class[i - 1]) == [0, 0]
            and list(ours.negative_by_class[i]) == [1, 1]]
    assert len(pair) == 1 and 50.0 < folds[pair[0]] < 60.0


def test_a_sheet_that_is_not_its_mirror_image_is_refused(panel_sheet):
    sheet = panel_sheet.sheet
    loaded = np.asarray(sheet.loaded).copy()
    loaded[np.flatnonzero(loaded)[0]] = False
    with pytest.raises(ValueError, match='loaded differs in a mirror image'):
        MirroredSystem(replace(sheet, loaded=loaded), panel_sheet.mirrors)
    shifted = Mirror(np.roll(panel_sheet.mirrors[0].node_images, 1), 0)
    with pytest.raises(ValueError, match='not the mirrored reference positions'):
        MirroredSystem(sheet, [shifted])
    with pytest.raises(ValueError, match='reverses x'):
        MirroredSystem(sheet, [Mirror(panel_sheet.mirrors[0].node_images, 2)])
    fixed = np.asarray(sheet.fixed).copy()
    fixed[panel_sheet.grid[0, 1], 0] = True  # a second pin along the axis
    with pytest.raises(ValueError, match='2 held coordinates have free images'):
        MirroredSystem(replace(sheet, fixed=fixed), panel_sheet.mirrors)
    with pytest.raises(ValueError, match='at least one mirror'):
        MirroredSystem(sheet, [])


def test_systems_of_one_mesh_in_other_rest_states_share_their_layouts_and_their_tangents(
        panel_sheet, moulded):
    flat = MirroredSystem(panel_sheet.sheet, panel_sheet.mirrors)
    values = flat.restrict_sheet(moulded[1])
    fresh = MirroredSystem(moulded[0], panel_sheet.mirrors).tangent_blocks(values, 1500.0)
    made = flat.tangent_blocks(values, 0.0)  # the flat sheet's layouts made first
    sharing = MirroredSystem(moulded[0], panel_sheet.mirrors)
    assert sharing.adopt_layouts(flat)
    assert sharing._layouts is flat._layouts and len(flat._layouts) == len(made) == 4
    for mine, theirs in zip(sharing.tangent_blocks(values, 1500.0), fresh):
        assert (mine != theirs).nnz == 0
    # Another mesh's layouts are not taken.
    other = build_panel_sheet(DEMONSTRATOR_ACTUATED, PanelMesh(20, 2, 1, 2))
    stranger = MirroredSystem(other.sheet, other.mirrors)
    assert not stranger.adopt_layouts(flat)
    assert stranger._layouts is not flat._layouts and not stranger._layouts
