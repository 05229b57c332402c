"""The 3-D bar element and bodies of several element groups: κ in closed form, rigid motion,
axial frequencies, the von Mises truss's snap-through path, and a beam braced by a bar."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from conftest import EPS, RTOL_ROUNDOFF, paper_body

from nrrncf_jax import Loads, RotatingFrameModel, Stationary, linalg, static_equilibrium
from nrrncf_jax.bodies.body import Body, element_group, truss_body
from nrrncf_jax.elements import Bar
from nrrncf_jax.integrate import ConstantStepSize, GeneralizedAlpha, Newton

E, RHO, AREA = 70e9, 2700.0, 1e-4


def test_bar_energy_force_and_tangent_in_closed_form():
    """U = ½ EA L ε² with the Green-Lagrange strain ε = (l² − L²)/(2L²); F = ∂U/∂q and
    K = ∂F/∂q (Eqs. 9-11) against automatic differentiation; κ's symmetries."""
    rng = np.random.default_rng(1)
    nodes = rng.normal(size=(4, 3))
    conn = np.array([[0, 1], [1, 2], [2, 3], [3, 0], [0, 2]])
    body = truss_body(nodes, conn, Bar(E, RHO, AREA))
    q = jnp.asarray(nodes + 0.1 * rng.normal(size=nodes.shape))
    L = np.linalg.norm(nodes[conn[:, 1]] - nodes[conn[:, 0]], axis=1)
    l2 = np.sum((np.asarray(q)[conn[:, 1]] - np.asarray(q)[conn[:, 0]]) ** 2, axis=1)
    U = np.sum(0.5 * E * AREA * L * ((l2 - L**2) / (2 * L**2)) ** 2)
    assert float(body.strain_energy(q)) == pytest.approx(U, rel=1e-12)
    np.testing.assert_allclose(body.elastic_force(q), jax.grad(body.strain_energy)(q), rtol=RTOL_ROUNDOFF,
                               atol=1e-12 * E * AREA)
    K_ad = jax.jacfwd(lambda x: body.elastic_force(x.reshape(-1, 3)).reshape(-1))(q.reshape(-1))
    np.testing.assert_allclose(body.stiffness_matrix(q), K_ad, rtol=RTOL_ROUNDOFF, atol=1e-12 * E * AREA)
    k = np.asarray(body.groups[0].kappa)
    for perm in ((1, 0, 2, 3), (0, 1, 3, 2), (2, 3, 0, 1)):
        np.testing.assert_array_equal(k, k.transpose((0,) + tuple(p + 1 for p in perm)))
    assert float(body.mass) == pytest.approx(RHO * AREA * L.sum(), rel=1e-14)


def test_rigid_motion_gives_zero_force():
    rng = np.random.default_rng(2)
    nodes = rng.normal(size=(5, 3))
    body = truss_body(nodes, [[0, 1], [1, 2], [2, 3], [3, 4], [4, 0], [1, 3]], Bar(E, RHO, AREA))
    A = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    q = jnp.asarray(nodes @ A.T + rng.normal(size=3))
    # Each bar's force is EA ε r' with ε the difference of two O(1) squared lengths: round-off EA·ε_mach.
    assert float(jnp.abs(body.elastic_force(q)).max()) < 100 * EPS * E * AREA


def test_axial_frequencies_of_a_fixed_free_rod():
    """n linear bars with consistent mass: the discrete eigenvalues are known in closed form,
    ω² = (6c²/h²)(1 − cos θ)/(2 + cos θ) with θ_k = (2k − 1)π/(2n), c² = E/ρ; they converge to
    the rod's ω_k = (2k − 1)πc/(2L) from above as h² (the first within (θ²/24) of it)."""
    n, L = 20, 2.0
    x = np.linspace(0.0, L, n + 1)
    nodes = np.stack([x, np.zeros_like(x), np.zeros_like(x)], axis=1)
    body = truss_body(nodes, np.stack([np.arange(n), np.arange(1, n + 1)], axis=1), Bar(E, RHO, AREA))
    K = np.asarray(body.stiffness_matrix(body.q_hat))[3::3, 3::3]  # axial DOFs of nodes 1..n
    M = np.asarray(body.mass_matrix())[1:, 1:]
    w2 = np.sort(np.linalg.eigvals(np.linalg.solve(M, K)).real)
    c2, h = E / RHO, L / n
    theta = (2 * np.arange(1, n + 1) - 1) * np.pi / (2 * n)
    exact_discrete = np.sort(6 * c2 / h**2 * (1 - np.cos(theta)) / (2 + np.cos(theta)))
    # Eigenvalues of a matrix pencil are good to ~n ε |λ_max|; relative to λ_k that is the bound below.
    np.testing.assert_allclose(w2, exact_discrete, rtol=0, atol=10 * n * EPS * exact_discrete.max())
    w1 = np.sqrt(w2[0])
    w1_rod = np.pi * np.sqrt(c2) / (2 * L)
    assert 0 < w1 / w1_rod - 1 < (np.pi / (2 * n)) ** 2 / 24 * 1.01


def _von_mises(a=1.0, h=0.1, n_bars=4):
    """A shallow spatial von Mises truss: n_bars bars from base nodes on a circle of radius a to
    an apex at height h (y up); the base nodes are pinned."""
    phi = 2 * np.pi * np.arange(n_bars) / n_bars
    base = np.stack([a * np.cos(phi), np.zeros(n_bars), a * np.sin(phi)], axis=1)
    nodes = np.vstack([base, [0.0, h, 0.0]])
    conn = np.stack([np.arange(n_bars), np.full(n_bars, n_bars)], axis=1)
    return truss_body(nodes, conn, Bar(E, RHO, AREA)), a, h, n_bars


def _P_closed_form(w, a, h, n):
    """The load P (down) that holds the apex at the deflection w: P = n EA u (h² − u²)/(2L³), u = h − w."""
    L = np.hypot(a, h)
    u = h - w
    return n * E * AREA * u * (h**2 - u**2) / (2 * L**3)


def test_von_mises_truss_snap_through_path():
    """The whole equilibrium path through the snap-through, w ∈ [0, 2.2h]: the internal force
    at the apex against the closed form (rising to the limit load at w = h(1 − 1/√3), falling
    through zero at w = h, negative on the inverted branch, zero again at the mirror image
    w = 2h), and the equilibrium that static
    Newton finds under load control below the limit load against the cubic's first root."""
    body, a, h, n = _von_mises()
    apex = n
    w_lim = h * (1 - 1 / np.sqrt(3))
    ws = np.sort(np.append(np.linspace(0.0, 2.2 * h, 23), w_lim))
    q = np.repeat(np.asarray(body.q_hat)[None], len(ws), axis=0)
    q[:, apex, 1] -= ws
    Fy = np.asarray(jax.vmap(body.elastic_force)(jnp.asarray(q)))[:, apex]
    P = _P_closed_form(ws, a, h, n)
    np.testing.assert_allclose(-Fy[:, 1], P, rtol=0, atol=1e-9 * np.abs(P).max())
    np.testing.assert_allclose(Fy[:, [0, 2]], 0.0, atol=1e-9 * np.abs(P).max())
    # The limit load P_lim = n EA h³/(3√3 L³), the element's largest force on the rising branch.
    P_lim = n * E * AREA * h**3 / (3 * np.sqrt(3) * np.hypot(a, h) ** 3)
    pulled = -Fy[:, 1]
    assert pulled[ws == w_lim][0] == pytest.approx(P_lim, rel=1e-9) and pulled[ws == w_lim][0] == pulled[ws <= h].max()

    load = 0.8 * P_lim
    model = RotatingFrameModel(body, Stationary(), loads=Loads(point_vectors=[apex], point_forces=[[0.0, -load, 0.0]]),
                               clamped=np.arange(n))
    qs = np.asarray(static_equilibrium(model, load_steps=4)).reshape(-1, 3)
    roots = np.roots([-1.0, 0.0, h**2, -load * 2 * np.hypot(a, h) ** 3 / (n * E * AREA)])  # in u = h − w
    u = max(r.real for r in roots if abs(r.imag) < 1e-12 and 0 < r.real <= h)
    assert qs[apex, 1] == pytest.approx(u, rel=1e-8)
    np.testing.assert_allclose(qs[apex, [0, 2]], 0.0, atol=1e-10 * h)


def test_bad_truss_input():
    with pytest.raises(ValueError, match="zero length"):
        truss_body([[0, 0, 0], [0, 0, 0], [1, 0, 0]], [[0, 1], [1, 2]], Bar(E, RHO, AREA))
    with pytest.raises(ValueError, match="refers to node"):
        truss_body([[0, 0, 0], [1, 0, 0]], [[0, 2]], Bar(E, RHO, AREA))
    with pytest.raises(ValueError, match="belong to no element"):
        truss_body([[0, 0, 0], [1, 0, 0], [2, 0, 0]], [[0, 1]], Bar(E, RHO, AREA))
    with pytest.raises(ValueError, match="E"):
        Bar(-1.0, RHO, AREA)
    body, *_ = _von_mises()
    with pytest.raises(ValueError, match="clamped"):
        RotatingFrameModel(body, Stationary())


def braced_cantilever(n_el=4, k_ratio=0.5):
    """The paper's beam as a cantilever along x whose tip is tied in y to a fixed point by a bar
    of axial stiffness k = k_ratio · 3EI/L³ (two element groups on one body)."""
    beam = paper_body(n_el)
    L = float(beam.q_hat[-6, 0])
    tip = beam.n_vectors - beam.vectors_per_node
    EI = 70e9 * np.pi / 4 * (0.02**4 - 0.005724**4)
    k = k_ratio * 3 * EI / L**3
    l_bar = 2.0
    anchor = np.asarray(beam.q_hat[tip]) + np.array([0.0, l_bar, 0.0])
    q_hat = np.vstack([np.asarray(beam.q_hat), anchor])
    bar = Bar(E, RHO, k * l_bar / E)
    groups = list(beam.groups) + [element_group(bar, q_hat, [[tip, beam.n_vectors]])]
    body = Body(q_hat, groups, is_position=np.append(np.asarray(beam.is_position), True), vectors_per_node=1)
    return body, tip, L, EI, k


@pytest.mark.slow
def test_beam_braced_by_a_bar_deflects_as_two_springs_in_parallel():
    """A tip load P on the cantilever braced by the bar: δ = P/(3EI/L³ + k) (small deflection).
    The beam's own O((δ/L)²) nonlinearity and its shear-free C1 discretisation keep it within 1e-4."""
    body, tip, L, EI, k = braced_cantilever()
    anchor = body.n_vectors - 1
    P = 1e-3 * (3 * EI / L**3 + k) * L * 1e-3  # δ = 1e-6 L: linear
    model = RotatingFrameModel(body, Stationary(), loads=Loads(point_vectors=[tip], point_forces=[[0.0, -P, 0.0]]),
                               clamped=[0, 2, 4, anchor])
    q = np.asarray(static_equilibrium(model, load_steps=1)).reshape(-1, 3)
    delta = float(body.q_hat[tip, 1] - q[tip, 1])
    assert delta == pytest.approx(P / (3 * EI / L**3 + k), rel=1e-4)


def test_sparse_solver_inside_the_integrator_equals_dense():
    """The truss's dynamics under a suddenly applied load, with the iteration matrix factored by
    SuperLU (``solver="sparse"``, pattern built once from the body) and by dense LU: the same apex
    motion to round-off times the run's amplification. Fixed steps (adaptive ones could differ
    where round-off flips a step decision), and Newton converged far below the bound (newton_tol
    1e-8 of the step's tolerance scale, 1e-6 m + 1e-4 |q|: ~1e-12 m, which a Newton count flipped
    by round-off moves the apex by at most)."""
    from nrrncf_jax import simulate

    body, a, h, n = _von_mises()
    loads = Loads(point_vectors=[n], point_forces=[[0.0, -0.5 * n * E * AREA * h**3 / np.hypot(a, h) ** 3, 0.0]])
    runs = {}
    for solver in ("dense", "sparse"):
        m = RotatingFrameModel(body, Stationary(), loads=loads, clamped=np.arange(n), solver=solver)
        assert isinstance(m.solver, {"dense": linalg.Dense, "sparse": linalg.Sparse}[solver])
        runs[solver] = simulate(m, GeneralizedAlpha(0.9), ConstantStepSize(5e-5, rtol=1e-4, atol=1e-6),
                                jnp.linspace(0.0, 2e-3, 5), newton=Newton(1e-8),
                                observe=lambda t, q, v: q.reshape(-1, 3)[n, 1])
        assert int(runs[solver].num_rejected) == 0  # Newton converged in every step
    np.testing.assert_allclose(runs["sparse"].ys, runs["dense"].ys, rtol=0, atol=1e-10 * h)
    assert float(runs["dense"].ys[-1]) < h  # it moved
    with pytest.raises(ValueError, match="solver"):
        RotatingFrameModel(body, Stationary(), clamped=np.arange(n), solver="cholesky")
