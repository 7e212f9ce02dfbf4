"""Observer staircase: orthogonal, in block-Hessenberg form, indices against brute force."""

from __future__ import annotations

import numpy as np
from hypothesis import example, given, settings
from hypothesis import strategies as st

from geomfdi.geometry.staircase import observer_staircase


def _pair(seed):
    rng = np.random.default_rng(seed)
    n, q = int(rng.integers(1, 9)), int(rng.integers(1, 4))
    A = rng.integers(-2, 3, (n, n)).astype(float)
    C = rng.integers(-2, 3, (q, n)).astype(float)
    if q > 1 and rng.random() < 0.3:  # dependent outputs
        C[-1] = C[0]
    if rng.random() < 0.3:  # an unobservable part: a block-triangular A
        r = int(rng.integers(1, n + 1))
        A[:r, r:] = 0.0
        C[:, r:] = 0.0
    return A, C


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**31 - 1))
@example(2**31 - 1)  # C = 0: no staircase block
def test_staircase_form_and_parity_dimensions(seed):
    A, C = _pair(seed)
    n, q = A.shape[0], C.shape[0]
    s = observer_staircase(A, C)
    assert np.allclose(s.Z.T @ s.Z, np.eye(n), atol=1e-12)
    assert np.allclose(s.Z.T @ A @ s.Z, s.A, atol=1e-10)
    assert np.allclose(C @ s.Z, s.C, atol=1e-10)
    edges = np.cumsum([0, *s.blocks])
    first = edges[1] if len(edges) > 1 else 0  # no block: C = 0
    assert np.allclose(s.C[:, first:], 0, atol=1e-10)  # C Z = [C1 0 … 0]
    for j in range(len(s.blocks)):  # block j couples only to blocks ≤ j + 1
        assert np.allclose(
            s.A[edges[j] : edges[j + 1], edges[min(j + 2, len(edges) - 1)] :], 0, atol=1e-10
        )
    assert list(s.blocks) == sorted(s.blocks, reverse=True)
    # brute force: dimension of the degree-ν parity space = (ν + 1) q − rank O_ν
    for nu in range(n + 2):
        O = np.vstack([C @ np.linalg.matrix_power(A, i) for i in range(nu + 1)])
        assert s.parity_dim(nu) == (nu + 1) * q - np.linalg.matrix_rank(O)
    obs = np.vstack([C @ np.linalg.matrix_power(A, i) for i in range(n)])
    assert s.n_observable == np.linalg.matrix_rank(obs)
    assert sum(s.indices) == s.n_observable
    assert s.max_index == (max(s.indices) if s.indices else 0)


def test_single_output_chain_has_one_index():
    n = 6
    A = np.eye(n, k=1)
    C = np.zeros((1, n))
    C[0, 0] = 1.0
    s = observer_staircase(A, C)
    assert s.blocks == [1] * n and s.indices == [n] and s.parity_dim(n - 1) == 0
