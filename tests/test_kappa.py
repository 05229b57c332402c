"""κ symmetries, F = ∂U/∂q, tangent = ∂F/∂q, and rigid-motion invariance (docs/theory.md, §2 Elastic
force)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from conftest import RTOL_ROUNDOFF, paper_body

from nrrncf_jax.motion import rotation_about

BEAMS = ["paper", pytest.param("curved-upwind", marks=pytest.mark.slow), "curved-out-of-plane"]


def _deformed(body, seed=0, amp=0.05):
    key = jax.random.PRNGKey(seed)
    return body.q_hat + amp * jax.random.normal(key, body.q_hat.shape)


@pytest.mark.parametrize("beam", BEAMS)
def test_kappa_symmetries(beam):
    k = np.asarray(paper_body(2, beam).groups[0].kappa)
    scale = np.abs(k).max()
    assert scale > 0
    np.testing.assert_allclose(k, k.transpose(0, 2, 1, 3, 4), atol=1e-12 * scale)  # κ^{αβμν} = κ^{βαμν}
    np.testing.assert_allclose(k, k.transpose(0, 1, 2, 4, 3), atol=1e-12 * scale)  # κ^{αβμν} = κ^{αβνμ}
    np.testing.assert_allclose(k, k.transpose(0, 3, 4, 1, 2), atol=1e-12 * scale)  # κ^{αβμν} = κ^{μναβ}


@pytest.mark.parametrize("beam", BEAMS)
def test_force_is_gradient_of_energy(beam):
    body = paper_body(2, beam)
    q = _deformed(body)
    F = body.elastic_force(q)
    F_ad = jax.grad(body.strain_energy)(q)
    np.testing.assert_allclose(F, F_ad, rtol=RTOL_ROUNDOFF, atol=RTOL_ROUNDOFF * np.abs(F).max())


@pytest.mark.parametrize("beam", BEAMS)
def test_tangent_is_jacobian_of_force(beam):
    body = paper_body(2, beam)
    q = _deformed(body, seed=1)
    K = body.stiffness_matrix(q)
    K_ad = jax.jacfwd(lambda x: body.elastic_force(x.reshape(-1, 3)).reshape(-1))(q.reshape(-1))
    np.testing.assert_allclose(K, K_ad, rtol=1e-9, atol=1e-10 * np.abs(K).max())


@pytest.mark.parametrize("beam", BEAMS)
def test_rigid_motion_gives_zero_force_and_energy(beam):
    body = paper_body(2, beam)
    F_scale = np.abs(body.elastic_force(_deformed(body))).max()
    A = rotation_about(jnp.array([0.3, -0.5, 0.8]) / jnp.linalg.norm(jnp.array([0.3, -0.5, 0.8])), 1.234)
    shift = jnp.array([1.5, -2.0, 0.7])
    q = body.q_hat @ A.T + jnp.where(body.is_position[:, None], shift, 0.0)
    assert abs(float(body.strain_energy(q))) < 1e-12 * F_scale
    assert float(jnp.abs(body.elastic_force(q)).max()) < 1e-11 * F_scale
    assert float(jnp.abs(body.elastic_force(body.q_hat)).max()) == 0.0


@pytest.mark.parametrize("beam", BEAMS)
def test_elastic_force_has_no_resultant_moment(beam):
    body = paper_body(2, beam)
    q = _deformed(body, seed=3)
    F = body.elastic_force(q)
    moment = jnp.sum(jnp.cross(q, F), axis=0)
    assert float(jnp.abs(moment).max()) < 1e-10 * float(jnp.abs(F).max())


def test_inertia_integrals_match_closed_form():
    body = paper_body(4)
    from nrrncf_jax.scenarios import beam_preset

    p = beam_preset("paper")
    mass = p.rho * np.pi * (p.r_outer**2 - p.r_inner**2) * p.length
    np.testing.assert_allclose(float(body.mass), mass, rtol=1e-12)
    # ϱ_α ⊗ e summed over position vectors gives m; Σ ϱ_α q̂_α is m × centroid (L/2, 0, 0).
    c = jnp.einsum("a,ai->i", body.varrho(), body.q_hat) / body.mass
    np.testing.assert_allclose(c, [p.length / 2, 0.0, 0.0], atol=1e-12)
    M = body.mass_matrix()
    np.testing.assert_allclose(M, M.T, atol=1e-14 * float(jnp.abs(M).max()))
    assert float(jnp.linalg.eigvalsh(M)[0]) > 0
