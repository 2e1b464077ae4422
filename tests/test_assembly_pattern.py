"""The tangent's sparsity pattern and the LDL^T's gather maps built from the connectivity in
linear time (issue 31 item 4) equal the general construction (``np.unique`` over every COO entry,
argsort and lexsort): the same CSR structure, the same slot of every element entry (so the same
data, bit for bit), the same upper triangle of the symmetric part."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.sparse as sp

import flexmb
from flexmb import linear, models
from flexmb.fe.assembly import PartitionedPattern, node_pattern


def _general(problem) -> PartitionedPattern:
    """The pattern the general way: every block's COO entries through ``np.unique``."""
    slot_f, slot_p = problem._slots[:2]
    rows, cols = zip(*[(np.broadcast_to(a[:, :, None], a.shape + a.shape[1:]).ravel(),
                        np.broadcast_to(a[:, None, :], a.shape + a.shape[1:]).ravel()) for a in problem._blocks])
    return PartitionedPattern(np.concatenate(rows), np.concatenate(cols), slot_f, slot_p)


def _same(a: PartitionedPattern, b: PartitionedPattern) -> None:
    assert np.array_equal(a.slots, b.slots)
    assert a.nnz == b.nnz
    for x, y in zip(a._templates, b._templates):
        assert x.shape == y.shape
        assert np.array_equal(x.indptr, y.indptr) and np.array_equal(x.indices, y.indices)


def _leaf_chain(dim: int) -> flexmb.Mechanism:
    """Beyond the papers: three leaf springs in series in mm (a link between each), a force with an
    offset (a load-stiffness block) on the free tip, the middle link's x prescribed."""
    m = flexmb.Mechanism(dim=dim)
    m.add_link("ground", fixed=True)
    z = (0.0,) * (dim - 2)
    prev = "ground"
    for i in range(3):
        m.add_link(f"L{i}", position=(10.0 * (i + 1), 0.0) + z)
        m.add_joint(prev, f"L{i}", flexmb.LeafSpring(length=10.0, elements=4 + i, E=200e3, nu=0.3, width=5.0,
                                                       thickness=0.1), origin=(10.0 * i, 0.0) + z)
        prev = f"L{i}"
    m.prescribe("L1", x=0.01)
    m.apply_force("L2", (0.0, 0.5) + z, point=(30.0, 2.0) + z)
    return m


@pytest.mark.parametrize("build", [
    lambda: models.fourbar(3, displacement=0.3),
    lambda: models.fourbar(2, displacement=0.3, dim=2),
    lambda: models.manipulator("location", math.radians(30)),
    lambda: models.cross_flexure_pivot(4, dim=2, rotation=0.4),
    lambda: models.cantilever(12, dim=3),
    lambda: _leaf_chain(2),
    lambda: _leaf_chain(3),
], ids=["fourbar3d", "fourbar2d", "manipulator", "cross2d", "cantilever3d", "leaves2d", "leaves3d"])
def test_pattern_from_connectivity_equals_the_general_one(build):
    problem = build().compile().problem
    _same(problem._pattern, _general(problem))


def test_a_block_outside_the_elements_node_pairs_is_refused():
    """An extra block coupling two nodes no element joins: None (the caller builds it in general)."""
    master = np.array([[0, 1], [2, 3]])
    slot = np.arange(24)
    assert node_pattern(master, 4, 6, slot, np.full(24, -1), extra=(np.array([[0, 18]]),)) is None
    assert node_pattern(master, 4, 6, slot, np.full(24, -1), extra=(np.array([[0, 7]]),)) is not None


@pytest.mark.skipif(not linear.available()["qdldl"], reason="qdldl not installed")
def test_symmetric_part_maps_give_the_upper_triangle():
    """The analysis's gather maps (`TangentSolver._analyse`, from the transpose's counting sort)
    place ``(K + K^T)/2`` in its upper triangle's CSC order, on a non-symmetric K of a random
    symmetric structure and on the manipulator's tangent."""
    rng = np.random.default_rng(3)
    n = 300
    A = sp.random(n, n, density=0.02, random_state=4, format="csr")
    K = (A + A.T + sp.eye(n) * 10.0).tocsr()  # symmetric structure
    K.data += rng.normal(scale=0.1, size=K.nnz)  # non-symmetric numbers
    K.sort_indices()
    problem = models.manipulator("joint", 0.4).compile().problem
    _, K2, _, _ = problem.evaluate(problem.model.initial_state(), 0.0)
    for M in (K, K2):
        solver = linear.TangentSolver()
        solver._analyse(M)
        data = 0.5 * (M.data[solver._ia] + M.data[solver._ib])
        got = sp.csc_matrix((data, solver._upper.indices, solver._upper.indptr), shape=M.shape)
        ones = sp.csr_matrix((np.ones(M.nnz), M.indices, M.indptr), shape=M.shape)
        structure = sp.triu(ones + ones.T).tocsc()  # the stored entries' upper triangle, zeros kept
        structure.sort_indices()
        assert np.array_equal(got.indptr, structure.indptr) and np.array_equal(got.indices, structure.indices)
        dense = M.toarray()
        assert np.array_equal(got.toarray(), np.triu(0.5 * (dense + dense.T)))


def test_structurally_non_symmetric_matrix_is_not_analysed():
    """A pattern whose mirror entries are missing gets no LDL^T analysis (SuperLU solves it)."""
    K = sp.csr_matrix(np.triu(np.ones((80, 80))) + np.eye(80) * 80)
    solver = linear.TangentSolver(use_ldl=True)
    x = solver.solve(K, np.ones(80))
    assert solver._upper is None
    assert np.allclose(K @ x, np.ones(80), rtol=1e-12, atol=0)


@pytest.mark.parametrize("build", [lambda: models.fourbar(3, displacement=0.3), lambda: _leaf_chain(3),
                                   lambda: _leaf_chain(2)], ids=["fourbar3d", "leaves3d", "leaves2d"])
def test_compiled_passes_of_large_models_equal_numpys(build, monkeypatch, kernels):
    """The compiled row expansion and analysis maps (used from 200 000 entries on) give numpy's
    arrays: both thresholds lowered to 0 on small models."""
    from flexmb.fe import assembly

    kernels("numba")
    problem = build().compile().problem
    _, K, _, _ = problem.evaluate(problem.model.initial_state(), 0.0)
    numpy_maps = linear.TangentSolver._maps(K)
    monkeypatch.setattr(assembly, "COMPILED_FROM", 0)
    monkeypatch.setattr(linear, "COMPILED_ANALYSIS_FROM", 0)
    _same(type(problem)._pattern.func(problem), _general(problem))
    for a, b in zip(linear.TangentSolver._maps_compiled(K), numpy_maps):
        assert np.array_equal(a, b)
    broken = sp.csr_matrix(np.triu(np.ones((6, 6))))
    assert linear.TangentSolver._maps_compiled(broken) is None and linear.TangentSolver._maps(broken) is None
