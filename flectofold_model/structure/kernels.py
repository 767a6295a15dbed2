"""Compiled element kernels of the structural sheet: the mid-edge bending gradient and Hessian.

The same rules as :mod:`.shell` and :mod:`.elements` (the mid-edge plate energy
``s^T M s`` with ``s = sin(beta) - sin(beta0)`` per face; the signed dihedral angle and its
closed-form gradient of Bridson, Marino & Fedkiw, SCA 2003; the dihedral angle's own second
derivatives as the derivatives of that closed form, :func:`_dihedral_hessian`, symmetrised),
written as loops over the faces and compiled, so that no ``(m, 21, 21)`` temporaries or
per-hinge Python calls are made. The tests hold them to central differences of the numpy
energy (:meth:`.shell.MidEdgeBending.local_energy`) and of this gradient; the dihedral angle
itself is :mod:`.elements`'s.

A face's local unknowns are 21: its three corners, the three wings across its edges (the far
corner of the neighbouring face; a boundary edge repeats the opposite corner), 18
coordinates, then the three edge rotations. Edge ``i`` of a face is the hinge
``(corner i+1, corner i+2, corner i, wing i)``.
"""

import math

import numpy as np

from flectofold_model._compiled import inline_kernel, kernel
from flectofold_model._validate import BoolArray, FloatArray, IntArray


@inline_kernel
def _dihedral(x: FloatArray, slots: IntArray, out_gradient: FloatArray) -> float:
    """Signed dihedral angle of the hinge at ``slots`` of ``x`` (18 coordinates) [rad].

    Writes its gradient, 12 values in the order of ``slots``, into ``out_gradient``.
    """
    p0 = 3 * slots[0]
    p1 = 3 * slots[1]
    p2 = 3 * slots[2]
    p3 = 3 * slots[3]
    ex = x[p1] - x[p0]
    ey = x[p1 + 1] - x[p0 + 1]
    ez = x[p1 + 2] - x[p0 + 2]
    ax = x[p2] - x[p0]
    ay = x[p2 + 1] - x[p0 + 1]
    az = x[p2 + 2] - x[p0 + 2]
    bx = x[p3] - x[p0]
    by = x[p3 + 1] - x[p0 + 1]
    bz = x[p3 + 2] - x[p0 + 2]
    # normal_a = edge x a, normal_b = b x edge
    nax = ey * az - ez * ay
    nay = ez * ax - ex * az
    naz = ex * ay - ey * ax
    nbx = by * ez - bz * ey
    nby = bz * ex - bx * ez
    nbz = bx * ey - by * ex
    length_sq = ex * ex + ey * ey + ez * ez
    length = math.sqrt(length_sq)
    cx = nay * nbz - naz * nby
    cy = naz * nbx - nax * nbz
    cz = nax * nby - nay * nbx
    sine = (cx * ex + cy * ey + cz * ez) / length
    cosine = nax * nbx + nay * nby + naz * nbz
    wa = length / (nax * nax + nay * nay + naz * naz)
    wb = length / (nbx * nbx + nby * nby + nbz * nbz)
    along_a = (ax * ex + ay * ey + az * ez) / length_sq
    along_b = (bx * ex + by * ey + bz * ez) / length_sq
    out_gradient[6] = -wa * nax
    out_gradient[7] = -wa * nay
    out_gradient[8] = -wa * naz
    out_gradient[9] = -wb * nbx
    out_gradient[10] = -wb * nby
    out_gradient[11] = -wb * nbz
    out_gradient[0] = (1.0 - along_a) * wa * nax + (1.0 - along_b) * wb * nbx
    out_gradient[1] = (1.0 - along_a) * wa * nay + (1.0 - along_b) * wb * nby
    out_gradient[2] = (1.0 - along_a) * wa * naz + (1.0 - along_b) * wb * nbz
    out_gradient[3] = along_a * wa * nax + along_b * wb * nbx
    out_gradient[4] = along_a * wa * nay + along_b * wb * nby
    out_gradient[5] = along_a * wa * naz + along_b * wb * nbz
    return math.atan2(sine, cosine)


@inline_kernel
def _skew_into(out: FloatArray, row: int, column: int, v0: float, v1: float, v2: float,
               sign: float) -> None:
    """Add ``sign [v]x`` (``[v]x u = v x u``) into ``out[row:row+3, column:column+3]``."""
    out[row, column + 1] -= sign * v2
    out[row, column + 2] += sign * v1
    out[row + 1, column] += sign * v2
    out[row + 1, column + 2] -= sign * v0
    out[row + 2, column] -= sign * v1
    out[row + 2, column + 1] += sign * v0


@inline_kernel
def _dihedral_hessian(x: FloatArray, slots: IntArray, normal_a: FloatArray,
                      normal_b: FloatArray, scratch: FloatArray, out: FloatArray) -> None:
    """Write the dihedral angle's second derivatives ``(12, 12)`` at ``slots`` into ``out``.

    The derivatives of the closed-form gradient of :func:`_dihedral`: with ``e = x1 - x0``,
    ``a = x2 - x0``, ``b = x3 - x0``, ``n_a = e x a``, ``n_b = b x e``, ``w = |e| / |n|^2``
    and ``alpha = (. e) / |e|^2``, the gradient is ``-w_a n_a`` on ``x2``, ``-w_b n_b`` on
    ``x3``, ``(1 - alpha_a) w_a n_a + (1 - alpha_b) w_b n_b`` on ``x0`` and ``alpha_a w_a n_a +
    alpha_b w_b n_b`` on ``x1``; each term differentiated by the product rule, ``d n_a =
    ([a]x - [e]x) dx0 - [a]x dx1 + [e]x dx2`` and ``d n_b = ([e]x - [b]x) dx0 + [b]x dx1 -
    [e]x dx3``. ``normal_a``, ``normal_b`` (3, 12) and ``scratch`` (5, 12) are work arrays.
    """
    p0 = 3 * slots[0]
    p1 = 3 * slots[1]
    p2 = 3 * slots[2]
    p3 = 3 * slots[3]
    e = (x[p1] - x[p0], x[p1 + 1] - x[p0 + 1], x[p1 + 2] - x[p0 + 2])
    a = (x[p2] - x[p0], x[p2 + 1] - x[p0 + 1], x[p2 + 2] - x[p0 + 2])
    b = (x[p3] - x[p0], x[p3 + 1] - x[p0 + 1], x[p3 + 2] - x[p0 + 2])
    na = (e[1] * a[2] - e[2] * a[1], e[2] * a[0] - e[0] * a[2], e[0] * a[1] - e[1] * a[0])
    nb = (b[1] * e[2] - b[2] * e[1], b[2] * e[0] - b[0] * e[2], b[0] * e[1] - b[1] * e[0])
    length_sq = e[0] * e[0] + e[1] * e[1] + e[2] * e[2]
    length = math.sqrt(length_sq)
    qa = na[0] * na[0] + na[1] * na[1] + na[2] * na[2]
    qb = nb[0] * nb[0] + nb[1] * nb[1] + nb[2] * nb[2]
    wa = length / qa
    wb = length / qb
    ae = a[0] * e[0] + a[1] * e[1] + a[2] * e[2]
    be = b[0] * e[0] + b[1] * e[1] + b[2] * e[2]
    along_a = ae / length_sq
    along_b = be / length_sq
    for r in range(3):
        for c in range(12):
            normal_a[r, c] = 0.0
            normal_b[r, c] = 0.0
    _skew_into(normal_a, 0, 0, a[0], a[1], a[2], 1.0)
    _skew_into(normal_a, 0, 0, e[0], e[1], e[2], -1.0)
    _skew_into(normal_a, 0, 3, a[0], a[1], a[2], -1.0)
    _skew_into(normal_a, 0, 6, e[0], e[1], e[2], 1.0)
    _skew_into(normal_b, 0, 0, e[0], e[1], e[2], 1.0)
    _skew_into(normal_b, 0, 0, b[0], b[1], b[2], -1.0)
    _skew_into(normal_b, 0, 3, b[0], b[1], b[2], 1.0)
    _skew_into(normal_b, 0, 9, e[0], e[1], e[2], -1.0)
    # scratch rows: d|e|, d w_a, d w_b, d alpha_a, d alpha_b (each 12).
    for c in range(12):
        for r in range(5):
            scratch[r, c] = 0.0
    for k in range(3):
        scratch[0, k] = -e[k] / length
        scratch[0, 3 + k] = e[k] / length
    for c in range(12):
        dqa = 0.0
        dqb = 0.0
        for k in range(3):
            dqa += 2.0 * na[k] * normal_a[k, c]
            dqb += 2.0 * nb[k] * normal_b[k, c]
        scratch[1, c] = scratch[0, c] / qa - length * dqa / (qa * qa)
        scratch[2, c] = scratch[0, c] / qb - length * dqb / (qb * qb)
    for k in range(3):
        # d(a.e) = e.da + a.de and d|e|^2 = 2 e.de, da = dx2 - dx0, db = dx3 - dx0,
        # de = dx1 - dx0.
        scratch[3, k] = (-e[k] - a[k]) / length_sq + 2.0 * ae * e[k] / (length_sq * length_sq)
        scratch[3, 3 + k] = a[k] / length_sq - 2.0 * ae * e[k] / (length_sq * length_sq)
        scratch[3, 6 + k] = e[k] / length_sq
        scratch[4, k] = (-e[k] - b[k]) / length_sq + 2.0 * be * e[k] / (length_sq * length_sq)
        scratch[4, 3 + k] = b[k] / length_sq - 2.0 * be * e[k] / (length_sq * length_sq)
        scratch[4, 9 + k] = e[k] / length_sq
    for r in range(3):
        big_a = wa * na[r]
        big_b = wb * nb[r]
        for c in range(12):
            d_a = na[r] * scratch[1, c] + wa * normal_a[r, c]
            d_b = nb[r] * scratch[2, c] + wb * normal_b[r, c]
            out[6 + r, c] = -d_a
            out[9 + r, c] = -d_b
            out[r, c] = ((1.0 - along_a) * d_a - big_a * scratch[3, c]
                         + (1.0 - along_b) * d_b - big_b * scratch[4, c])
            out[3 + r, c] = (along_a * d_a + big_a * scratch[3, c]
                             + along_b * d_b + big_b * scratch[4, c])


@inline_kernel
def _hinge_slots(edge: int, slots: IntArray) -> None:
    slots[0] = (edge + 1) % 3
    slots[1] = (edge + 2) % 3
    slots[2] = edge
    slots[3] = 3 + edge


@inline_kernel
def _tilts(x: FloatArray, interior: BoolArray, side: FloatArray, beta: FloatArray,
           d_beta: FloatArray, slots: IntArray, gradient: FloatArray) -> None:
    """Tilts ``beta`` (3) and their gradients ``d_beta`` (3, 21) of one face's unknowns."""
    for i in range(3):
        for k in range(21):
            d_beta[i, k] = 0.0
        angle = 0.0
        if interior[i]:
            _hinge_slots(i, slots)
            angle = _dihedral(x, slots, gradient)
            for part in range(4):
                for c in range(3):
                    d_beta[i, 3 * slots[part] + c] = 0.5 * gradient[3 * part + c]
        d_beta[i, 18 + i] = side[i]
        beta[i] = 0.5 * angle + side[i] * x[18 + i]


@inline_kernel
def _moments(quadratic: FloatArray, beta: FloatArray, rest_sine: FloatArray,
             moment: FloatArray) -> None:
    """``mu = 2 M s`` of one face, ``s = sin(beta) - sin(beta0)``, into ``moment`` (3)."""
    for i in range(3):
        total = 0.0
        for j in range(3):
            total += 2.0 * quadratic[i, j] * (math.sin(beta[j]) - rest_sine[j])
        moment[i] = total


@kernel
def bending_gradient(local: FloatArray, interior: BoolArray, side: FloatArray,
                     quadratic: FloatArray, rest_sine: FloatArray) -> FloatArray:
    """Gradient of the mid-edge bending energy per face ``(m, 21)`` of ``local`` ``(m, 21)``."""
    count = local.shape[0]
    out = np.zeros((count, 21))
    beta = np.empty(3)
    d_beta = np.empty((3, 21))
    moment = np.empty(3)
    slots = np.empty(4, dtype=np.int64)
    gradient = np.empty(12)
    for f in range(count):
        x = local[f]
        _tilts(x, interior[f], side[f], beta, d_beta, slots, gradient)
        _moments(quadratic[f], beta, rest_sine[f], moment)
        for i in range(3):
            weight = moment[i] * math.cos(beta[i])
            for k in range(21):
                out[f, k] += weight * d_beta[i, k]
    return out


@kernel
def bending_hessian(local: FloatArray, interior: BoolArray, side: FloatArray,
                    quadratic: FloatArray, rest_sine: FloatArray) -> FloatArray:
    """Hessian of the mid-edge bending energy per face ``(m, 21 * 21)``, row by row.

    ``2 ds^T M ds + sum_i mu_i (cos(beta_i) d2beta_i - sin(beta_i) dbeta_i dbeta_i^T)``,
    ``mu = 2 M s``; ``d2beta_i`` is half the dihedral angle's second derivatives
    (:func:`_dihedral_hessian`), symmetrised.
    """
    count = local.shape[0]
    out = np.zeros((count, 21 * 21))
    beta = np.empty(3)
    d_beta = np.empty((3, 21))
    d_sine = np.empty((3, 21))
    moment = np.empty(3)
    slots = np.empty(4, dtype=np.int64)
    gradient = np.empty(12)
    second = np.empty((12, 12))
    normal_a = np.empty((3, 12))
    normal_b = np.empty((3, 12))
    scratch = np.empty((5, 12))
    for f in range(count):
        x = local[f]
        _tilts(x, interior[f], side[f], beta, d_beta, slots, gradient)
        for i in range(3):
            cosine = math.cos(beta[i])
            for k in range(21):
                d_sine[i, k] = cosine * d_beta[i, k]
        _moments(quadratic[f], beta, rest_sine[f], moment)
        h = out[f]
        for i in range(3):
            for j in range(3):
                weight = 2.0 * quadratic[f, i, j]
                if weight == 0.0:
                    continue
                for a in range(21):
                    da = weight * d_sine[i, a]
                    if da == 0.0:
                        continue
                    for b in range(21):
                        h[21 * a + b] += da * d_sine[j, b]
            curvature = moment[i] * math.sin(beta[i])
            for a in range(21):
                da = curvature * d_beta[i, a]
                if da == 0.0:
                    continue
                for b in range(21):
                    h[21 * a + b] -= da * d_beta[i, b]
        for i in range(3):
            if not interior[f, i]:
                continue
            weight = 0.5 * moment[i] * math.cos(beta[i])
            _hinge_slots(i, slots)
            _dihedral_hessian(x, slots, normal_a, normal_b, scratch, second)
            for row in range(12):
                a = 3 * slots[row // 3] + row % 3
                for column in range(12):
                    b = 3 * slots[column // 3] + column % 3
                    h[21 * a + b] += weight * 0.5 * (second[row, column] + second[column, row])
    return out


@inline_kernel
def _membrane_state(x: FloatArray, inverse: FloatArray, modulus: float, poisson: float,
                    deformation: FloatArray, stress: FloatArray) -> None:
    """Write a triangle's ``F`` ``(3, 2)`` and second Piola-Kirchhoff stress ``S`` ``(2, 2)``.

    ``x`` holds its corners' 9 coordinates; ``F = [x1 - x0, x2 - x0] inverse``,
    ``E = (F^T F - I) / 2``, ``S = C ((1 - nu) E + nu tr(E) I)`` with ``C = modulus``.
    """
    for i in range(3):
        e1 = x[3 + i] - x[i]
        e2 = x[6 + i] - x[i]
        for a in range(2):
            deformation[i, a] = e1 * inverse[0, a] + e2 * inverse[1, a]
    for a in range(2):
        for b in range(2):
            product = 0.0
            for i in range(3):
                product += deformation[i, a] * deformation[i, b]
            stress[a, b] = 0.5 * (product - (1.0 if a == b else 0.0))
    trace = stress[0, 0] + stress[1, 1]
    for a in range(2):
        for b in range(2):
            stress[a, b] = modulus * ((1.0 - poisson) * stress[a, b]
                                      + (poisson * trace if a == b else 0.0))


@kernel
def membrane_gradient(local: FloatArray, inverse: FloatArray, area: FloatArray,
                      modulus: FloatArray, poisson: FloatArray) -> FloatArray:
    """Gradient of the constant-strain triangles' energy ``(m, 9)`` [N], corner by corner.

    Edge forces ``A F S inverse^T`` ``(3, 2)`` on corners 1 and 2, their negative sum on
    corner 0 (the rule of :func:`.elements.membrane_gradient`).
    """
    count = local.shape[0]
    out = np.empty((count, 9))
    deformation = np.empty((3, 2))
    stress = np.empty((2, 2))
    for m in range(count):
        _membrane_state(local[m], inverse[m], modulus[m], poisson[m], deformation, stress)
        for i in range(3):
            total = 0.0
            for edge in range(2):
                force = 0.0
                for a in range(2):
                    for b in range(2):
                        force += deformation[i, a] * stress[a, b] * inverse[m, edge, b]
                force *= area[m]
                out[m, 3 * (edge + 1) + i] = force
                total += force
            out[m, i] = -total
    return out


@kernel
def membrane_hessian(local: FloatArray, inverse: FloatArray, area: FloatArray,
                     modulus: FloatArray, poisson: FloatArray) -> FloatArray:
    """Hessian of the constant-strain triangles' energy ``(m, 81)``, row by row.

    ``A [(B S B^T)_kl delta_ij + C ((1 - nu) dE(k, i) : dE(l, j) + nu tr dE(k, i)
    tr dE(l, j))]`` with ``B`` the corners' reference shape gradients and ``dE(k, i) =
    sym(B_k F_i)`` (the rule of :func:`.elements.membrane_hessian`).
    """
    count = local.shape[0]
    out = np.empty((count, 81))
    deformation = np.empty((3, 2))
    stress = np.empty((2, 2))
    shape = np.empty((3, 2))
    variation = np.empty((9, 4))
    traces = np.empty(9)
    for m in range(count):
        _membrane_state(local[m], inverse[m], modulus[m], poisson[m], deformation, stress)
        for a in range(2):
            shape[0, a] = -inverse[m, 0, a] - inverse[m, 1, a]
            shape[1, a] = inverse[m, 0, a]
            shape[2, a] = inverse[m, 1, a]
        for k in range(3):
            for i in range(3):
                p = 3 * k + i
                for a in range(2):
                    for b in range(2):
                        variation[p, 2 * a + b] = 0.5 * (shape[k, a] * deformation[i, b]
                                                         + deformation[i, a] * shape[k, b])
                traces[p] = variation[p, 0] + variation[p, 3]
        c = modulus[m]
        nu = poisson[m]
        for k in range(3):
            for other in range(3):
                geometric = 0.0
                for a in range(2):
                    for b in range(2):
                        geometric += shape[k, a] * stress[a, b] * shape[other, b]
                for i in range(3):
                    p = 3 * k + i
                    for j in range(3):
                        q = 3 * other + j
                        inner = 0.0
                        for ab in range(4):
                            inner += variation[p, ab] * variation[q, ab]
                        value = c * ((1.0 - nu) * inner + nu * traces[p] * traces[q])
                        if i == j:
                            value += geometric
                        out[m, 9 * p + q] = area[m] * value
    return out


@kernel
def scatter_add(slot: IntArray, weight: FloatArray, entries: FloatArray, keep: IntArray,
                size: int) -> FloatArray:
    """Return ``data`` ``(size,)`` with ``data[slot[e]] += weight[e] entries[keep[e]]``.

    In order of ``e``: the sums of ``np.bincount(slot, weights=weight * entries[keep])``,
    without its two temporaries.
    """
    data = np.zeros(size)
    for e in range(slot.shape[0]):
        data[slot[e]] += weight[e] * entries[keep[e]]
    return data
