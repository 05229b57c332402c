"""A 20,000-DOF body that is not a chain: a 3-D space-frame boom, a square box truss of 1,666 bays
(20,004 DOFs, 29,994 bars in two element groups), clamped at its root layer.

Each bay has four longerons and an X of diagonals in each of its four faces; each layer (square
section, side a = bay length h) four battens and an X of two section diagonals. The section bars
are STIFF times stiffer than the bay bars, so every section is rigid in its plane (to O(1/STIFF)).
Then the boom's axial modes are those of a chain of rigid layers, known in closed form
(``axial_chain``): by symmetry (X-bracing everywhere) the four corners of a layer move alike and
the modes decouple from bending and torsion. This checks, at full size:

- the sparse solve of an iteration matrix K + c M (``assemble_and_factor(solver="sparse")``)
  by its backward error, and the static axial tip load, exact for the rigid-layer chain;
- on a 996-DOF copy of the same construction: sparse = dense within the round-off of the matrix's
  condition number;
- the first axial modes from ``sparse_modes`` (shift-invert) against the chain's exact discrete
  closed form and against the continuous fixed-free rod with a tip mass, O(h²) apart.

The lowest modes of the boom, its bending pairs, are not checked at this size: bending is a
fourth-order problem whose stiffness EA a² comes from differences of the longerons' axial
stiffness, so its eigenvalues are of order N⁻⁴ of K's entries and float64 round-off shows at the
1e-2 level at 1,666 bays (measured: the two equal bending frequencies of the square section split
by 8e-3 at 1,666 bays, 4e-4 at 160, 1e-5 at 40). The axial modes are second order (condition N²).

The body is two ``element_group``s (bay bars, section bars) on one set of nodes; a group of more
than 64 elements computes its integrals in vmapped chunks (about a second for 30,000 bars).
``test_vmapped_build_equals_truss_body`` checks that path against the per-element one.
"""

import functools

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.sparse.linalg as spla
from conftest import EPS, roundoff_tol
from scipy.optimize import brentq

from nrrncf_jax.bodies.body import Body, element_group, truss_body
from nrrncf_jax.elements import Bar
from nrrncf_jax.linalg import assemble_and_factor, assemble_sparse, sparse_modes
from nrrncf_jax.linalg import sparse as sparse_module

E, RHO, AREA = 70e9, 2700.0, 1e-4  # aluminium bars of 1 cm²
H = 0.05  # bay length = section side [m]
STIFF = 1e6  # section bars' stiffness over the bay bars'
N_FULL, N_SMALL = 1666, 82  # bays: 20,004 and 996 DOFs
C_M = 4e8  # the mass weight of the iteration matrix: a Newmark step (β = 1/4) of 0.1 ms, 1/(β Δt²)


def box_truss_mesh(n_bays: int):
    """Nodes (4 a layer: node 4i + 2j + k at (i h, (j − ½) h, (k − ½) h)) and the connectivity of the
    bay bars (longerons, face diagonals) and of the section bars (battens, section diagonals)."""
    i = np.arange(n_bays + 1)[:, None, None]
    j, k = np.meshgrid([0, 1], [0, 1], indexing="ij")
    nodes = np.stack(np.broadcast_arrays(i * H, (j - 0.5) * H, (k - 0.5) * H), axis=-1).reshape(-1, 3)
    nid = lambda i, j, k: 4 * i + 2 * j + k  # noqa: E731
    lay, bay = np.arange(n_bays + 1), np.arange(n_bays)
    section = [(nid(lay, 0, 0), nid(lay, 1, 0)), (nid(lay, 0, 1), nid(lay, 1, 1)), (nid(lay, 0, 0), nid(lay, 0, 1)),
               (nid(lay, 1, 0), nid(lay, 1, 1)), (nid(lay, 0, 0), nid(lay, 1, 1)), (nid(lay, 0, 1), nid(lay, 1, 0))]
    bays = [(nid(bay, j, k), nid(bay + 1, j, k)) for j in (0, 1) for k in (0, 1)]  # longerons
    bays += [(nid(bay, s, k), nid(bay + 1, 1 - s, k)) for s in (0, 1) for k in (0, 1)]  # X in the faces k = 0, 1
    bays += [(nid(bay, j, s), nid(bay + 1, j, 1 - s)) for s in (0, 1) for j in (0, 1)]  # X in the faces j = 0, 1
    conn = lambda pairs: np.stack([np.stack(p, axis=1) for p in pairs], axis=1).reshape(-1, 2)  # noqa: E731
    return nodes, conn(bays), conn(section)


def bay_bar():
    return Bar(E, RHO, AREA)


@functools.cache
def box_truss(n_bays: int, stiff: float = STIFF) -> Body:
    """The boom as a body of two bar groups (bay bars, section bars ``stiff`` times stiffer)."""
    nodes, bays, section = box_truss_mesh(n_bays)
    groups = [element_group(bar, nodes, conn)
              for conn, bar in ((bays, bay_bar()), (section, Bar(stiff * E, RHO, AREA)))]
    return Body(nodes, groups, is_position=np.ones(len(nodes), bool))


def free_dofs(body: Body) -> np.ndarray:
    return np.arange(body.n_dof) >= 12  # the root layer's four nodes clamped


@eqx.filter_jit
def _tangent_and_mass_parts(body: Body):
    return [(Kt, dofs, g.M_e) for g, (Kt, dofs) in zip(body.groups, body.tangent_parts(body.q_hat))]


def parts(body: Body, c_K: float, c_M: float):
    """Element blocks of c_K K + c_M M ⊗ I3 at the reference, group by group (as the full-order
    models assemble their iteration matrix), NumPy."""
    out = []
    for Kt, dofs, M_e in _tangent_and_mass_parts(body):
        n_el, ne = M_e.shape[:2]
        M3 = np.einsum("eab,ij->eaibj", np.asarray(M_e), np.eye(3)).reshape(n_el, 3 * ne, 3 * ne)
        out.append((c_K * np.asarray(Kt) + c_M * M3, np.asarray(dofs)))
    return out


def factor_solve(body, G_parts, b, solver="sparse"):
    """``assemble_and_factor(...).solve(b)`` in one jit, the element DOFs closed over (concrete)."""
    dofs = [d for _, d in G_parts]
    free = jnp.asarray(free_dofs(body))
    f = jax.jit(lambda Gs, b: assemble_and_factor(list(zip(Gs, dofs)), free, solver=solver).solve(b))
    return np.asarray(f([jnp.asarray(G) for G, _ in G_parts], jnp.asarray(b)))


# ---- the rigid-layer chain in closed form -------------------------------------------------------------

def axial_chain():
    """The boom's axial motion with rigid layers: bay stiffness k (each bar EA/ℓ·cos²φ along x: four
    longerons, eight face diagonals of length d = √2 h), the bays' consistent mass on their two layers
    [[m_b/3, m_b/6], [m_b/6, m_b/3]] and each layer's section mass m_s (moving as one)."""
    d = np.sqrt(2.0) * H
    k = 4 * E * AREA / H + 8 * E * AREA / d * (H / d) ** 2
    m_b = RHO * AREA * (4 * H + 8 * d)
    m_s = RHO * AREA * (4 * H + 2 * d)
    return k, m_b, m_s


def axial_discrete(n_bays: int, n_modes: int):
    """The chain's exact frequencies: u_i = sin(iθ) solves every interior row for
    ω² = k(2 − 2cos θ)/(2m_b/3 + m_s + (m_b/3) cos θ); the free end's row
    k(u_N − u_{N−1}) = ω² ((m_b/3 + m_s) u_N + (m_b/6) u_{N−1}) picks θ (near the rod's λ_n/N)."""
    k, m_b, m_s = axial_chain()
    N = n_bays
    w2 = lambda t: k * (2 - 2 * np.cos(t)) / (2 * m_b / 3 + m_s + m_b / 3 * np.cos(t))  # noqa: E731
    tip = lambda t: (k * (np.sin(N * t) - np.sin((N - 1) * t))  # noqa: E731
                     - w2(t) * ((m_b / 3 + m_s) * np.sin(N * t) + m_b / 6 * np.sin((N - 1) * t)))
    lam, _ = axial_rod(n_bays, n_modes)
    theta = np.array([brentq(tip, 0.99 * l / N, 1.01 * l / N, xtol=1e-16, rtol=4 * EPS) for l in lam])
    return np.sqrt(w2(theta)), theta


def axial_rod(n_bays: int, n_modes: int):
    """The continuous fixed-free rod of EA = k h and m' = (m_b + m_s)/h with the tip mass m_s/2 (the
    layers' masses at x_1 … x_N are m_s/h spread over [0, L] plus m_s/2 at x = L, to O(h²) by the
    trapezoidal rule): u = sin(λx/L) with cos λ = μ λ sin λ, μ = (m_s/2)/(m' L); ω = (λ/L)√(EA/m').
    Returns (λ_n, ω_n)."""
    k, m_b, m_s = axial_chain()
    L = n_bays * H
    m_line = (m_b + m_s) / H
    mu = m_s / 2 / (m_line * L)
    lam = np.array([brentq(lambda x: np.cos(x) - mu * x * np.sin(x), (n - 1) * np.pi + 1e-9, (n - 0.5) * np.pi,
                           xtol=1e-15, rtol=4 * EPS) for n in range(1, n_modes + 1)])
    return lam, lam / L * np.sqrt(k * H / m_line)


def axial_modes(body: Body, n_modes: int):
    """The first ``n_modes`` axial modes of the boom by ``sparse_modes``: shift-invert about each
    closed-form frequency (axial modes lie among many bending and torsion modes), the one mode of
    the 6 nearest that moves along x (≥ 99 % of its Σφ² in x components)."""
    G_K, G_M = parts(body, 1.0, 0.0), parts(body, 0.0, 1.0)
    K, M = assemble_sparse(G_K, body.n_dof), assemble_sparse(G_M, body.n_dof)
    free = free_dofs(body)
    guess, _ = axial_discrete(len(body.q_hat) // 4 - 1, n_modes)
    omega, phi = [], []
    for w in guess:
        om, ph = sparse_modes(K, M, 6, sigma=(0.999 * w) ** 2, free=free)
        share = (ph.reshape(-1, 3, ph.shape[1])[:, 0] ** 2).sum(axis=0) / (ph**2).sum(axis=0)
        axial = np.flatnonzero(share > 0.99)
        assert axial.size == 1, (om / w, share)
        omega.append(om[axial[0]])
        phi.append(ph[:, axial[0]])
    return np.array(omega), np.stack(phi, axis=1), M


# ---- tests --------------------------------------------------------------------------------------------

def test_vmapped_build_equals_truss_body():
    """Six bays (72 bay bars, more than one chunk): the vmapped integrals of a large group are those
    of the per-element path (``element_group`` on the first 64 bars)."""
    nodes6, bays6, _ = box_truss_mesh(6)  # 72 bay bars
    ref = truss_body(nodes6, bays6[:64], bay_bar()).groups[0]
    got = element_group(bay_bar(), nodes6, bays6)
    got = eqx.tree_at(lambda g: (g.kappa, g.M_e, g.varrho_e, g.m_e), got,
                      (got.kappa[:64], got.M_e[:64], got.varrho_e[:64], got.m_e[:64]))
    for name in ("kappa", "M_e", "varrho_e", "m_e"):
        np.testing.assert_allclose(getattr(got, name), getattr(ref, name), rtol=1e-14, err_msg=name)


def test_small_copy_sparse_equals_dense():
    """996 DOFs (82 bays), the iteration matrix K + c M: SuperLU and dense LU agree with each other
    and with NumPy within 100 κ₁(A_ff) ε ‖x‖ on the free DOFs (``test_linalg.roundoff_tol``: each
    solver is backward stable, so within about κ ε of the exact solution; A_ff the free block, as the
    clamped DOFs' identity rows are decoupled and solved exactly). κ₁(A_ff) = 5e7 (the stiff
    sections), so the bound is 1.1e-6 relative to max|x|; measured 7e-10 (sparse, threshold
    pivoting) and 3e-11 (dense) against NumPy."""
    body = box_truss(N_SMALL)
    assert body.n_dof == 996
    free = free_dofs(body)
    G = parts(body, 1.0, C_M)
    A = assemble_sparse(G, body.n_dof, free).toarray()
    b = np.where(free, np.random.default_rng(0).normal(size=body.n_dof), 0.0) * E * AREA / H
    x_np = np.linalg.solve(A, b)
    x_dense, x_sparse = (factor_solve(body, G, b, s) for s in ("dense", "sparse"))
    scale = np.abs(x_np).max()
    tol = roundoff_tol(A[free][:, free]) * scale
    assert tol < 1e-5 * scale  # a bound that still says something
    for x in (x_dense, x_sparse):
        np.testing.assert_allclose(x, x_np, rtol=0, atol=tol)
        assert np.all(x[~free] == 0)
    np.testing.assert_allclose(x_sparse, x_dense, rtol=0, atol=tol)


@pytest.mark.slow
def test_20000_dof_sparse_solve():
    """20,004 DOFs, 29,994 bars (no dense matrix is formed). The sparse solve of K + c M:

    - componentwise backward error (Oettli-Prager) ω = max_i |Ax − b|_i / (|A||x| + |b|)_i ≤
      10 n_eff ε: LU with |ΔA| ≤ γ_{n_eff} |L||U| (Higham Thm 9.3, n_eff the longest inner product:
      at most the longest row of SciPy's L + U with the solver's own ordering options, 36 here) and
      a factor 10 for growth under threshold pivoting (0.1). Measured 4e-16 against 8e-14. (The
      normwise backward error says nothing here: the stiff sections' rows are 1e6 times the others,
      and it is 5e-24.)
    - the static axial tip load F (F/4 on each tip node): u_x = F x/(k h) at every layer, exact for
      the rigid-layer chain; the sections' compliance changes it by O(1/STIFF). Bound 1e-6 relative
      (measured 1.7e-7), and 1e-6 of the tip displacement across (measured 7e-8: X-bracing is
      symmetric, nothing bends or twists)."""
    body = box_truss(N_FULL)
    assert body.n_dof == 20_004 and body.n_elements == 29_994 and not body.chain
    n, free = body.n_dof, free_dofs(body)
    G = parts(body, 1.0, C_M)
    b = np.where(free, np.random.default_rng(1).normal(size=n), 0.0) * E * AREA / H
    x = factor_solve(body, G, b)
    A = assemble_sparse(G, n, free)
    assert np.all(x[~free] == 0)  # identity rows, zero right-hand side
    r = np.abs(A @ x - b)[free]
    omega = (r / (abs(A) @ np.abs(x) + np.abs(b))[free]).max()
    lu = spla.splu(A, permc_spec=sparse_module.PERMC_SPEC, diag_pivot_thresh=sparse_module.DIAG_PIVOT_THRESH,
                   options=dict(SymmetricMode=True))
    n_eff = int(np.diff((abs(lu.L) + abs(lu.U)).tocsr().indptr).max())
    assert omega <= 10 * n_eff * EPS, (omega, n_eff)

    F = 1e3
    f = np.zeros((n // 3, 3))
    f[-4:, 0] = F / 4
    K = parts(body, 1.0, 0.0)
    u = factor_solve(body, K, f.reshape(-1)).reshape(-1, 4, 3)
    k, _, _ = axial_chain()
    x_layer = H * np.arange(N_FULL + 1)
    exact = np.broadcast_to((F * x_layer / (k * H))[:, None], (N_FULL + 1, 4))
    np.testing.assert_allclose(u[:, :, 0], exact, rtol=1e-6)
    assert np.abs(u[:, :, 1:]).max() < 1e-6 * exact.max()


@pytest.mark.slow
def test_20000_dof_axial_modes_against_closed_form():
    """The first two axial modes of the 20,004-DOF boom by shift-invert ``sparse_modes``:

    - against the rigid-layer chain's exact discrete frequencies (``axial_discrete``): 1e-6
      relative, the O(1/STIFF) compliance of the sections (measured −8.6e-8 at 1,666 bays and
      −8.5e-8 at 82: not round-off, which would grow with the axial chain's N² condition;
      ``test_section_compliance_is_order_one_over_stiff``);
    - against the continuous rod with a tip mass (``axial_rod``): the chain's dispersion lies
      between the lumped-mass (−θ²/24) and the consistent-mass (+θ²/24) rod's, θ_n = λ_n/N, so
      |ω/ω_rod − 1| ≤ θ²/24 + 1e-6 (θ₁²/24 = 3.7e-8 at 1,666 bays; measured −7e-8, 4e-8);
    - the discretisation error is O(h²): the discrete-to-rod difference at 82 bays (5.8e-6,
      5.2e-5) times (82/1666)² predicts the one at 1,666 bays within 5 % (measured 0.9 %, 1.3 %:
      the θ⁴ terms);
    - the modes are mass-normalised and zero on the clamped root."""
    n_modes = 2
    omega, phi, M = axial_modes(box_truss(N_FULL), n_modes)
    disc, theta = axial_discrete(N_FULL, n_modes)
    _, rod = axial_rod(N_FULL, n_modes)
    np.testing.assert_allclose(omega, disc, rtol=1e-6)
    assert np.all(np.abs(omega / rod - 1) <= theta**2 / 24 + 1e-6), (omega / rod - 1, theta**2 / 24)
    np.testing.assert_allclose(phi.T @ (M @ phi), np.eye(n_modes), atol=1e-9)
    assert np.all(phi[:12] == 0)

    small, _, _ = axial_modes(box_truss(N_SMALL), n_modes)
    disc_s, theta_s = axial_discrete(N_SMALL, n_modes)
    _, rod_s = axial_rod(N_SMALL, n_modes)
    np.testing.assert_allclose(small, disc_s, rtol=1e-6)
    err_s, err = disc_s / rod_s - 1, disc / rod - 1
    assert np.all(np.abs(err_s) <= theta_s**2 / 24) and np.all(np.abs(err) <= theta**2 / 24)
    np.testing.assert_allclose(err, err_s * (N_SMALL / N_FULL) ** 2, rtol=0.05)


@pytest.mark.slow
def test_section_compliance_is_order_one_over_stiff():
    """The 1e-6 tolerance of the chain comparisons is the sections' O(1/STIFF) compliance: on the
    82-bay copy the first axial frequency's difference from the rigid-layer chain scales as
    1/STIFF (measured −0.0847/STIFF at 1e4 and at 1e6, the same to 4e-5); 1 % allowed for
    round-off and O(1/STIFF²)."""
    dev = {}
    for stiff, body in ((1e4, box_truss(N_SMALL, 1e4)), (STIFF, box_truss(N_SMALL))):
        omega, _, _ = axial_modes(body, 1)
        dev[stiff] = omega[0] / axial_discrete(N_SMALL, 1)[0][0] - 1
    assert -1 / STIFF < dev[STIFF] < 0
    assert dev[1e4] * 1e4 == pytest.approx(dev[STIFF] * STIFF, rel=0.01)
