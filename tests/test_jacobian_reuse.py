"""The iteration matrix kept across steps (``Newton(reuse=True)``) and the fixed-step mode.

Fixed steps: the kept and the fresh matrix solve the same discrete equations, each step to
Newton's tolerance, so the runs differ by what Newton leaves, not by an integration error. Adaptive
steps: both runs follow the same error control along different step sequences, so they agree to
the tolerance's order. No test times anything (``benchmarks/investigations/jacobian_reuse.py`` does)."""

import jax.numpy as jnp
import numpy as np
import pytest
from conftest import paper_body

from nrrncf_jax import (
    AdaptiveStepSize,
    ConstantStepSize,
    GeneralizedAlpha,
    Newton,
    RotatingFrameModel,
    SpinUp,
    simulate,
)
from nrrncf_jax.bodies.rigid import slender_rod
from nrrncf_jax.integrate import GeneralizedAlphaIndex3
from nrrncf_jax.multibody import Marker, Mechanism, hinge

TS = np.linspace(0.0, 3.0, 31)
RTOL, ATOL, NEWTON_TOL = 1e-4, 1e-6, 1e-3


def _tip(t, q, v):
    return q.reshape(-1, 3)[-6]  # the tip node's position (6 nodal vectors a node)


def _spin_model():
    """The paper's beam on 2 full-order elements spun up to 3 rad/s in 6 s (Eq. 43)."""
    return RotatingFrameModel(paper_body(2), SpinUp(3.0, 6.0))


def _double_pendulum():
    """Two rigid rods of 1 m hinged end to end about Z, released at 60° under gravity."""
    c, s = np.cos(np.pi / 3), np.sin(np.pi / 3)
    a, b = (0.0, 0.0, 0.0), (s, -c, 0.0)
    tip = (2 * s, -2 * c, 0.0)
    rods = [slender_rod(1.0, 1.0, a, b), slender_rod(0.5, 1.0, b, tip)]
    joints = [hinge(None, Marker(0, a), (0.0, 0.0, 1.0)), hinge(Marker(0, b), Marker(1, b), (0.0, 0.0, 1.0))]
    mech = Mechanism(rods, joints, gravity=(0.0, -9.81, 0.0))
    return mech, mech.nodal_vectors


def _newton_bound(n_steps, y):
    """How far two fixed-step runs whose Newton stops at ``NEWTON_TOL`` of the step tolerance may
    differ: each step's solution by up to twice that (both runs' remainders), and the scheme
    carries an earlier step's difference on without growth (stable, and dissipative for ρ∞ < 1),
    so at most the sum over the steps."""
    return 2 * n_steps * NEWTON_TOL * (ATOL + RTOL * float(np.abs(np.asarray(y)).max()))


def test_fixed_steps_with_a_held_matrix_solve_the_same_equations():
    model = _spin_model()
    runs = {reuse: simulate(model, GeneralizedAlpha(0.9), ConstantStepSize(0.02, rtol=RTOL, atol=ATOL), TS,
                            observe=_tip, newton=Newton(NEWTON_TOL, kind="modified", reuse=reuse))
            for reuse in (False, True)}
    fresh, held = runs[False], runs[True]
    n = int(fresh.num_steps)
    assert int(fresh.num_factorizations) == n + int(fresh.num_rejected)
    # some steps solve on a held matrix, and the step sequence is the fresh run's (a solve that
    # fails on a held matrix is solved again on a fresh one inside its step)
    assert int(held.num_factorizations) < n, (int(held.num_factorizations), n)
    assert (int(held.num_steps), int(held.num_rejected)) == (n, int(fresh.num_rejected))
    np.testing.assert_array_less(np.abs(np.asarray(held.ys) - np.asarray(fresh.ys)).max(),
                                 _newton_bound(n, fresh.ys))


def test_adaptive_steps_with_a_kept_matrix_reach_the_same_motion():
    """Against a run at 1/100 of the tolerance (the reference), both runs' errors are of the
    tolerance's order; the kept matrix changes the step sequence, not the accuracy the error
    control delivers: its error at most twice the fresh run's, plus one step's tolerance for
    where a different step sequence lands."""
    model = _spin_model()

    def run(rtol, reuse):
        return simulate(model, GeneralizedAlpha(0.9), AdaptiveStepSize(rtol, ATOL), TS, observe=_tip,
                        newton=Newton(NEWTON_TOL, reuse=reuse))

    ref, fresh, kept = run(RTOL / 100, False), run(RTOL, False), run(RTOL, True)
    y = np.asarray(ref.ys)
    e_fresh, e_kept = (np.abs(np.asarray(s.ys) - y).max() for s in (fresh, kept))
    one_step = ATOL + RTOL * np.abs(y).max()
    assert e_kept <= 2 * e_fresh + one_step, (e_kept, e_fresh, one_step)
    assert int(kept.num_factorizations) < int(kept.num_steps) + int(kept.num_rejected)


@pytest.mark.slow
def test_index3_fixed_steps_with_a_held_matrix_solve_the_same_equations():
    """The index-3 step keeps the bodies' factors and takes the joints' Jacobian at the step's
    end from the velocity projection: the same discrete equations as factoring every step."""
    mech, vectors = _double_pendulum()
    ts = np.linspace(0.0, 1.0, 21)

    def observe(t, z, v):
        return vectors(z)[1][-1]  # the second rod's last nodal vector

    runs = {reuse: simulate(mech, GeneralizedAlphaIndex3(0.9), ConstantStepSize(2e-3, rtol=RTOL, atol=ATOL), ts,
                            observe=observe, newton=Newton(NEWTON_TOL, reuse=reuse))
            for reuse in (False, True)}
    fresh, held = runs[False], runs[True]
    n = int(fresh.num_steps)
    assert int(fresh.num_factorizations) == n + int(fresh.num_rejected)
    assert int(held.num_factorizations) < n, (int(held.num_factorizations), n)
    np.testing.assert_array_less(np.abs(np.asarray(held.ys) - np.asarray(fresh.ys)).max(),
                                 _newton_bound(n, fresh.ys))


def test_full_newton_counts_a_factorisation_an_iteration():
    sol = simulate(_spin_model(), GeneralizedAlpha(0.9), ConstantStepSize(0.1), jnp.asarray(TS[:6]),
                   observe=_tip, newton=Newton(kind="full"))
    assert int(sol.num_factorizations) == int(sol.num_newton)


def test_bad_reuse_settings_are_refused():
    with pytest.raises(ValueError, match="modified Newton"):
        Newton(reuse=True, kind="full")
    with pytest.raises(ValueError, match="reuse_band"):
        Newton(reuse=True, reuse_band=1.5)
    with pytest.raises(ValueError, match="reuse_rate"):
        Newton(reuse=True, reuse_rate=0.0)
    with pytest.raises(ValueError, match="forward mode"):
        simulate(_spin_model(), GeneralizedAlpha(0.9), ConstantStepSize(0.1), TS[:3], observe=_tip,
                 newton=Newton(reuse=True), adjoint="reverse")
