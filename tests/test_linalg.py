"""The block-triangular batched solve against its plain twin, numpy.linalg.solve; the vector
lengths against theirs, numpy.linalg.norm."""

from __future__ import annotations

import numpy as np
import pytest

from mjlink import validation
from mjlink.model import jet
from mjlink.reference import kinetostatics, linalg


def test_dense_and_block_systems_match_lapack():
    rng = np.random.default_rng(0)
    A = rng.normal(size=(500, 7, 7)) + 5 * np.eye(7)
    b = rng.normal(size=(500, 7))
    assert np.allclose(linalg.solve(A, b), np.linalg.solve(A, b[..., None])[..., 0], rtol=1e-12, atol=1e-12)
    # Block lower-triangular with a permutation: the plan must find the blocks and their order.
    B = np.zeros((300, 6, 6))
    B[:, :2, :2] = rng.normal(size=(300, 2, 2)) + 3 * np.eye(2)
    B[:, 2:, :] = rng.normal(size=(300, 4, 6))
    B[:, 2:, 2:] += 4 * np.eye(4)
    perm = np.array([3, 0, 5, 1, 4, 2])
    B = B[:, perm][:, :, perm[::-1]]
    c = rng.normal(size=(300, 6))
    assert np.allclose(linalg.solve(B, c), np.linalg.solve(B, c[..., None])[..., 0], rtol=1e-11, atol=1e-12)


def test_singular_system_raises_like_lapack():
    A = np.zeros((3, 2, 2))
    A[:, 0, 0] = 1.0
    A[1, 1, 1] = 1.0  # structurally nonzero, numerically zero in rows 0 and 2
    with pytest.raises(np.linalg.LinAlgError):
        linalg.solve(A, np.ones((3, 2)))


@pytest.mark.parametrize("name", ["takeup", "crank_slider", "takeup_eyelets", "warp_knitting"])
def test_kinetostatics_equals_the_lapack_twin(name, monkeypatch):
    mech = validation.get(name)
    phi = mech.phi0 + np.linspace(0.0, mech.period, 97)
    fast = kinetostatics.reactions(mech, phi, mech.speed, 3.0)
    monkeypatch.setattr(linalg, "solve", lambda A, b: np.linalg.solve(A, b[..., None])[..., 0])
    plain = kinetostatics.reactions(mech, phi, mech.speed, 3.0)
    scale = max(np.abs(f).max() for f in plain.forces.values())
    for k in plain.forces:
        assert np.allclose(fast.forces[k], plain.forces[k], rtol=0, atol=1e-12 * scale), k
    assert np.allclose(fast.torque, plain.torque, rtol=1e-12, atol=1e-15)


def test_block_plan_equals_scipy_sparse_graph_searches():
    """The plain-Python matching and strongly connected components give the blocks scipy's
    sparse-graph routines give (the fine block-triangular form is unique): random sparse
    patterns, structurally singular ones included."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import connected_components, maximum_bipartite_matching

    rng = np.random.default_rng(5)
    for _ in range(300):
        m = int(rng.integers(1, 25))
        pattern = rng.random((m, m)) < rng.uniform(0.05, 0.4)
        if rng.random() < 0.8:  # mostly solvable: a permuted diagonal
            pattern[np.arange(m), rng.permutation(m)] = True
        plan = linalg._plan(pattern.tobytes(), m)
        match = maximum_bipartite_matching(csr_matrix(pattern.astype(np.int8)), perm_type="column")
        if np.any(match < 0):
            assert plan is None
            continue
        assert plan is not None
        _, label = connected_components(
            csr_matrix(pattern[:, match].astype(np.int8)), directed=True, connection="strong"
        )
        want = {frozenset(np.flatnonzero(label == a).tolist()) for a in np.unique(label)}
        assert {frozenset(rows) for rows, _ in plan} == want
        # Every block's unknowns are matched to its rows through structural nonzeros, and a
        # block only uses unknowns of itself or of blocks solved before it.
        solved: set[int] = set()
        for rows, cols in plan:
            assert all(pattern[r, c] for r, c in zip(rows, cols, strict=True))
            used = {int(c) for r in rows for c in np.flatnonzero(pattern[r])}
            assert used <= solved | set(cols)
            solved |= set(cols)


@pytest.mark.parametrize("shape", [(2000, 3), (2000, 2), (6, 400, 3), (0, 3), (3,), (50, 4), (1, 2)])
def test_norms_equal_numpy_norm_bit_for_bit(shape):
    """Every shape the agreement, loop gaps and checks use (and others, which fall back), with
    lengths from 1e-200 to 1e200, zeros and non-finite entries: the same doubles, NaN where
    numpy gives NaN, and numpy's overflow to inf."""
    rng = np.random.default_rng(3)
    v = rng.standard_normal(shape) * 10.0 ** rng.uniform(-200, 200, shape)
    flat = v.reshape(-1)
    flat[::17], flat[::23], flat[::29], flat[::31] = np.inf, np.nan, 0.0, -np.inf
    with np.errstate(over="ignore", invalid="ignore"):
        want = np.linalg.norm(v, axis=-1)
        got = jet.norms(v)
        assert got.shape == want.shape
        assert np.array_equal(got, want, equal_nan=True)
        w = v[..., ::-1]  # a strided view, as a column slice of a trace is
        assert np.array_equal(jet.norms(w), np.linalg.norm(w, axis=-1), equal_nan=True)
    assert np.array_equal(jet.norms(np.array([[3, 4]])), [5.0])  # integers as numpy takes them
