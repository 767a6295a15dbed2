"""Bending of a triangulated sheet by mid-edge directors: a discrete Kirchhoff-Love plate.

Every edge carries a director, a unit vector tilted from the normals of the faces beside it;
its tilt from face ``f`` at edge ``i`` is ``beta = theta / 2 + sigma psi``, with ``theta`` the
dihedral angle of the edge (0 flat), ``psi`` the edge's own rotation (a degree of freedom;
``sigma = +1`` on one side, ``-1`` on the other) and, on a free or supported boundary edge,
``beta = psi`` alone. Interpolating the directors linearly between the mid-edges
(Crouzeix-Raviart) gives each face a constant second fundamental form, with ``e_a`` the
reference edge vectors from corner 0, ``m_i`` the outward unit normal of the edge opposite
corner ``i`` (reference, flat):

``II(e_a, e_b) = -2 [sin(beta_a) m_a . e_b - sin(beta_0) m_0 . e_b]``, symmetrised,

the shape operator ``S = I^-1 II`` against the reference metric ``I`` and the Kirchhoff plate
energy ``A D / 2 [nu tr(S)^2 + (1 - nu) tr(S^2)]`` per face, ``D = E t^3 / (12 (1 - nu^2))``.
This is the mid-edge formulation of Chen, Sastry, van Rees & Vouga (ACM TOG 37(4), 2018,
after Grinspun, Gingold, Reisman & Zorin, Eurographics 2006 and Weischedel 2012): with the
edge rotations as unknowns it converges under mesh refinement on meshes that are not regular,
where the two-face hinge of bar-and-hinge models depends on the mesh. Free edges bend without
moment because their ``psi`` is free, and the face's curvature gives the surface strain
``kappa t / 2`` of its laminate directly.

The edge vectors enter through their reference values, so the plate energy is exact for
bending without stretch, which is what a GFRP sheet does (its membrane strains are of order
1e-4); the membrane triangles carry the stretch. A sheet moulded curved (a pre-folded hinge)
has rest tilts ``beta0`` and the energy of ``sin(beta) - sin(beta0)``: its second fundamental
form is measured from the moulded one, on the flat reference metric.
"""

import copy
from typing import Optional

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import FloatArray
from flectofold_model.structure import elements, kernels


class MidEdgeBending:
    """The bending energy of a sheet, its gradient and the local layout of its unknowns.

    Each face's local unknowns are 21: its three corners, the three wings across its edges
    (the far corner of the neighbouring face; a boundary edge repeats the opposite corner),
    18 coordinates in all, and the three edge rotations.
    """

    def __init__(self, reference_xy_m: npt.ArrayLike, faces: npt.ArrayLike,
                 plate_stiffness_nm: FloatArray, poisson_ratio: npt.ArrayLike,
                 rest_sine: Optional[npt.ArrayLike] = None) -> None:
        faces = np.asarray(faces, dtype=np.int64)
        self.rest_sine = (np.zeros(faces.shape) if rest_sine is None
                          else np.ascontiguousarray(rest_sine, dtype=np.float64))
        self.faces = faces
        count = len(faces)
        opposite_start = faces[:, [1, 2, 0]]
        opposite_end = faces[:, [2, 0, 1]]
        key = (np.minimum(opposite_start, opposite_end) * (faces.max() + 1)
               + np.maximum(opposite_start, opposite_end)).ravel()
        unique, edge = np.unique(key, return_inverse=True)
        self.edge_count = len(unique)
        edge = edge.reshape(count, 3)
        self.edges = edge
        uses = np.bincount(edge.ravel(), minlength=self.edge_count)
        if np.any(uses > 2):
            raise ValueError('an edge is shared by more than two faces')
        # The first face that uses an edge is its side +1, the second its side -1.
        order = np.argsort(edge.ravel(), kind='stable')
        first = np.zeros(edge.size, dtype=bool)
        first[order[np.r_[True, edge.ravel()[order][1:] != edge.ravel()[order][:-1]]]] = True
        self.side = np.where(first.reshape(count, 3), 1.0, -1.0)
        self.interior = (uses[edge] == 2)
        partner = np.full(edge.size, -1)
        flat_edge = edge.ravel()
        sorted_edges = flat_edge[order]
        pair = np.flatnonzero(sorted_edges[1:] == sorted_edges[:-1])
        partner[order[pair]] = order[pair + 1]
        partner[order[pair + 1]] = order[pair]
        wing = faces.ravel().copy()
        has = partner >= 0
        wing[has] = faces.ravel()[partner[has]]
        self.wings = np.where(self.interior, wing.reshape(count, 3), faces)
        corners = np.asarray(reference_xy_m)[faces]
        self.shape_basis = _shape_basis(corners)
        """``I^-1 B_i`` per face ``(m, 3, 2, 2)``: the shape operator per unit ``sin(beta_i)``."""
        self.quadratic = _face_quadratic(corners, self.shape_basis, plate_stiffness_nm,
                                         poisson_ratio)
        self.stencil = np.concatenate([faces, self.wings], axis=1)

    def subset(self, faces: npt.ArrayLike) -> 'MidEdgeBending':
        """Return the same bending restricted to some faces: their stencils, every edge."""
        chosen = np.asarray(faces, dtype=np.int64)
        part = copy.copy(self)
        for name in ('rest_sine', 'faces', 'edges', 'side', 'interior', 'wings',
                     'shape_basis', 'quadratic', 'stencil'):
            setattr(part, name, np.ascontiguousarray(getattr(self, name)[chosen]))
        return part

    def local_energy(self, local: FloatArray) -> FloatArray:
        """Bending energy per face ``(m,)`` [J] of local unknowns ``(m, 21)``."""
        beta = self._tilts(local)
        sine = np.sin(beta) - self.rest_sine
        return np.einsum('mi,mij,mj->m', sine, self.quadratic, sine)

    def local_gradient(self, local: FloatArray) -> FloatArray:
        """Gradient of :meth:`local_energy` with respect to the local unknowns ``(m, 21)``.

        Compiled (:func:`.kernels.bending_gradient`): ``2 M s`` times ``cos(beta)`` times the
        tilts' gradients, half the dihedral angle's on an interior edge plus ``sigma`` on the
        edge's rotation.
        """
        return kernels.bending_gradient(np.ascontiguousarray(local), self.interior, self.side,
                                        self.quadratic, self.rest_sine)

    def local_hessian(self, local: FloatArray) -> FloatArray:
        """Hessian of :meth:`local_energy` ``(m, 21, 21)``.

        ``E = s^T M s`` with ``s = sin(beta) - sin(beta0)``: the chain rule gives
        ``2 ds^T M ds + sum_i mu_i (cos(beta_i) d2beta_i - sin(beta_i) dbeta_i dbeta_i^T)``,
        ``mu = 2 M s``; the dihedral angles' own second derivatives ``d2beta_i`` (half the
        dihedral's) are the derivatives of their closed-form gradients. Compiled
        (:func:`.kernels.bending_hessian`).
        """
        return kernels.bending_hessian(np.ascontiguousarray(local), self.interior, self.side,
                                       self.quadratic,
                                       self.rest_sine).reshape(len(local), 21, 21)

    def _tilts(self, local: FloatArray) -> FloatArray:
        """Director tilts ``beta`` ``(m, 3)`` of local unknowns ``(m, 21)``."""
        corners = local[:, :18].reshape(-1, 6, 3)
        angles = np.zeros((len(local), 3))
        for i in range(3):
            mask = self.interior[:, i]
            if np.any(mask):
                angles[mask, i] = elements.dihedral_angle(
                    corners[mask][:, [(i + 1) % 3, (i + 2) % 3, i, 3 + i]])
        return 0.5 * angles + self.side * local[:, 18:]

    def tilt_sine(self, local: FloatArray) -> FloatArray:
        """Sines of the director tilts ``(m, 3)`` of local unknowns ``(m, 21)``."""
        return np.sin(self._tilts(local))

    def curvature_per_m(self, local: FloatArray, from_rest: bool = False) -> FloatArray:
        """Principal curvatures ``(m, 2)`` [1/m] of each face, largest magnitude first.

        With ``from_rest`` the change of curvature from the stress-free state, which is what
        strains the laminate.
        """
        sine = self.tilt_sine(local) - (self.rest_sine if from_rest else 0.0)
        shape = np.einsum('mi,mijk->mjk', sine, self.shape_basis)
        values = np.linalg.eigvals(shape).real
        order = np.argsort(-np.abs(values), axis=1)
        return np.take_along_axis(values, order, axis=1)


def _shape_basis(corners: FloatArray) -> FloatArray:
    """``I^-1 B_i`` per face ``(m, 3, 2, 2)``: the shape operator per unit ``sin(beta_i)``."""
    e1 = corners[:, 1] - corners[:, 0]
    e2 = corners[:, 2] - corners[:, 0]
    edges = np.stack([e1, e2], axis=1)
    metric = np.einsum('mai,mbi->mab', edges, edges)
    normals = []
    for i in range(3):
        tangent = corners[:, (i + 2) % 3] - corners[:, (i + 1) % 3]
        tangent = tangent / np.linalg.norm(tangent, axis=-1, keepdims=True)
        normals.append(np.stack([tangent[:, 1], -tangent[:, 0]], axis=-1))
    basis = np.zeros((len(corners), 3, 2, 2))
    for b in range(2):
        basis[:, 0, :, b] = 2.0 * np.einsum('mi,mi->m', normals[0], edges[:, b])[:, None]
        basis[:, 1, 0, b] = -2.0 * np.einsum('mi,mi->m', normals[1], edges[:, b])
        basis[:, 2, 1, b] = -2.0 * np.einsum('mi,mi->m', normals[2], edges[:, b])
    basis = 0.5 * (basis + np.swapaxes(basis, 2, 3))
    return np.einsum('mab,mibc->miac', np.linalg.inv(metric), basis)


def _face_quadratic(corners: FloatArray, shape: FloatArray, plate_stiffness_nm: FloatArray,
                    poisson_ratio: npt.ArrayLike) -> FloatArray:
    """``M`` per face ``(m, 3, 3)`` with the face's energy ``sin(beta)^T M sin(beta)`` [J].

    ``shape`` is :func:`_shape_basis` of the same corners.
    """
    e1 = corners[:, 1] - corners[:, 0]
    e2 = corners[:, 2] - corners[:, 0]
    area = 0.5 * (e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    trace = np.einsum('miaa->mi', shape)
    product = np.einsum('miab,mjba->mij', shape, shape)
    nu = np.asarray(poisson_ratio)[:, None, None]
    return (0.5 * (area * plate_stiffness_nm)[:, None, None]
            * (nu * trace[:, :, None] * trace[:, None, :] + (1.0 - nu) * product))
