"""The studies' one L-BFGS driver (``studies.optimize``): the Armijo line search past failed trial
points, convergence on closed-form problems, and its stopping rules."""

import jax.numpy as jnp
import numpy as np
import pytest

from nrrncf_jax.integrate.simulate import SimulationError
from nrrncf_jax.studies.optimize import armijo_backtracking, lbfgs


def _quadratic(u):
    return float(np.sum((u - 1.0) ** 2)), 2.0 * (u - 1.0), None


def test_line_search_backtracks_past_failed_trials():
    """A trial point whose simulation stops early, or whose loss is not finite, shortens the
    L-BFGS step instead of ending the optimisation; no decrease at all gives None."""

    def evaluate(u):  # fails beyond u = 1.5, has no finite loss in (1.25, 1.5]
        if u[0] > 1.5:
            raise SimulationError("simulation stopped at t = 3 s")
        if u[0] > 1.25:
            raise FloatingPointError("non-finite loss")
        return _quadratic(u)

    u = np.zeros(1)
    value, grad, _ = _quadratic(u)
    step = np.array([4.0])  # far too long: alpha = 1 and 0.5 fail, 0.25 (u = 1) is the minimum
    (u_try, v_try, _, _), tries = armijo_backtracking(evaluate, u, value, step, float(grad @ step))
    assert tries == 3 and u_try[0] == 1.0 and v_try == 0.0

    found, tries = armijo_backtracking(evaluate, u, value, -step, float(grad @ -step), max_tries=5)
    assert found is None and tries == 5  # an ascent direction never passes Armijo's test

    nan = armijo_backtracking(lambda u: (np.nan, u, None), u, value, step, float(grad @ step), max_tries=3)
    assert nan == (None, 3)  # a NaN loss returned (not raised) is no decrease either


def _rosenbrock(x):
    a, b = float(x[0]), float(x[1])
    f = (1 - a) ** 2 + 100 * (b - a * a) ** 2
    g = jnp.array([-2 * (1 - a) - 400 * a * (b - a * a), 200 * (b - a * a)])
    return f, g, ("aux", f)


@pytest.mark.slow
def test_lbfgs_converges_on_rosenbrock_and_reports_each_step():
    x0 = jnp.array([-1.2, 1.0])
    f0, g0, aux0 = _rosenbrock(x0)
    steps = []
    run = lbfgs(_rosenbrock, x0, f0, g0, aux0, max_iterations=200, gtol=1e-8,
                on_step=lambda i, x, f, g, aux: steps.append((i, f, aux)))
    assert run.stop == "gtol"
    np.testing.assert_allclose(run.x, [1.0, 1.0], atol=1e-7)
    assert run.value < 1e-14 and run.iterations < 100
    assert [i for i, _, _ in steps] == list(range(1, run.iterations + 1))
    assert all(later < earlier for (_, earlier, _), (_, later, _) in zip(steps, steps[1:]))  # monotone
    assert run.aux == ("aux", run.value) and steps[-1][2] == run.aux  # the accepted point's aux comes back
    assert run.evaluations >= run.iterations


def test_lbfgs_any_shape_and_stopping_rules():
    """x of any shape (here 2 x 3); ftol ends the run after an iteration that gains too little, a
    line search with no decrease ends it, and max_iterations bounds it."""
    rng = np.random.default_rng(0)
    B = rng.normal(size=(6, 6))
    A = B @ B.T + 6 * np.eye(6)
    b = rng.normal(size=6)

    v_min = np.linalg.solve(A, b)

    def quad(x):  # minimum 1 at v_min (ftol is relative to a positive loss)
        d = np.asarray(x).reshape(-1) - v_min
        return float(1.0 + 0.5 * d @ A @ d), jnp.asarray((A @ d).reshape(2, 3)), None

    x0 = jnp.zeros((2, 3))
    run = lbfgs(quad, x0, *quad(x0), max_iterations=100, gtol=1e-10)
    assert run.stop == "gtol" and run.x.shape == (2, 3)
    np.testing.assert_allclose(np.asarray(run.x).reshape(-1), v_min, rtol=1e-9)

    loose = lbfgs(quad, x0, *quad(x0), max_iterations=100, ftol=1e-2)
    assert loose.stop == "ftol" and loose.iterations < run.iterations

    short = lbfgs(quad, x0, *quad(x0), max_iterations=2)
    assert short.stop == "iterations" and short.iterations == 2

    def noisy(x):  # the loss resolved only to 1e-3: the line search runs out of trials near the optimum
        f, g, _ = quad(x)
        return round(f, 3), g, None

    flat = lbfgs(noisy, x0, *noisy(x0), max_iterations=100, max_tries=4)
    assert flat.stop == "line search" and flat.iterations < 100


def test_lbfgs_steps_around_a_region_where_the_simulation_fails():
    """f = √(1 + (u − 1)²), flat far from its minimum at u = 1, so the secant steps overshoot, into
    u > 2 where the "simulation" fails: those trials are halved back and the run converges."""
    failed = []

    def evaluate(u):
        d = float(u[0]) - 1.0
        if d > 1.0:
            failed.append(float(u[0]))
            raise SimulationError("simulation stopped at t = 3 s")
        return float(np.sqrt(1 + d * d)), jnp.array([d / np.sqrt(1 + d * d)]), None

    u0 = jnp.array([-6.0])
    run = lbfgs(evaluate, u0, *evaluate(u0), max_iterations=50, gtol=1e-12)
    assert run.stop == "gtol" and float(run.x[0]) == pytest.approx(1.0, abs=1e-12)
    assert len(failed) >= 5 and run.evaluations == run.iterations + len(failed)
