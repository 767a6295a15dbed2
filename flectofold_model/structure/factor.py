"""Factorisations of the sheet's symmetric tangents and their inertia.

:func:`symmetric_factor` tries CHOLMOD's supernodal Cholesky ``P A P^T = L L^T`` [1]_ (through
cvxopt's binding [2]_) first, every time: its success says the tangent is positive definite
(no negative eigenvalue), its failure (a pivot that is not positive) says it is not, and then
SuperLU's symmetric-mode ``L D L^T`` factorises it and the signs of ``D`` count the negative
eigenvalues (Sylvester's law of inertia). Without cvxopt every factorisation is SuperLU's;
the solutions are the same to round-off either way. What each costs on the panels' tangents:
``msg_docs/structure.md``.

The symbolic analysis (fill-reducing ordering, supernodes) depends on the sparsity pattern
alone; it is made once per pattern and kept (:data:`PATTERNS_KEPT` patterns per thread: a
thread's factors are its own), since every tangent of a path has its system's one pattern.

cvxopt is GPL-3.0-or-later; it is imported on first use only.

References
----------
.. [1] Y. Chen, T. A. Davis, W. W. Hager, S. Rajamanickam, "Algorithm 887: CHOLMOD,
   supernodal sparse Cholesky factorization and update/downdate", ACM Transactions on
   Mathematical Software 35(3):22, 2008.
.. [2] M. S. Andersen, J. Dahl, L. Vandenberghe, CVXOPT 1.3, ``cvxopt.cholmod``.
"""

from collections import OrderedDict
import threading
from typing import Any, cast, Optional

import numpy as np
from scipy.sparse import csc_matrix
from scipy.sparse.linalg import splu, SuperLU

from flectofold_model._validate import FloatArray, IntArray

#: Sparsity patterns whose symbolic analysis is kept (least recently used dropped first).
PATTERNS_KEPT = 16

_cholmod: Any = None
_cvxopt: Any = None
_local = threading.local()


def _kept() -> 'OrderedDict[tuple[int, int, int], list[_Pattern]]':
    """Return this thread's kept patterns, least recently used first."""
    if not hasattr(_local, 'patterns'):
        _local.patterns = OrderedDict()
    return cast('OrderedDict[tuple[int, int, int], list[_Pattern]]', _local.patterns)


def available() -> bool:
    """Whether CHOLMOD (cvxopt) can be imported; without it :func:`cholesky` gives None."""
    global _cholmod, _cvxopt
    if _cholmod is None:
        try:
            import cvxopt
            from cvxopt import cholmod
        except ImportError:
            _cholmod = False
        else:
            _cvxopt, _cholmod = cvxopt, cholmod
    return _cholmod is not False


class _Pattern:
    """A CSC pattern's lower triangle as a cvxopt matrix and its symbolic factorisation."""

    def __init__(self, indices: IntArray, indptr: IntArray) -> None:
        size = len(indptr) - 1
        self.indices, self.indptr = indices.copy(), indptr.copy()
        columns = np.repeat(np.arange(size), np.diff(indptr))
        self.lower = np.flatnonzero(indices >= columns)
        self.matrix = _cvxopt.spmatrix(np.zeros(len(self.lower)),
                                       indices[self.lower].astype(np.int64),
                                       columns[self.lower].astype(np.int64), (size, size))
        # CHOLMOD keeps the entries column-major with sorted rows: the order of a sorted
        # CSC's lower entries, checked once here.
        probe = np.arange(1.0, len(self.lower) + 1.0)
        self.matrix.V = _cvxopt.matrix(probe)
        rows = np.asarray(self.matrix.I).ravel()
        cols = np.asarray(self.matrix.J).ravel()
        if not (np.array_equal(rows, indices[self.lower])
                and np.array_equal(cols, columns[self.lower])):
            raise ValueError('the CSC pattern is not sorted column by column')
        self._set_options()
        self.symbolic = _cholmod.symbolic(self.matrix, uplo='L')
        self.generation = 0
        """Numeric factorisations made on :attr:`symbolic`: a factor is valid while it is its."""

    @staticmethod
    def _set_options() -> None:
        _cholmod.options['supernodal'] = 2  # supernodal L L^T
        _cholmod.options['postorder'] = True
        _cholmod.options['print'] = 0

    def matches(self, indices: IntArray, indptr: IntArray) -> bool:
        return np.array_equal(self.indptr, indptr) and np.array_equal(self.indices, indices)


class CholeskyFactor:
    """A positive definite matrix's Cholesky factor; :meth:`solve` as SuperLU's."""

    def __init__(self, pattern: _Pattern) -> None:
        self._pattern = pattern
        self._generation = pattern.generation
        size = len(pattern.indptr) - 1
        self.shape = (size, size)

    def solve(self, rhs: FloatArray) -> FloatArray:
        """Return ``x`` with ``A x = rhs`` (a vector of the matrix's size).

        Raises RuntimeError when another matrix of the same pattern has been factorised since.
        """
        if self._pattern.generation != self._generation:
            raise RuntimeError('another matrix of this pattern was factorised since')
        solution = _cvxopt.matrix(np.ascontiguousarray(rhs, dtype=np.float64))
        _cholmod.solve(self._pattern.symbolic, solution)
        return np.asarray(solution).ravel()


def cholesky(matrix: csc_matrix) -> Optional[CholeskyFactor]:
    """Return the Cholesky factor of a symmetric ``matrix``; None if it is not positive definite.

    Only the lower triangle is read. None too where CHOLMOD is not installed
    (:func:`available`). A factor lives in its pattern's symbolic factorisation, which the
    next matrix of the same pattern refactorises: its :meth:`~CholeskyFactor.solve` then
    refuses.
    """
    if not available() or matrix.shape[0] == 0:
        return None
    matrix = _sorted_csc(matrix)
    return _numeric(_pattern(matrix.indices, matrix.indptr), matrix)


def symmetric_factor(matrix: csc_matrix) -> tuple['CholeskyFactor | SuperLU', Optional[int]]:
    """Factorise a symmetric ``matrix`` and count its negative eigenvalues.

    Cholesky (:func:`cholesky`, 0 negative eigenvalues); where it fails, SuperLU's symmetric
    mode (minimum degree on ``A + A^T``, diagonal pivots), ``P A P^T = L D L^T`` with ``D``
    the diagonal of ``U``, whose signs are those of the eigenvalues (Sylvester's law of
    inertia). The count is None where SuperLU pivoted off the diagonal after all.

    Raises
    ------
    RuntimeError
        Where SuperLU finds the matrix exactly singular.
    """
    found = cholesky(matrix)
    if found is not None:
        return found, 0
    factor = symmetric_lu(matrix)
    pivots = lu_pivots(factor)
    return factor, None if pivots is None else int(np.count_nonzero(pivots < 0.0))


def positive_definite(matrix: csc_matrix) -> 'CholeskyFactor | SuperLU | None':
    """Return a factor of a symmetric ``matrix`` if it is positive definite, else None.

    :func:`symmetric_factor` with no negative eigenvalue counted: Cholesky's success, or
    SuperLU's symmetric mode with every pivot above zero (a zero pivot is exactly singular,
    which SuperLU raises).

    Raises
    ------
    RuntimeError
        Where SuperLU finds the matrix exactly singular.
    """
    factor, negatives = symmetric_factor(matrix)
    return factor if negatives == 0 else None


def symmetric_lu(matrix: csc_matrix) -> SuperLU:
    """Factorise in SuperLU's symmetric mode: minimum degree on ``A + A^T``, diagonal pivots."""
    return splu(matrix, permc_spec='MMD_AT_PLUS_A', diag_pivot_thresh=0.0,
                options={'SymmetricMode': True})


def lu_pivots(factor: SuperLU) -> Optional[FloatArray]:
    """Return the pivots ``D`` of a symmetric-mode factor ``P H P^T = L D L^T``.

    Their signs are the tangent's inertia; None where SuperLU pivoted off the diagonal after
    all.
    """
    if not np.array_equal(factor.perm_r, factor.perm_c):
        return None
    return factor.U.diagonal()


def _sorted_csc(matrix: csc_matrix) -> csc_matrix:
    matrix = matrix.tocsc()
    return matrix if matrix.has_sorted_indices else matrix.sorted_indices()


def _numeric(pattern: _Pattern, matrix: csc_matrix) -> Optional[CholeskyFactor]:
    pattern.matrix.V = _cvxopt.matrix(np.ascontiguousarray(matrix.data[pattern.lower],
                                                           dtype=np.float64))
    pattern._set_options()
    pattern.generation += 1
    try:
        _cholmod.numeric(pattern.matrix, pattern.symbolic)
    except ArithmeticError:
        return None
    return CholeskyFactor(pattern)


def _pattern(indices: IntArray, indptr: IntArray) -> _Pattern:
    patterns = _kept()
    key = (len(indptr) - 1, len(indices), int(indices[-1]) if len(indices) else -1)
    kept = patterns.get(key, [])
    for pattern in kept:
        if pattern.matches(indices, indptr):
            patterns.move_to_end(key)
            return pattern
    pattern = _Pattern(indices, indptr)
    patterns[key] = kept + [pattern]
    patterns.move_to_end(key)
    while sum(len(found) for found in patterns.values()) > PATTERNS_KEPT:
        patterns.popitem(last=False)
    return pattern
