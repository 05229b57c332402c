"""Large static deflection of a cantilever under a dead tip load against the elastica."""

import numpy as np
import pytest
from conftest import paper_body
from scipy.integrate import solve_bvp

from nrrncf_jax import Loads, RotatingFrameModel, SimulationError, Stationary, static_equilibrium
from nrrncf_jax.scenarios import beam_preset


def elastica_tip(L, EI, P):
    """Tip (x, y) of the inextensible cantilever elastica under a downward end load P, from the
    boundary-value problem EI θ'' = −P cos θ, θ(0) = 0, θ'(L) = 0 (scipy, independent of us)."""

    def f(s, y):
        return np.vstack([y[1], -(P / EI) * np.cos(y[0]), np.cos(y[0]), -np.sin(y[0])])

    def bc(ya, yb):
        return np.array([ya[0], yb[1], ya[2], ya[3]])

    s = np.linspace(0, L, 400)
    y0 = np.zeros((4, s.size))
    y0[2] = s
    sol = solve_bvp(f, bc, s, y0, tol=1e-10, max_nodes=100000)
    assert sol.success
    return sol.sol(L)[2], sol.sol(L)[3]


@pytest.mark.slow
@pytest.mark.parametrize("load", [2.0])
def test_tip_deflection_matches_elastica(load):
    p = beam_preset("paper")
    L = p.length
    EI = p.E * np.pi / 4 * (p.r_outer**4 - p.r_inner**4)
    P = load * EI / L**2
    x_ref, y_ref = elastica_tip(L, EI, P)  # a large deflection: y_ref = -0.49 L
    body = paper_body(8)
    tip = body.n_vectors - body.vectors_per_node
    model = RotatingFrameModel(body, Stationary(), loads=Loads(point_vectors=[tip], point_forces=[[0.0, -P, 0.0]]))
    q = np.asarray(static_equilibrium(model, load_steps=8)).reshape(-1, 3)
    # 8 elements: 0.22 % in y and 0.07 % in x measured (mesh and the element's small
    # extensibility, which the inextensible elastica leaves out).
    assert q[tip, 1] == pytest.approx(y_ref, rel=3e-3)
    assert q[tip, 0] == pytest.approx(x_ref, rel=1e-3)


def test_static_newton_failure_is_reported():
    body = paper_body(2)
    tip = body.n_vectors - body.vectors_per_node
    huge = Loads(point_vectors=[tip], point_forces=[[0.0, -1e9, 0.0]])
    with pytest.raises(SimulationError, match="load increment 1/1"):
        static_equilibrium(RotatingFrameModel(body, Stationary(), loads=huge), load_steps=1, max_iter=5)
