"""Every model's iteration matrix S = c_M ∂r/∂a + c_C ∂r/∂v + c_K ∂r/∂q against ``jax.jacfwd``
of its residual (RNCF, ANCF, damped RNCF, reduced with either force evaluation, and a body of two
element groups), and gravity against the cantilever's closed form."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from conftest import paper_body
from test_bar import braced_cantilever

from nrrncf_jax import (
    InertialFrameModel,
    Loads,
    RayleighDamping,
    RotatingFrameModel,
    SpinUp,
    Stationary,
    reduce_rotating_model,
    static_equilibrium,
    vibration_modes,
)

C_M, C_C, C_K = 1.0, 0.03, 4e-4  # a generalized-α step of ~0.05 s


def _models():
    body = paper_body(3)
    motion = SpinUp(4.0, 2.0)
    g = Loads(gravity=[0.0, -9.81, 0.0])
    rncf = RotatingFrameModel(body, motion, loads=g)
    braced, *_ = braced_cantilever(3)
    models = {
        "rncf": rncf,
        "ancf": InertialFrameModel(body, motion, loads=g),
        "rncf-damped": RotatingFrameModel(body, motion, damping=RayleighDamping(0.1, 1e-3)),
        "rncf-two-groups": RotatingFrameModel(braced, motion, clamped=[0, 2, 4, braced.n_vectors - 1]),
    }
    phi = vibration_modes(body, rncf.free_mask(), 4).phi
    for force in ("tensor", "projected"):
        models[f"reduced-{force}"] = reduce_rotating_model(rncf, phi, force=force)
    return models


MODELS = _models()


@eqx.filter_jit
def _jacobians_and_solves(m, t, q, v, a, b):
    """∂r/∂(q, v, a) by ``jax.jacfwd``, the factor's solve of b and of r, and the Newton update."""
    J = [jax.jacfwd(lambda x, k=k: m.residual(t, *[x if i == k else y for i, y in enumerate((q, v, a))]))(z)
         for k, z in enumerate((q, v, a))]
    fac = m.factor_iteration_matrix(t, q, v, C_M, C_C, C_K)
    r = m.residual(t, q, v, a)
    return J, fac.solve(b), fac.solve(r), m.newton_update(t, q, v, a, C_M, C_C, C_K)


SLOW = {"rncf-damped", "reduced-tensor"}  # damping's S: also test_damping; the tensor force: also test_reduction


@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.slow) if n in SLOW else n for n in sorted(MODELS)])
def test_iteration_matrix_matches_autodiff_of_the_residual(name):
    m = MODELS[name]
    rng = np.random.default_rng(0)
    t = 1.0
    q0, _ = m.initial_state(t)
    n = m.n_dof
    scale = 1e-2 if name.startswith("reduced") else 1e-3
    q, v, a = (jnp.asarray(q0 + scale * rng.normal(size=n)), jnp.asarray(rng.normal(size=n)),
               jnp.asarray(rng.normal(size=n)))
    q, v, a = m.constrain(t, q, v, a)
    free = np.asarray(m.free_mask())
    b = np.where(free, rng.normal(size=n), 0.0)
    J, x, x_r, update = _jacobians_and_solves(m, t, q, v, a, jnp.asarray(b))
    S = C_K * np.asarray(J[0]) + C_C * np.asarray(J[1]) + C_M * np.asarray(J[2])
    S = S[np.ix_(free, free)]
    x = np.asarray(x)
    # Residual of the solve, relative to |S||x|: round-off times the condition of S (the stiff
    # cross-section modes make it ~1e8 for the full beam).
    res = np.abs(S @ x[free] - b[free]).max() / (np.abs(S).max() * np.abs(x).max())
    assert res < 1e-9, res
    np.testing.assert_array_equal(x[~free], 0.0)
    np.testing.assert_allclose(update, x_r, rtol=1e-7, atol=1e-9 * float(jnp.abs(x_r).max()))


@pytest.mark.slow
def test_cantilever_under_its_own_weight():
    """Static tip deflection δ = qL⁴/(8EI) with q = ρAg (Euler-Bernoulli), in the rotating frame
    at rest with gravity applied as Q = ϱ g (Eq. 12). At full gravity the paper's beam sags
    ~0.8 m (10 % of L), where the large-deflection terms show at O((δ/L)²); at 1e-3 g the
    response is linear to 1e-7 and the 8-element C1 beam (cubic field, quartic exact
    deflection) is within 1e-3 of the closed form."""
    body = paper_body(8)
    g = 9.81e-3
    model = RotatingFrameModel(body, Stationary(), loads=Loads(gravity=[0.0, -g, 0.0]))
    q = np.asarray(static_equilibrium(model, load_steps=1)).reshape(-1, 3)
    tip = body.n_vectors - body.vectors_per_node
    L, ro, ri = 8.0, 0.02, 0.005724
    A, I = np.pi * (ro**2 - ri**2), np.pi / 4 * (ro**4 - ri**4)
    delta = 2700.0 * A * g * L**4 / (8 * 70e9 * I)
    assert float(body.q_hat[tip, 1] - q[tip, 1]) == pytest.approx(delta, rel=1e-3)
