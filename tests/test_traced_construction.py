"""Every model can be built inside ``jax.jit``, ``jax.grad`` and ``jax.vmap`` from a traced
parameter (a spin rate, Young's modulus, gravity): what a model needs to know before tracing (its
connectivity, the iteration matrix's solver and sparsity pattern, its joints' structure) is static
data, never computed from array values at construction."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from conftest import RTOL_ROUNDOFF

import nrrncf_jax as nr
from nrrncf_jax.bodies import beam_body, straight_reference
from nrrncf_jax.elements import Material, TubeSection
from nrrncf_jax.multibody import FloatingFrameSystem, MultibodySystem
from nrrncf_jax.reduction import reduce_rotating_model
from nrrncf_jax.scenarios.pendulum import PendulumBasis, PendulumSpec, build_pendulum, build_reduced_pendulum

TS = jnp.linspace(0.0, 0.2, 3)


@pytest.fixture(scope="module")
def body():
    return nr.beam_preset("paper").body(3)


def _residual_norm(model):
    """|r(t, q0, v0, 0)|² at a perturbed initial state: a scalar that touches every term."""
    q0, v0 = model.initial_state(0.0)
    q = q0 + 1e-3 * jnp.sin(jnp.arange(q0.shape[0]))
    r = model.residual(0.5, q, v0, jnp.zeros_like(q0))
    return jnp.sum(r**2)


def _tip(model):
    tip = nr.tip_index(model.body) if hasattr(model, "body") else None
    return lambda t, q, v: model.displacements(t, q)[tip]


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["rncf", "ancf"])
def test_full_order_model_built_in_jit_and_vmap(body, kind):
    """The issue's example: a spin-up simulated from a traced spin rate, under jit and vmap; the
    traced runs equal the eager ones to round-off."""
    cls = nr.RotatingFrameModel if kind == "rncf" else nr.InertialFrameModel

    def run(w):
        m = cls(body, nr.SpinUp(w, 2.0))
        return nr.simulate(m, nr.GeneralizedAlpha(0.9), nr.AdaptiveStepSize(), TS, observe=lambda t, q, v: q).ys

    eager = run(3.0)
    np.testing.assert_allclose(jax.jit(run)(3.0), eager, rtol=RTOL_ROUNDOFF, atol=RTOL_ROUNDOFF)
    batch = jax.vmap(run)(jnp.array([3.0, 4.0]))
    np.testing.assert_allclose(batch[0], eager, rtol=RTOL_ROUNDOFF, atol=RTOL_ROUNDOFF)


@pytest.mark.slow
def test_body_built_from_traced_youngs_modulus():
    """A body (element integrals) and its model built from a traced E: jit, grad (against a
    central difference; the residual is smooth in E) and vmap."""

    def f(E):
        b = beam_body(Material(E, 2700.0, 0.3), TubeSection(0.02, 0.005), straight_reference(8.0, 2))
        return _residual_norm(nr.RotatingFrameModel(b, nr.SpinUp(4.0, 15.0)))

    E = 70e9
    np.testing.assert_allclose(jax.jit(f)(E), f(E), rtol=RTOL_ROUNDOFF)
    g = jax.grad(f)(E)
    h = 1e-4 * E
    fd = (f(E + h) - f(E - h)) / (2 * h)
    # Central difference: truncation O(h²) relative, round-off ~ eps |f| / h.
    np.testing.assert_allclose(g, fd, rtol=1e-6)
    np.testing.assert_allclose(jax.vmap(f)(jnp.array([E, 2 * E]))[0], f(E), rtol=RTOL_ROUNDOFF)


def test_reduced_model_built_in_jit_grad_vmap(body):
    """The Galerkin projection onto a fixed basis, built inside the transformations from a
    traced spin rate."""
    full = nr.RotatingFrameModel(body, nr.SpinUp(4.0, 15.0))
    free = np.asarray(full.free_mask())
    Psi = np.zeros((body.n_dof, 4))
    Psi[np.flatnonzero(free)[-4:], np.arange(4)] = 1.0

    def f(w):
        return _residual_norm(reduce_rotating_model(nr.RotatingFrameModel(body, nr.SpinUp(w, 15.0)), Psi))

    np.testing.assert_allclose(jax.jit(f)(4.0), f(4.0), rtol=RTOL_ROUNDOFF)
    assert np.isfinite(jax.grad(f)(4.0))
    np.testing.assert_allclose(jax.vmap(f)(jnp.array([4.0, 5.0]))[0], f(4.0), rtol=RTOL_ROUNDOFF)


@pytest.fixture(scope="module")
def pendulum_parts():
    spec = PendulumSpec(elements=2)
    ancf = build_pendulum(spec)
    floating, _ = build_reduced_pendulum(spec, PendulumBasis(2, pairs=()))
    return ancf, floating


@pytest.mark.slow
@pytest.mark.parametrize("which", ["ancf", "floating"])
def test_multibody_systems_built_in_jit_grad_vmap(pendulum_parts, which):
    """Jointed systems (inertial-frame ANCF bodies; reduced bodies in floating frames) built from
    their bodies and joints with a traced gravity: the residual and the consistent accelerations
    under jit, grad and vmap."""
    template = pendulum_parts[0] if which == "ancf" else pendulum_parts[1]
    cls = MultibodySystem if which == "ancf" else FloatingFrameSystem

    def f(g):
        s = cls(template.bodies, template.joints, gravity=jnp.stack([0.0, -g, 0.0]))
        z0, v0 = s.initial_state(0.0)
        a, lam = s.consistent_accelerations(0.0, z0, v0)
        return jnp.sum(a**2) + jnp.sum(lam**2)

    eager = f(9.81)
    np.testing.assert_allclose(jax.jit(f)(9.81), eager, rtol=1e-9)
    # a and λ are linear in g from rest: f is quadratic in g, f'(g) = 2 f(g) / g.
    np.testing.assert_allclose(jax.grad(f)(9.81), 2 * eager / 9.81, rtol=1e-9)
    np.testing.assert_allclose(jax.vmap(f)(jnp.array([9.81, 2 * 9.81])), [eager, 4 * eager], rtol=1e-9)
