"""The eigensolver's round-off in close modes (``reduction.purify_close_modes``): a mode that
the loads leave alone carries no load after purification, the rotation stays inside the solver's
own uncertainty ε λ_max / |ω_i² − ω_j²|, and a physical load survives.

Tolerances: the purified load and the modes' orthonormality are products of a few unit-size
rotations, exact to a small multiple of eps; the MMI weight of an unloaded mode is the square of
such a load (relative), so 1e-12 on its amplitude is round-off with a wide margin, where the
unpurified eigensolver leaves the mixing of close modes (1e-8 and more)."""

import numpy as np
import pytest
from conftest import EPS, paper_body

from nrrncf_jax import RotatingFrameModel, SpinUp
from nrrncf_jax.reduction import purify_close_modes, vibration_modes
from nrrncf_jax.reduction.pipeline import modal_interaction

W2 = np.array([1.0, 1.01, 5.0, 9.0, 20.0])  # the five lowest eigenvalues; mode 0 and 1 are 1 % apart
LAMBDA_MAX = 1e10  # the discretisation's largest: eps λ_max / gap ≈ 2e-4 for the close pair


def _rotated(phi, i, j, angle):
    c, s = np.cos(angle), np.sin(angle)
    phi = phi.copy()
    phi[:, [i, j]] = phi[:, [i, j]] @ np.array([[c, s], [-s, c]])
    return phi


def _case(load_on_mode_0):
    """Exact modes (M = I, K diagonal) of a problem whose loads F reach mode 0 by
    ``load_on_mode_0`` only, then mixed as an eigensolver may mix them: by 1e-6 between the
    close pair and 1e-9 towards mode 2 (both inside the solver's uncertainty)."""
    rng = np.random.default_rng(0)
    F = rng.standard_normal((6, 40))
    F[0] *= load_on_mode_0
    exact = np.eye(6)[:, :5]
    mixed = _rotated(_rotated(exact, 0, 1, 1e-6), 0, 2, 1e-9)
    return F, exact, mixed


def test_an_unloaded_close_mode_is_purified_to_round_off():
    F, exact, mixed = _case(0.0)
    before = np.linalg.norm(mixed[:, 0] @ F) / np.linalg.norm(mixed.T @ F, axis=1).max()
    assert before > 1e-8  # the mixing shows in the load: the test can fail
    phi = np.asarray(purify_close_modes(mixed, np.sqrt(W2), mixed.T @ F, LAMBDA_MAX))
    loads = phi.T @ F
    assert np.linalg.norm(loads[0]) <= 100 * EPS * np.linalg.norm(loads, axis=1).max()
    np.testing.assert_allclose(phi.T @ phi, np.eye(5), atol=100 * EPS)
    # the purified modes are the exact ones (up to sign), to round-off
    np.testing.assert_allclose(np.abs(phi.T @ exact), np.eye(5), atol=100 * EPS)


def test_a_physical_load_survives_and_the_rotation_stays_inside_the_solver_uncertainty():
    F, exact, mixed = _case(1e-2)  # mode 0 truly loaded: 1e-2, far above the 2e-4 uncertainty
    phi = np.asarray(purify_close_modes(mixed, np.sqrt(W2), mixed.T @ F, LAMBDA_MAX))
    loads = phi.T @ F
    assert np.linalg.norm(loads[0]) >= 0.5 * np.linalg.norm(F[0])
    moved = phi.T @ mixed  # the rotation that was applied
    theta = EPS * LAMBDA_MAX / np.abs(W2[:, None] - W2[None, :] + np.eye(5))
    off = np.abs(moved - np.diag(np.diag(moved)))
    assert np.all(off <= theta * (1 + 1e-6) + 100 * EPS)


def test_purify_input_shapes_must_agree():
    _, _, mixed = _case(0.0)
    with pytest.raises(ValueError, match="one row per mode"):
        purify_close_modes(mixed, np.sqrt(W2), np.zeros((4, 3)), LAMBDA_MAX)


def test_the_curved_beams_unloaded_modes_take_no_part_in_the_mmi():
    """The curved in-plane beam spun about its plane's normal: its out-of-plane modes (0, 2, 4)
    sit 1-2 % below in-plane ones, and nothing loads them. Their MMI amplitude is round-off with
    the purification, and the in-plane modes' amplitudes do not move beyond the rotation's size."""
    full = RotatingFrameModel(paper_body(2, "curved-upwind"), SpinUp(2.0, 1.47))
    ts = np.linspace(0.0, 2.0, 21)
    modes = vibration_modes(full.body, full.free_mask(), 6)
    assert float(modes.lambda_max) > 1e3 * float(modes.omega[-1]) ** 2
    _, W, _, _ = modal_interaction(full, ts, 6, modes=modes)
    amp = np.sqrt(np.diag(W) / np.diag(W).max())
    assert np.all(amp[[0, 2, 4]] <= 1e-12)
    unpurified = type(modes)(omega=modes.omega, phi=modes.phi)  # lambda_max None: no purification
    _, W0, _, _ = modal_interaction(full, ts, 6, modes=unpurified)
    amp0 = np.sqrt(np.diag(W0) / np.diag(W0).max())
    assert amp0[0] > 1e-10  # the eigensolver's own mixing, which the purification removes
    np.testing.assert_allclose(amp[[1, 3, 5]], amp0[[1, 3, 5]], rtol=1e-6)


def test_sparse_modes_bound_the_largest_eigenvalue():
    """The sparse solver's ``lambda_max`` is the element-by-element bound: at least the dense
    solver's exact largest eigenvalue."""
    full = RotatingFrameModel(paper_body(2, "curved-upwind"), SpinUp(2.0, 1.47))
    dense = vibration_modes(full.body, full.free_mask(), 4, solver="dense")
    sparse = vibration_modes(full.body, full.free_mask(), 4, solver="sparse")
    assert float(sparse.lambda_max) >= float(dense.lambda_max) * (1 - 1e-9)
    assert float(sparse.lambda_max) <= 100 * float(dense.lambda_max)
