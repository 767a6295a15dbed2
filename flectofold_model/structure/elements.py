"""The elements of the structural sheet: membrane triangles, dihedral angles, cushion prisms.

Every element is vectorised over many elements of one kind. Each function takes the current
node positions of the elements' corners, shape ``(m, k, 3)`` for ``m`` elements of ``k``
nodes, and returns energies ``(m,)``, gradients ``(m, k, 3)`` or Hessians ``(m, 3k, 3k)``.

* **Membrane**: the constant-strain triangle with the St Venant-Kirchhoff law in plane stress,
  energy ``A0 (C / 2) [(1 - nu) tr(E^2) + nu tr(E)^2]`` per element, ``C = E t / (1 - nu^2)``,
  ``E`` the Green-Lagrange strain of the flat reference; exact for large rotations.
* **Dihedral angle** of two triangles sharing an edge, signed, 0 flat; its gradient (the
  closed form of Bridson, Marino & Fedkiw, SCA 2003) is compiled with the bending energy
  built on it (:mod:`.kernels`, :mod:`.shell`).
* **Cushion prism**: the volume between a triangle of the loaded surface and the fixed plane
  ``z = z0`` below it, ``S_z (z_mean - z0)`` with ``S_z`` the triangle's area projected on the
  plane. Its gradient times the gauge pressure is the cushion's load, which therefore follows
  the surface as it turns (a follower load) and is conservative: the work of the pressure
  equals ``integral p dV`` exactly.

The membrane Hessian is analytic (:func:`membrane_hessian`, geometric plus material
stiffness), as is the bending's (:mod:`.kernels`); the cushion prisms' is central differences
of their analytic gradient, element by element (the volume is smooth; the step is
:data:`HESSIAN_STEP_M`), which keeps Newton's method quadratic to the residuals the path solver
asks for.
"""

from typing import Callable, cast

import numpy as np

from flectofold_model._validate import FloatArray

#: Step of the central differences of the element Hessians [m, or rad for rotations].
HESSIAN_STEP_M = 1e-7


def membrane_reference(reference_xy: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Inverse reference edge matrices ``(m, 2, 2)`` and reference areas ``(m,)`` [m2].

    ``reference_xy`` holds the flat corners ``(m, 3, 2)``, counter-clockwise.
    """
    edges = np.stack([reference_xy[:, 1] - reference_xy[:, 0],
                      reference_xy[:, 2] - reference_xy[:, 0]], axis=-1)
    area = 0.5 * np.linalg.det(edges)
    if np.any(area <= 0.0):
        raise ValueError('membrane triangles must be counter-clockwise with positive area')
    return cast(FloatArray, np.linalg.inv(edges)), area  # float64 in, float64 out


def membrane_energy(corners: FloatArray, inverse: FloatArray, area: FloatArray,
                    modulus_n_per_m: FloatArray, poisson: FloatArray) -> FloatArray:
    """Strain energy of constant-strain triangles [J] (``modulus = E t / (1 - nu^2)``)."""
    strain = _green_strain(corners, inverse)
    trace = strain[:, 0, 0] + strain[:, 1, 1]
    squared = np.einsum('mij,mij->m', strain, strain)
    return area * 0.5 * modulus_n_per_m * ((1.0 - poisson) * squared + poisson * trace**2)


def membrane_gradient(corners: FloatArray, inverse: FloatArray, area: FloatArray,
                      modulus_n_per_m: FloatArray, poisson: FloatArray) -> FloatArray:
    """Gradient of :func:`membrane_energy` with respect to the corners ``(m, 3, 3)`` [N]."""
    deformation = _deformation(corners, inverse)
    strain = 0.5 * (np.einsum('mki,mkj->mij', deformation, deformation) - np.eye(2))
    trace = strain[:, 0, 0] + strain[:, 1, 1]
    stress = modulus_n_per_m[:, None, None] * (
        (1.0 - poisson)[:, None, None] * strain + (poisson * trace)[:, None, None] * np.eye(2))
    edge_force = area[:, None, None] * np.einsum('mki,mij,mlj->mkl', deformation, stress,
                                                 inverse)
    gradient = np.empty_like(corners)
    gradient[:, 1:] = np.swapaxes(edge_force, 1, 2)
    gradient[:, 0] = -edge_force.sum(axis=2)
    return gradient


def membrane_hessian(corners: FloatArray, inverse: FloatArray, area: FloatArray,
                     modulus_n_per_m: FloatArray, poisson: FloatArray) -> FloatArray:
    """Hessian of :func:`membrane_energy` ``(m, 9, 9)``, corners' coordinates node by node.

    With ``F = X B`` (``B`` the reference shape gradients of the three corners, ``(3, 2)``),
    ``S`` the second Piola-Kirchhoff stress and ``dE(k, i) = sym(B_k F_i)`` the strain a unit
    move of corner ``k`` along ``i`` makes: ``H = A [(B S B^T)_kl delta_ij + C ((1 - nu)
    dE(k, i) : dE(l, j) + nu tr dE(k, i) tr dE(l, j))]`` (geometric plus material stiffness).
    """
    deformation = _deformation(corners, inverse)
    strain = 0.5 * (np.einsum('mki,mkj->mij', deformation, deformation) - np.eye(2))
    trace = strain[:, 0, 0] + strain[:, 1, 1]
    stress = modulus_n_per_m[:, None, None] * (
        (1.0 - poisson)[:, None, None] * strain + (poisson * trace)[:, None, None] * np.eye(2))
    shape = np.einsum('kc,mca->mka', _CORNER_EDGES, inverse)  # (m, 3 corners, 2)
    geometric = np.einsum('mka,mab,mlb->mkl', shape, stress, shape)
    count = len(corners)
    hessian = np.einsum('mkl,ij->mkilj', geometric, np.eye(3)).reshape(count, 9, 9)
    # dE(k, i)_ab = (B_ka F_ib + F_ia B_kb) / 2, as (m, 9, 4).
    half = np.einsum('mka,mib->mkiab', shape, deformation)
    variation = 0.5 * (half + np.swapaxes(half, 3, 4)).reshape(count, 9, 4)
    traces = variation[:, :, 0] + variation[:, :, 3]
    material = modulus_n_per_m[:, None, None] * (
        (1.0 - poisson)[:, None, None] * np.einsum('mpa,mqa->mpq', variation, variation)
        + poisson[:, None, None] * np.einsum('mp,mq->mpq', traces, traces))
    return area[:, None, None] * (hessian + material)


#: Corner -> edge vectors of a triangle: ``e1 = x1 - x0``, ``e2 = x2 - x0`` (rows: corners).
_CORNER_EDGES = np.array([[-1.0, -1.0], [1.0, 0.0], [0.0, 1.0]])


def membrane_principal_strain(corners: FloatArray, inverse: FloatArray) -> FloatArray:
    """Principal Green-Lagrange strains ``(m, 2)`` of triangles, largest magnitude first."""
    values = cast(FloatArray, np.linalg.eigvalsh(_green_strain(corners, inverse)))  # float64
    order = np.argsort(-np.abs(values), axis=1)
    return np.take_along_axis(values, order, axis=1)


def _deformation(corners: FloatArray, inverse: FloatArray) -> FloatArray:
    edges = np.stack([corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]], axis=-1)
    return edges @ inverse


def _green_strain(corners: FloatArray, inverse: FloatArray) -> FloatArray:
    deformation = _deformation(corners, inverse)
    return 0.5 * (np.einsum('mki,mkj->mij', deformation, deformation) - np.eye(2))


def dihedral_angle(corners: FloatArray) -> FloatArray:
    """Signed dihedral angles of hinges ``(m,)`` [rad], 0 when the two triangles are flat.

    A hinge's corners are ``(edge start, edge end, wing of triangle A, wing of triangle B)``;
    triangle A is ``(edge start, edge end, wing A)`` counter-clockwise in the reference and
    triangle B ``(edge end, edge start, wing B)``.
    """
    edge, normal_a, normal_b = _hinge_vectors(corners)
    length = np.linalg.norm(edge, axis=-1)
    sine = np.einsum('mi,mi->m', cross_rows(normal_a, normal_b), edge) / length
    cosine = np.einsum('mi,mi->m', normal_a, normal_b)
    return np.arctan2(sine, cosine)


def _hinge_vectors(corners: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    edge = corners[:, 1] - corners[:, 0]
    normal_a = cross_rows(edge, corners[:, 2] - corners[:, 0])
    normal_b = cross_rows(corners[:, 3] - corners[:, 0], edge)
    return edge, normal_a, normal_b


def prism_volume(corners: FloatArray, base_z_m: float) -> FloatArray:
    """Volume between surface triangles and the plane ``z = base_z_m`` ``(m,)`` [m3]."""
    return _projected_area(corners) * (corners[:, :, 2].mean(axis=1) - base_z_m)


def prism_gradient(corners: FloatArray, base_z_m: float) -> FloatArray:
    """Gradient of :func:`prism_volume` ``(m, 3, 3)`` [m2]: the load per pascal."""
    x, y = corners[:, :, 0], corners[:, :, 1]
    height = corners[:, :, 2].mean(axis=1) - base_z_m
    gradient = np.empty_like(corners)
    following, preceding = [1, 2, 0], [2, 0, 1]
    gradient[:, :, 0] = 0.5 * (y[:, following] - y[:, preceding]) * height[:, None]
    gradient[:, :, 1] = 0.5 * (x[:, preceding] - x[:, following]) * height[:, None]
    gradient[:, :, 2] = (_projected_area(corners) / 3.0)[:, None]
    return gradient


def _projected_area(corners: FloatArray) -> FloatArray:
    x, y = corners[:, :, 0], corners[:, :, 1]
    return 0.5 * ((x[:, 1] - x[:, 0]) * (y[:, 2] - y[:, 0])
                  - (x[:, 2] - x[:, 0]) * (y[:, 1] - y[:, 0]))


def finite_difference_hessian(gradient: Callable[[FloatArray], FloatArray], local: FloatArray,
                              step: float = HESSIAN_STEP_M) -> FloatArray:
    """Central-difference Hessians ``(m, k, k)`` of an element gradient function.

    ``gradient(local)`` maps the elements' local unknowns ``(m, k)`` to ``(m, k)``; the
    Hessian is symmetrised.
    """
    count, size = local.shape
    hessian = np.empty((count, size, size))
    for column in range(size):
        plus = local.copy()
        minus = local.copy()
        plus[:, column] += step
        minus[:, column] -= step
        hessian[:, :, column] = (gradient(plus) - gradient(minus)) / (2.0 * step)
    return 0.5 * (hessian + np.swapaxes(hessian, 1, 2))


def cross_rows(a: FloatArray, b: FloatArray) -> FloatArray:
    """Row-wise cross product of ``(m, 3)`` arrays (``np.cross`` without its axis handling)."""
    return np.stack([a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1],
                     a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2],
                     a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]], axis=1)
