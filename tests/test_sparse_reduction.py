"""The offline stage of large bodies: vibration modes by sparse shift-invert Lanczos and modal
derivatives from one sparse factorisation, against the dense routes on a body just above
``linalg.DENSE_MAX_DOFS`` (where ``"auto"`` switches to them).

Tolerances come from each result's own residual, not from what passes:

- an eigenvalue: for a mass-normalised φ with residual r = Kφ − λMφ, the pencil has an
  eigenvalue within ‖r‖_{M⁻¹} = √(rᵀM⁻¹r) of λ (Kato's bound for a symmetric definite pencil), so
  the dense and sparse eigenvalues agree to the sum of their two bounds (they are well separated
  here, so both bound the same eigenvalue);
- a modal derivative θ = −K⁻¹b: both solvers are backward stable, ‖Kθ + b‖ ≤ c ε ‖K‖‖θ‖; the
  difference of the two solutions is bounded by ‖K⁻¹‖ times the sum of their residuals.
"""

import numpy as np
import pytest
import scipy.sparse.linalg as spla
from conftest import EPS, paper_body

from nrrncf_jax import RotatingFrameModel, Stationary
from nrrncf_jax.linalg import DENSE_MAX_DOFS, assemble_sparse
from nrrncf_jax.reduction import modal_derivatives, vibration_modes
from nrrncf_jax.reduction.modes import _element_blocks

# The tests share the 1026-DOF body (``large``): one worker builds it once.
pytestmark = pytest.mark.xdist_group("sparse_large")


@pytest.fixture(scope="module")
def large():
    body = paper_body(56)  # 57 nodes x 18 = 1026 DOFs, 1008 free
    free = np.asarray(RotatingFrameModel(body, Stationary()).free_mask())
    assert free.sum() > DENSE_MAX_DOFS
    Kp, Mp = _element_blocks(body, body.q_hat, None)
    K = assemble_sparse([(np.asarray(G), np.asarray(d)) for G, d in Kp], body.n_dof)
    M = assemble_sparse([(np.asarray(G), np.asarray(d)) for G, d in Mp], body.n_dof)
    idx = np.flatnonzero(free)
    return body, free, K[idx][:, idx].tocsc(), M[idx][:, idx].tocsc(), idx


def _eigen_bound(K, M, phi, lam):
    """‖Kφ − λMφ‖_{M⁻¹} for each column (Kato's bound on the distance to an eigenvalue)."""
    R = K @ phi - (M @ phi) * lam
    MinvR = spla.splu(M).solve(R)
    return np.sqrt(np.einsum("ik,ik->k", R, MinvR))


def test_sparse_modes_equal_dense(large):
    body, free, K, M, idx = large
    k = 6
    sparse = vibration_modes(body, free, k)  # "auto": sparse above DENSE_MAX_DOFS
    dense = vibration_modes(body, free, k, solver="dense")
    lam_s, lam_d = np.asarray(sparse.omega) ** 2, np.asarray(dense.omega) ** 2
    phi_s, phi_d = np.asarray(sparse.phi)[idx], np.asarray(dense.phi)[idx]
    np.testing.assert_allclose(phi_s.T @ (M @ phi_s), np.eye(k), atol=1e-10)  # mass-normalised
    bound = _eigen_bound(K, M, phi_s, lam_s) + _eigen_bound(K, M, phi_d, lam_d)
    assert np.all(np.abs(lam_s - lam_d) <= bound + 4 * EPS * lam_d)
    # Distinct eigenvalues are separated by far more than the bounds, so both approximate the
    # same one (the y/z bending pairs of the tube are double eigenvalues: one cluster each).
    gaps = np.diff(lam_s)
    assert np.all((gaps > 10 * (bound[1:] + bound[:-1])) | (gaps < 1e-8 * lam_s[1:]))
    # The same shapes up to sign (the pairs of equal frequency, bending in y and z, may mix).
    C = phi_s.T @ (M @ phi_d)  # orthogonal when both span the same eigenspaces
    assert np.allclose(np.sort(np.linalg.svd(C, compute_uv=False)), 1.0, atol=1e-6)


def test_sparse_modal_derivatives_equal_dense(large):
    body, free, K, M, idx = large
    phi = vibration_modes(body, free, 3).phi
    pairs = [(0, 0), (0, 2), (1, 1)]
    th_s = np.asarray(modal_derivatives(body, free, phi, pairs).theta)[idx]
    th_d = np.asarray(modal_derivatives(body, free, phi, pairs, solver="dense").theta)[idx]
    # Each solves K θ = −b: the residual of one against the other's right-hand side, K θ_d, is
    # small (backward error c ε ‖K‖‖θ‖ with c ~ the solver's growth), and the difference is
    # bounded by ‖K⁻¹‖ ‖K(θ_s − θ_d)‖.
    normK = spla.norm(K, 1)
    r = K @ (th_s - th_d)
    lu = spla.splu(K)
    inv_norm = spla.onenormest(spla.LinearOperator(K.shape, matvec=lu.solve, rmatvec=lambda x: lu.solve(x, "T")))
    for c in range(len(pairs)):
        tn = np.abs(th_d[:, c]).sum()
        assert np.abs(r[:, c]).sum() <= 1e3 * EPS * normK * tn
        assert np.abs(th_s[:, c] - th_d[:, c]).sum() <= inv_norm * 1e3 * EPS * normK * tn
        assert tn > 0.0


def test_sparse_route_needs_k(large):
    body, free, *_ = large
    with pytest.raises(ValueError, match="number of modes"):
        vibration_modes(body, free)
    with pytest.raises(ValueError, match="solver"):
        vibration_modes(body, free, 3, solver="iterative")
