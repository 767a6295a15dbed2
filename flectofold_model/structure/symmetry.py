"""Mirror symmetry of a sheet: the equilibrium path on one cell, the stability on the whole.

A sheet whose mesh, laminates, cushion and supports are symmetric under one or two mirrors
(the quad panel: ``x -> -x`` and ``y -> -y``; the hexagon: ``x -> -x``) keeps a symmetric
shape under its symmetric cushion load as long as the symmetric path is followed, and at
every symmetric state its tangent splits into independent blocks, one per symmetry class:
the deformations even or odd under each mirror (four classes for two mirrors) [1]_. Hence

* the **path** needs only the even class: the unknowns of one symmetry cell (a half of the
  sheet for one mirror, a quarter for two), and each class's energy, gradient and tangent
  are those of one cell's faces, times the group's order (every face has its images, none
  is its own);
* the **stability** of each equilibrium is still that of the whole sheet: its tangent's
  inertia is the sum of the classes' (Sylvester's law of inertia on the block-diagonal form),
  so a mode that breaks the symmetry (one flap up, the other down) is found as before. What
  the symmetric path does not do is follow such a mode past its bifurcation.

The image of a coordinate is that of its node with the mirrored component's sign reversed;
the image of an edge's rotation (:mod:`.shell`) is the rotation of the image edge, with the
sign ``sigma sigma'`` of the two faces' sides of it (the director's tilt is a geometric angle,
the same in both faces). An edge on a mirror line has opposite sides in a face and its image,
so its rotation is odd: a symmetric shape has none there.

Held coordinates: the symmetric model holds those held in every image. A coordinate held in
the sheet but not in all its images may be released only where a rigid translation along its
axis costs no energy (the quad panel's pin-and-slider: the pin's axial coordinate); the path
is then solved without it and translated back to it.

References
----------
.. [1] Healey, T. J. (1988). A group-theoretic approach to computational bifurcation problems
   with symmetry. Computer Methods in Applied Mechanics and Engineering 67(3), 257-295.
"""

from dataclasses import dataclass, replace
from itertools import product
from typing import Sequence

import numpy as np
import numpy.typing as npt
from scipy.sparse import coo_matrix, csc_matrix, diags

from flectofold_model._validate import FloatArray, IntArray
from flectofold_model.structure import kernels
from flectofold_model.structure.sheet import csc_layout, Sheet, SheetSystem
from flectofold_model.structure.shell import MidEdgeBending


@dataclass(frozen=True)
class Mirror:
    """A mirror of a sheet's mesh."""

    node_images: np.ndarray
    """Image node of each node ``(n,)``."""
    axis: int
    """Coordinate the mirror reverses (0 ``x``, 1 ``y``) about 0."""


@dataclass(frozen=True)
class SignedPermutation:
    """A symmetry acting on a sheet's unknowns: ``u'[image[k]] = sign[k] u[k]``."""

    image: np.ndarray
    sign: np.ndarray
    face_image: np.ndarray
    """Image triangle of each triangle."""

    def then(self, other: 'SignedPermutation') -> 'SignedPermutation':
        """Return this symmetry followed by ``other``."""
        return SignedPermutation(other.image[self.image], self.sign * other.sign[self.image],
                                 other.face_image[self.face_image])


def mirror_action(sheet: Sheet, bending: MidEdgeBending, mirror: Mirror) -> SignedPermutation:
    """Return the signed permutation of a mirror on all unknowns (coordinates, edges).

    Raises
    ------
    ValueError
        Where the mesh is not its own mirror image (a triangle without an image, an image
        node out of the reference's mirror position), or a triangle is its own image.
    """
    nodes = np.asarray(mirror.node_images, dtype=np.int64)
    count = sheet.node_count
    if nodes.shape != (count,) or not np.array_equal(np.sort(nodes), np.arange(count)):
        raise ValueError('node_images must be a permutation of the nodes')
    if mirror.axis not in (0, 1):
        raise ValueError('a mirror reverses x (0) or y (1)')
    xy = np.asarray(sheet.reference_xy_m, dtype=np.float64)
    expected = xy.copy()
    expected[:, mirror.axis] *= -1.0
    if not np.allclose(xy[nodes], expected, rtol=0.0, atol=1e-9 * np.ptp(xy).max()):
        raise ValueError('the node images are not the mirrored reference positions')
    faces = np.asarray(sheet.triangles, dtype=np.int64)
    key = np.sort(faces, axis=1) @ np.array([count * count, count, 1])
    order = np.argsort(key)
    mapped = np.sort(nodes[faces], axis=1) @ np.array([count * count, count, 1])
    where = np.searchsorted(key[order], mapped)
    where = np.minimum(where, len(order) - 1)
    if not np.array_equal(key[order][where], mapped):
        raise ValueError('a triangle has no mirror image in the mesh')
    face_image = order[where]
    if np.any(face_image == np.arange(len(faces))):
        raise ValueError('a triangle is its own mirror image: put the mirror on mesh lines')
    # Local corner i of a face goes to the image face's corner holding the image node.
    image_faces = faces[face_image]
    local = np.argmax(image_faces[:, None, :] == nodes[faces][:, :, None], axis=2)
    edge_image = bending.edges[face_image[:, None], local]
    edge_sign = bending.side * bending.side[face_image[:, None], local]
    edges = bending.edge_count
    edge_target = np.full(edges, -1)
    edge_value = np.zeros(edges)
    edge_target[bending.edges.ravel()] = edge_image.ravel()
    edge_value[bending.edges.ravel()] = edge_sign.ravel()
    coordinate_sign = np.ones(3)
    coordinate_sign[mirror.axis] = -1.0
    image = np.concatenate([(3 * nodes[:, None] + np.arange(3)).ravel(),
                            3 * count + edge_target])
    sign = np.concatenate([np.tile(coordinate_sign, count), edge_value])
    return SignedPermutation(image, sign, face_image)


def symmetry_group(sheet: Sheet, bending: MidEdgeBending,
                   mirrors: Sequence[Mirror]) -> list[tuple[SignedPermutation, tuple[int, ...]]]:
    """Every element of the group the mirrors generate, with its exponents per mirror."""
    actions = [mirror_action(sheet, bending, mirror) for mirror in mirrors]
    size = 3 * sheet.node_count + bending.edge_count
    identity = SignedPermutation(np.arange(size), np.ones(size),
                                 np.arange(len(sheet.triangles)))
    group = []
    for exponents in product((0, 1), repeat=len(actions)):
        element = identity
        for action, power in zip(actions, exponents):
            if power:
                element = element.then(action)
        group.append((element, exponents))
    return group


class MirroredSystem:
    """A symmetric sheet's equations on its even deformations, and its tangent per class.

    The same interface as :class:`~.sheet.SheetSystem` for :func:`~.sheet.trace_path` and
    :func:`~.sheet.solve_prescribed`, over the even class's unknowns (one per orbit of
    unknowns under the group). :meth:`tangent_blocks` gives the tangent of every class, the
    even one first; :meth:`sheet_unknowns` and :meth:`positions` give the whole sheet's.
    """

    def __init__(self, sheet: Sheet, mirrors: Sequence[Mirror]) -> None:
        if not mirrors:
            raise ValueError('a mirrored system needs at least one mirror')
        self.sheet = sheet
        bending = MidEdgeBending(sheet.reference_xy_m, sheet.triangles,
                                 sheet.plate_stiffness_nm, sheet.poisson_ratio,
                                 sheet.rest_tilt_sine)
        group = symmetry_group(sheet, bending, mirrors)
        self.order = len(group)
        for name in ('thickness_m', 'youngs_modulus_pa', 'poisson_ratio', 'loaded'):
            values = np.asarray(getattr(sheet, name))
            for element, _ in group:
                if not np.array_equal(values[element.face_image], values):
                    raise ValueError(f'the sheet is not symmetric: {name} differs in a mirror '
                                     'image')
        nodes = sheet.node_count
        position_dofs = 3 * nodes
        held = np.asarray(sheet.fixed, dtype=bool).ravel()
        symmetric_held = held.copy()
        for element, _ in group:
            symmetric_held[element.image[:position_dofs]] &= held
        released = np.flatnonzero(held & ~symmetric_held)
        if len(released) > 1:
            raise ValueError(f'{len(released)} held coordinates have free images; at most '
                             'one (a rigid translation) can be released')
        if len(released) == 1 and released[0] % 3 == 2:
            raise ValueError('a held out-of-plane coordinate has a free image: the cushion '
                             'resists that translation')
        self._released = int(released[0]) if len(released) else None
        cell = _cell_faces(group, len(sheet.triangles))
        symmetric = replace(sheet, fixed=symmetric_held.reshape(nodes, 3))
        self.cell = SheetSystem(symmetric, faces=cell)
        free = self.cell.free
        where = np.full(self.cell.size_all, -1)
        where[free] = np.arange(len(free))
        classes = _class_signs(len(mirrors))
        self.blocks = [_class_basis(group, free, where, signs) for signs in classes]
        self.class_names = tuple(_class_name(signs, mirrors) for signs in classes)
        """Each class by the mirrors it is odd under: ``'even'``, ``'odd in y'``, ..."""
        if self._released is not None:
            self.blocks = [_without_translation(basis, free, where, self._released,
                                                position_dofs)
                           for basis in self.blocks]
        self.basis = self.blocks[0]
        self._gram = np.asarray(self.basis.multiply(self.basis).sum(axis=0)).ravel()
        self.moves_positions = _position_columns(self.basis, free, position_dofs)
        """True for the even unknowns that move coordinates (the others turn edges)."""
        self._sheet_free = np.flatnonzero(~np.concatenate(
            [held, np.zeros(bending.edge_count, dtype=bool)]))
        self.extent_m = self.cell.extent_m
        self.free_count = self.basis.shape[1]
        self._layouts: dict[int, tuple[IntArray, FloatArray,
                                       tuple[IntArray, IntArray, IntArray]]] = {}

    # The interface of SheetSystem, over the even unknowns.
    def rest_values(self) -> FloatArray:
        """Return the even unknowns of the reference (flat) shape."""
        return self.restrict(self.cell.reference[self.cell.free])

    def restrict(self, symmetric_free: FloatArray) -> FloatArray:
        """Even unknowns nearest (least squares) to free unknowns of the symmetric model."""
        return np.asarray(self.basis.T @ symmetric_free) / self._gram

    def restrict_sheet(self, sheet_unknowns: npt.ArrayLike) -> FloatArray:
        """Even unknowns of a symmetric shape given as the sheet's own free unknowns."""
        full = self.cell.reference.copy()
        full[self._sheet_free] = np.asarray(sheet_unknowns, dtype=np.float64)
        return self.restrict(full[self.cell.free])

    def _all(self, values: FloatArray) -> FloatArray:
        unknowns = self.cell.full(np.asarray(self.basis @ values))
        if self._released is not None:
            axis = self._released % 3
            shift = self.cell.reference[self._released] - unknowns[self._released]
            unknowns[axis:3 * self.sheet.node_count:3] += shift
        return unknowns

    def sheet_unknowns(self, values: FloatArray) -> FloatArray:
        """Return the whole sheet's free unknowns (its own held coordinates held)."""
        return self._all(values)[self._sheet_free]

    def nodal_load(self, forces_n: FloatArray) -> FloatArray:
        """Return the load on the even unknowns of symmetric forces ``(n, 3)`` on the nodes."""
        return np.asarray(self.basis.T @ self.cell.nodal_load(forces_n))

    def positions(self, values: FloatArray) -> FloatArray:
        """Node positions ``(n, 3)`` of the whole sheet [m]."""
        return self._all(values)[:3 * self.sheet.node_count].reshape(-1, 3)

    def volume_m3(self, values: FloatArray) -> float:
        """Volume under the loaded triangles [m3]."""
        return self.order * self.cell.volume_m3(np.asarray(self.basis @ values))

    def energies_j(self, values: FloatArray) -> tuple[float, float]:
        """``(membrane, bending)`` strain energies of the whole sheet [J]."""
        membrane, bending = self.cell.energies_j(np.asarray(self.basis @ values))
        return self.order * membrane, self.order * bending

    def gradients(self, values: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Strain-energy and volume gradients over the even unknowns."""
        energy, volume = self.cell.gradients(np.asarray(self.basis @ values))
        return (self.order * np.asarray(self.basis.T @ energy),
                self.order * np.asarray(self.basis.T @ volume))

    def hessians(self, values: FloatArray, pressure_pa: float) -> csc_matrix:
        """Return the even class's tangent ``H - p H_V``."""
        return self.tangent_blocks(values, pressure_pa, classes=1)[0]

    def tangent_blocks(self, values: FloatArray, pressure_pa: float,
                       classes: int = 0) -> list[csc_matrix]:
        """Return the tangent of each symmetry class (``classes`` of them, 0 all), even first.

        Each block is ``order B^T H B`` of the cell's tangent ``H`` and the class's basis
        ``B``, summed straight from the cell's element entries: every free unknown is in
        one orbit, so a row of ``B`` has at most one entry and an element entry at
        ``(r, c)`` lands at ``(column(r), column(c))`` with the product of their signs.
        """
        entries = self.cell.hessian_entries(np.asarray(self.basis @ values), pressure_pa)
        blocks = []
        for index in range(classes or len(self.blocks)):
            keep, weight, (slot, indices, indptr) = self._block_layout(index)
            size = len(indptr) - 1
            data = kernels.scatter_add(slot, weight, entries, keep, len(indices))
            blocks.append(csc_matrix((data, indices, indptr), shape=(size, size)))
        return blocks

    def adopt_layouts(self, other: 'MirroredSystem') -> bool:
        """Share ``other``'s class layouts if they are this system's; return whether shared.

        A layout (:meth:`_block_layout`) depends on the cell's element entries and the class
        bases alone, which a sheet of the same mesh, mirrors and supports in another rest
        state (a moulded one) has too: where both are equal, the two systems keep their
        layouts in one store from then on, each made once for both.
        """
        same = (np.array_equal(self.cell.entry_rows, other.cell.entry_rows)
                and np.array_equal(self.cell.entry_cols, other.cell.entry_cols)
                and self.order == other.order and len(self.blocks) == len(other.blocks)
                and all(mine.shape == theirs.shape and (mine != theirs).nnz == 0
                        for mine, theirs in zip(self.blocks, other.blocks)))
        if same:
            other._layouts.update(self._layouts)
            self._layouts = other._layouts
        return same

    def _block_layout(self, index: int) -> tuple[IntArray, FloatArray,
                                                 tuple[IntArray, IntArray, IntArray]]:
        """Return a class's cell entries, their weights and its CSC layout (made once)."""
        if index not in self._layouts:
            basis = self.blocks[index]
            rows, cols = self.cell.entry_rows, self.cell.entry_cols
            by_row = basis.tocsr()
            if np.any(np.diff(by_row.indptr) > 1):
                raise ValueError('a free unknown lies in two orbits')
            column = np.full(basis.shape[0], -1)
            sign = np.zeros(basis.shape[0])
            present = np.flatnonzero(np.diff(by_row.indptr))
            column[present] = by_row.indices[by_row.indptr[present]]
            sign[present] = by_row.data[by_row.indptr[present]]
            keep = np.flatnonzero((column[rows] >= 0) & (column[cols] >= 0))
            weight = self.order * sign[rows[keep]] * sign[cols[keep]]
            self._layouts[index] = (keep, weight, csc_layout(
                column[rows[keep]], column[cols[keep]], basis.shape[1]))
        return self._layouts[index]


def _cell_faces(group: list[tuple[SignedPermutation, tuple[int, ...]]],
                count: int) -> IntArray:
    """One triangle of every orbit (the least index), each orbit as large as the group."""
    images = np.stack([element.face_image for element, _ in group])
    ordered = np.sort(images, axis=0)
    if np.any(ordered[1:] == ordered[:-1]):
        raise ValueError('a triangle is its own image under the group')
    return np.flatnonzero(images.min(axis=0) == np.arange(count))


def _class_signs(mirrors: int) -> list[tuple[int, ...]]:
    """Characters of the classes (+1 even, -1 odd per mirror), the even class first."""
    return [tuple(signs) for signs in product((1, -1), repeat=mirrors)]


def _class_name(signs: tuple[int, ...], mirrors: Sequence[Mirror]) -> str:
    """Return ``'even'`` or ``'odd in x'``, ...: the coordinates whose mirror flips it."""
    odd = [('x', 'y')[mirror.axis] for sign, mirror in zip(signs, mirrors) if sign < 0]
    return 'odd in ' + ' and '.join(odd) if odd else 'even'


def _class_basis(group: list[tuple[SignedPermutation, tuple[int, ...]]], free: IntArray,
                 where: IntArray, signs: tuple[int, ...]) -> csc_matrix:
    """Basis ``(free, k)`` of a class: per orbit of free unknowns, its projected unit vector."""
    rows, cols, data = [], [], []
    images = np.stack([where[element.image[free]] for element, _ in group])
    if np.any(images < 0):
        raise ValueError('a free unknown has a held image')
    least = images.min(axis=0)
    representatives = np.flatnonzero(least == np.arange(len(free)))
    column = np.full(len(free), -1)
    column[representatives] = np.arange(len(representatives))
    for (element, exponents), image in zip(group, images):
        character = np.prod([s if power else 1 for s, power in zip(signs, exponents)])
        rows.append(image[representatives])
        cols.append(column[representatives])
        data.append(character * element.sign[free[representatives]])
    basis = coo_matrix((np.concatenate(data), (np.concatenate(rows), np.concatenate(cols))),
                       shape=(len(free), len(representatives))).tocsc()
    basis.sum_duplicates()
    basis.eliminate_zeros()
    keep = np.flatnonzero(np.diff(basis.indptr) > 0)
    basis = basis[:, keep]
    largest = np.asarray(abs(basis).max(axis=0).todense()).ravel()
    return csc_matrix(basis @ diags(1.0 / largest))


def _position_columns(basis: csc_matrix, free: IntArray, position_dofs: int) -> np.ndarray:
    """Return True for the basis columns that move coordinates (the others turn edges)."""
    first_rows = basis.indices[basis.indptr[:-1]]
    return free[first_rows] < position_dofs


def _without_translation(basis: csc_matrix, free: IntArray, where: IntArray,
                         released: int, position_dofs: int) -> csc_matrix:
    """Drop the released coordinate's orbit from the class that holds the rigid translation.

    The translation along the released coordinate's axis is a zero mode of the symmetric
    model; in the class that contains it, holding the released coordinate removes it, and
    since the translation costs no energy the rest of that block has the inertia the sheet
    with its pin has (the other classes keep the orbit: there it is a real deformation).
    """
    translation = ((free < position_dofs) & (free % 3 == released % 3)).astype(np.float64)
    if not np.any(basis.T @ translation):
        return basis
    row = where[released]
    keep = np.flatnonzero(np.asarray(basis[[row], :].todense()).ravel() == 0.0)
    return csc_matrix(basis[:, keep])
