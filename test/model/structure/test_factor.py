"""CHOLMOD's Cholesky of the tangents: the same answers as SuperLU, refusals where it must."""

import threading
import time

import numpy as np
import pytest
from scipy.sparse import csc_matrix, random as sparse_random
from scipy.sparse.linalg import spsolve

from flectofold_model.actuation.statics import DEMONSTRATOR_ACTUATED
from flectofold_model.structure import factor
from flectofold_model.structure.panel import PanelMesh, structural_path
from flectofold_model.structure.sheet import block_inertia, factorise

pytestmark = pytest.mark.skipif(not factor.available(), reason='cvxopt (CHOLMOD) not installed')


def _symmetric(size, shift, seed=3):
    rng = np.random.default_rng(seed)
    part = sparse_random(size, size, density=0.05, random_state=rng, format='csc')
    return csc_matrix(part + part.T + shift * np.eye(size))


def _without_cholmod(monkeypatch):
    monkeypatch.setattr(factor, '_cholmod', False)


def test_a_positive_definite_matrix_is_solved_as_scipy_solves_it():
    matrix = _symmetric(200, 10.0)
    assert np.linalg.eigvalsh(matrix.toarray()).min() > 0.0
    rhs = np.random.default_rng(5).standard_normal(200)
    found = factor.cholesky(matrix)
    assert found is not None
    assert found.solve(rhs) == pytest.approx(spsolve(matrix, rhs), rel=1e-10, abs=1e-12)


def test_a_matrix_with_one_negative_eigenvalue_is_not_factorised():
    matrix = _symmetric(200, 0.0).toarray()
    eigenvalues = np.linalg.eigvalsh(matrix)
    # Shift so that exactly the least eigenvalue is below zero.
    shifted = csc_matrix(matrix - 0.5 * (eigenvalues[0] + eigenvalues[1]) * np.eye(200))
    assert np.count_nonzero(np.linalg.eigvalsh(shifted.toarray()) < 0.0) == 1
    assert factor.cholesky(shifted) is None
    # SuperLU then factorises it, and the inertia counts its one negative eigenvalue.
    rhs = np.ones(200)
    assert factorise(shifted).solve(rhs) == pytest.approx(spsolve(shifted, rhs), rel=1e-8)


def test_an_unsorted_matrix_and_an_empty_one_are_taken():
    matrix = _symmetric(50, 10.0)
    order = np.arange(matrix.nnz)
    for column in range(50):
        span = slice(matrix.indptr[column], matrix.indptr[column + 1])
        order[span] = order[span][::-1]
    shuffled = csc_matrix((matrix.data[order], matrix.indices[order], matrix.indptr),
                          shape=matrix.shape)
    shuffled.has_sorted_indices = False
    rhs = np.arange(50.0)
    assert factor.cholesky(shuffled).solve(rhs) == pytest.approx(spsolve(matrix, rhs),
                                                                 rel=1e-10)
    assert factor.cholesky(csc_matrix((0, 0))) is None


def test_a_factor_refuses_to_solve_once_its_pattern_holds_another_matrix():
    matrix = _symmetric(60, 10.0)
    first = factor.cholesky(matrix)
    rhs = np.ones(60)
    first.solve(rhs)
    second = factor.cholesky(matrix * 2.0)
    with pytest.raises(RuntimeError, match='factorised since'):
        first.solve(rhs)
    assert second.solve(rhs) == pytest.approx(spsolve(matrix, rhs) / 2.0, rel=1e-10)


def test_the_kept_symbolic_analyses_are_bounded():
    factor._kept().clear()
    for size in range(20, 20 + factor.PATTERNS_KEPT):
        assert factor.cholesky(_symmetric(size, 10.0)) is not None
    assert sum(len(kept) for kept in factor._kept().values()) == factor.PATTERNS_KEPT
    assert factor.cholesky(_symmetric(19, 10.0)) is not None  # one beyond: the oldest goes
    assert sum(len(kept) for kept in factor._kept().values()) == factor.PATTERNS_KEPT
    assert all(key[0] != 20 for key in factor._kept())  # the first, size 20, went


def test_threads_factorising_matrices_of_one_pattern_keep_their_own_factors():
    matrix = _symmetric(120, 10.0)
    rhs = np.ones(120)
    expected = spsolve(matrix, rhs)
    failures = []

    def work(scale):
        try:
            for _ in range(200):
                found = factor.cholesky(matrix * scale)
                time.sleep(0)  # let the other thread factorise in between
                if not np.allclose(found.solve(rhs), expected / scale, rtol=1e-10):
                    failures.append(f'wrong solution at scale {scale}')
        except RuntimeError as error:
            failures.append(str(error))

    threads = [threading.Thread(target=work, args=(scale,)) for scale in (1.0, 3.0)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert failures == []


def test_without_cholmod_the_factorisation_and_inertia_are_superlus(monkeypatch):
    matrix = _symmetric(80, 10.0)
    rhs = np.ones(80)
    _without_cholmod(monkeypatch)
    assert not factor.available()
    assert factor.cholesky(matrix) is None
    assert type(factorise(matrix)).__name__ == 'SuperLU'
    assert factorise(matrix).solve(rhs) == pytest.approx(spsolve(matrix, rhs), rel=1e-10)


def test_a_path_with_cholmod_is_the_path_without_it(monkeypatch):
    mesh = PanelMesh(20, 2, 2, 2)
    kwargs = {'steps': 12, 'target_fold_rad': np.radians(60.0)}
    ours = structural_path(DEMONSTRATOR_ACTUATED, mesh, **kwargs)
    _without_cholmod(monkeypatch)
    theirs = structural_path(DEMONSTRATOR_ACTUATED, mesh, **kwargs)
    assert ours.ended == theirs.ended == 'closed'
    assert len(ours.pressure_pa) == len(theirs.pressure_pa) >= 10
    assert ours.pressure_pa == pytest.approx(theirs.pressure_pa, rel=1e-8, abs=1e-6)
    assert np.max(np.abs(ours.positions_m - theirs.positions_m)) < 1e-9
    assert np.array_equal(ours.negative_by_class, theirs.negative_by_class)
    assert np.array_equal(ours.stable_at_volume, theirs.stable_at_volume)


def test_the_inertia_of_an_indefinite_block_is_counted_by_superlu():
    class Blocks:
        def __init__(self, blocks):
            self.blocks = blocks

        def tangent_blocks(self, values, pressure):
            return self.blocks

        def gradients(self, values):
            return None, np.ones(self.blocks[0].shape[0])

    positive = _symmetric(40, 10.0)
    dense = _symmetric(40, 0.0).toarray()
    eigenvalues = np.linalg.eigvalsh(dense)
    two_negative = csc_matrix(dense - 0.5 * (eigenvalues[1] + eigenvalues[2]) * np.eye(40))
    found = block_inertia(Blocks([positive, two_negative]), None, 0.0)
    assert found is not None
    assert found[0] == (0, 2)
    assert found[1] == pytest.approx(np.ones(40) @ np.linalg.solve(positive.toarray(),
                                                                   np.ones(40)), rel=1e-10)
