"""The iteration-matrix solvers (``nrrncf_jax.linalg``): dense, block-tridiagonal and sparse
against each other and NumPy, constrained DOFs, the sparse solver inside ``jit`` and loops, its
derivatives against the dense one's, a 20,000-DOF chain and its modes against the closed form."""

import threading

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.sparse as sp
from conftest import EPS, RTOL_ROUNDOFF, roundoff_tol

from nrrncf_jax.linalg import (
    CACHE_SIZE,
    DENSE_MAX_DOFS,
    BlockTridiagonalLU,
    DenseInverse,
    DenseLU,
    SparseLU,
    SparsityPattern,
    assemble_and_factor,
    assemble_sparse,
    choose_solver,
    dense_augmented,
    factor_block,
    schur_factor,
    sparse_modes,
)

SOLVERS = ("dense", "block_tridiagonal", "sparse")


def chain_parts(nb, m, seed=0, skew=0.3):
    """Random element matrices of a chain (element e on nodes e, e + 1, m DOFs a node): SPD plus
    a skew part, as an iteration matrix with gyroscopic terms."""
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(nb - 1, 2 * m, 2 * m))
    Ge = np.einsum("eij,ekj->eik", X, X) / (2 * m) + 0.1 * np.eye(2 * m) + skew * (X - X.transpose(0, 2, 1)) / 4
    dofs = m * np.arange(nb - 1)[:, None] + np.arange(2 * m)
    return Ge, dofs


def dense_reference(parts, free):
    """NumPy assembly, constrained rows and columns identity."""
    n = free.size
    A = np.zeros((n, n))
    for Ge, dofs in parts:
        np.add.at(A, (dofs[:, :, None], dofs[:, None, :]), Ge)
    f = free.astype(float)
    return A * f[:, None] * f[None, :] + np.diag(1.0 - f)


def solve(parts, free, b, **kwargs):
    """``assemble_and_factor(parts, free, **kwargs).solve(b)`` in one jit-compiled function (one
    compilation instead of dozens op by op), the element DOFs concrete (closed over)."""
    dofs = [d for _, d in parts]
    f = jax.jit(lambda Gs, b: assemble_and_factor(list(zip(Gs, dofs)), jnp.asarray(free), **kwargs).solve(b))
    return np.asarray(f([jnp.asarray(G) for G, _ in parts], jnp.asarray(b)))


def test_solvers_agree_on_a_chain():
    m, nb = 3, 40
    Ge, dofs = chain_parts(nb, m)
    n = m * nb
    free = np.ones(n, bool)
    free[:m] = False  # the clamped first node
    free[n // 2] = False
    b = np.random.default_rng(1).normal(size=n)
    A = dense_reference([(Ge, dofs)], free)
    x_ref = np.linalg.solve(A, b)
    tol = roundoff_tol(A)
    assert tol < 1e-10
    xs = {}
    for solver in SOLVERS:
        # The element DOFs a concrete JAX array closed over by the jit (the other tests: NumPy).
        xs[solver] = solve([(Ge, jnp.asarray(dofs))], free, b, chain_block=m, solver=solver)
        np.testing.assert_allclose(xs[solver], x_ref, rtol=0, atol=tol * np.abs(x_ref).max())
    assert isinstance(assemble_and_factor([(Ge, dofs)], jnp.asarray(free), chain_block=m), BlockTridiagonalLU)
    # Identity rows: the constrained DOFs' increments are their right-hand sides.
    for x in xs.values():
        np.testing.assert_array_equal(x[~free], b[~free])
    # The host-side SciPy assembly is the same matrix.
    np.testing.assert_allclose(assemble_sparse([(Ge, dofs)], n, free).toarray(), A, rtol=0, atol=1e-14)


@pytest.mark.parametrize("sizes", [(5, 7, 4), (6, 6, 6)], ids=["unequal bodies", "equal bodies"])
def test_augmented_factors_solve_the_saddle_point_system_and_its_constraint_rows(sizes):
    """Every form of the constrained iteration matrix (the bodies' LU factors or inverses with the
    joints' Schur complement, their inverses stacked when the bodies are equal, one dense LU)
    solves [[S, Bᵀ], [B, 0]] like a dense solve of the whole matrix, and
    ``solve_constraint_rows(c)`` is ``solve([0; c])`` (the velocity projection's right-hand side)."""
    rng = np.random.default_rng(3)
    m = 6
    blocks = [rng.standard_normal((n, n)) + 3 * n * np.eye(n) for n in sizes]
    n = sum(sizes)
    S = np.zeros((n, n))
    offsets = tuple(int(o) for o in np.concatenate([[0], np.cumsum(sizes)[:-1]]))
    for o, b in zip(offsets, blocks):
        S[o:o + len(b), o:o + len(b)] = b
    B = rng.standard_normal((m, n))
    A = np.block([[S, B.T], [B, np.zeros((m, m))]])
    F, c = rng.standard_normal(n + m), rng.standard_normal(m)
    tol = roundoff_tol(A)
    by_inverse = schur_factor([factor_block(jnp.asarray(b)) for b in blocks], offsets, sizes, jnp.asarray(B))
    assert all(isinstance(f, DenseInverse) for f in by_inverse.bodies)
    assert (by_inverse.stacked is not None) == (len(set(sizes)) == 1)
    forms = (schur_factor([DenseLU.factor(jnp.asarray(b)) for b in blocks], offsets, sizes, jnp.asarray(B)),
             by_inverse, dense_augmented(jnp.asarray(S), jnp.asarray(B)))
    for fac in forms:
        for rhs, got in ((F, fac.solve(jnp.asarray(F))),
                         (np.concatenate([np.zeros(n), c]), fac.solve_constraint_rows(jnp.asarray(c)))):
            want = np.linalg.solve(A, rhs)
            np.testing.assert_allclose(np.asarray(got), want, rtol=0, atol=tol * np.abs(want).max())


@pytest.mark.slow
def test_pivoted_lu_forms_agree_and_need_no_permutation_loop():
    """``DenseLU`` keeps (U, L⁻¹P): its CPU form (one getrf of [A | I]) and the other platforms'
    (the square LU and its permutation) agree with NumPy on a matrix whose first pivot comes from
    another row, and so do their derivatives (jvp against dx = A⁻¹(db − dA x)). On a CPU the
    compiled factor-and-solve holds no loop: ``lu_solve``'s pivots-to-permutation loop of n
    scatter steps, which it replaced, was most of the reduced pendulum's step."""
    from nrrncf_jax.linalg.dense import _pivoted_lu_augmented, _pivoted_lu_square

    rng = np.random.default_rng(3)
    A = rng.normal(size=(9, 9))
    A[0, 0] = 1e-4
    b, dA, db = rng.normal(size=9), rng.normal(size=(9, 9)), rng.normal(size=9)
    x = np.linalg.solve(A, b)
    dx = np.linalg.solve(A, db - dA @ x)
    for form in (_pivoted_lu_augmented, _pivoted_lu_square):
        def solve_with(A, b, form=form):
            lu, C = form(A)
            return DenseLU(lu=lu, inv_lower=C).solve(b)

        x1, dx1 = jax.jvp(solve_with, (jnp.asarray(A), jnp.asarray(b)), (jnp.asarray(dA), jnp.asarray(db)))
        np.testing.assert_allclose(x1, x, rtol=1e-11, atol=1e-12)
        np.testing.assert_allclose(dx1, dx, rtol=1e-9, atol=1e-11)
    np.testing.assert_allclose(DenseLU.factor(A).solve(np.stack([b, db], axis=1)),
                               np.linalg.solve(A, np.stack([b, db], axis=1)), rtol=1e-11, atol=1e-12)
    # Above EXPLICIT_INVERSE_MAX: the permutation kept, the same solution and derivative.
    from nrrncf_jax.linalg.dense import EXPLICIT_INVERSE_MAX

    n = EXPLICIT_INVERSE_MAX + 3
    A2 = rng.normal(size=(n, n))
    A2[0, 0] = 1e-4
    b2, dA2, db2 = rng.normal(size=n), rng.normal(size=(n, n)), rng.normal(size=n)
    x2 = np.linalg.solve(A2, b2)
    dx2 = np.linalg.solve(A2, db2 - dA2 @ x2)
    assert DenseLU.factor(A2).perm is not None and DenseLU.factor(A).perm is None
    x3, dx3 = jax.jvp(lambda A, b: DenseLU.factor(A).solve(b), (jnp.asarray(A2), jnp.asarray(b2)),
                      (jnp.asarray(dA2), jnp.asarray(db2)))
    cond = np.linalg.cond(A2)
    np.testing.assert_allclose(x3, x2, rtol=0, atol=1e-13 * cond * np.abs(x2).max())
    np.testing.assert_allclose(dx3, dx2, rtol=0, atol=1e-13 * cond**2 * np.abs(dx2).max())
    if jax.default_backend() == "cpu":
        text = jax.jit(lambda A, b: DenseLU.factor(A).solve(b)).lower(A, b).compile().as_text()
        assert " while(" not in text and "while." not in text


def test_several_groups_dense_against_sparse():
    """Two element groups of different sizes on one matrix (a chain and long springs between
    distant nodes, so the pattern is no chain): dense and sparse against NumPy."""
    m, nb = 3, 30
    Ge, dofs = chain_parts(nb, m)
    n = m * nb
    rng = np.random.default_rng(2)
    pairs = np.array([[0, 17], [4, 29], [8, 22], [3, 11]])
    springs = (m * pairs[:, :, None] + np.arange(m)).reshape(-1, 2 * m)  # (4, 6): node pairs
    k = rng.uniform(0.5, 2.0, size=len(pairs))
    Gs = k[:, None, None] * np.kron(np.array([[1.0, -1.0], [-1.0, 1.0]]), np.eye(m))[None]
    one = (np.eye(1)[None] * 0.7).repeat(5, 0), rng.choice(n, size=(5, 1), replace=False)  # 1-DOF "masses"
    parts = [(Ge, dofs), (Gs, springs), one]
    free = np.ones(n, bool)
    free[:m] = False
    A = dense_reference(parts, free)
    b = rng.normal(size=n)
    x_ref = np.linalg.solve(A, b)
    for solver in ("dense", "sparse"):
        x = solve(parts, free, b, chain_block=m, solver=solver)
        np.testing.assert_allclose(x, x_ref, rtol=0, atol=roundoff_tol(A) * np.abs(x_ref).max())
    assert choose_solver(parts, n, chain_block=m) == "dense"  # several groups: no chain; small
    np.testing.assert_allclose(assemble_sparse(parts, n, free).toarray(), A, rtol=0, atol=1e-14)


def test_sparse_in_jit_loops_and_vmap():
    """SparseLU made and solved inside jit and a while_loop body (factor once, solve twice, as
    modified Newton), with traced element DOFs through a prebuilt pattern; under vmap as a loop,
    with more members than cached factorisations (the dropped ones are factored again)."""
    m, nb = 3, 20
    Ge, dofs = chain_parts(nb, m)
    n = m * nb
    free = jnp.asarray(np.arange(n) >= m)
    b = jnp.asarray(np.random.default_rng(3).normal(size=n))

    def loop(solver):
        def body(c):
            i, x = c
            fac = assemble_and_factor([(Ge * (1.0 + 0.1 * i), dofs)], free, solver=solver)
            return i + 1, x + fac.solve(b - 0.5 * x) + fac.solve(x)

        return jax.jit(lambda: jax.lax.while_loop(lambda c: c[0] < 4, body, (0, jnp.zeros(n)))[1])()

    np.testing.assert_allclose(loop("sparse"), loop("dense"), rtol=1e-11, atol=1e-11)

    pattern = SparsityPattern.from_dofs(n, [dofs])
    assert SparsityPattern.from_dofs(n, [dofs.copy()]) is pattern  # built once per mesh
    traced = jax.jit(lambda G, d: assemble_and_factor([(G, d)], free, solver="sparse", pattern=pattern).solve(b))
    np.testing.assert_allclose(traced(Ge, dofs), solve([(Ge, dofs)], free, b, solver="dense"), rtol=1e-11, atol=1e-11)
    with pytest.raises(ValueError, match="concrete element_dofs"):
        jax.jit(lambda d: assemble_and_factor([(Ge, d)], free, solver="sparse").solve(b))(dofs)
    with pytest.raises(ValueError, match="other element DOFs"):
        assemble_and_factor([(Ge, dofs[::-1])], free, solver="sparse", pattern=pattern)

    scales = 1.0 + 0.05 * jnp.arange(CACHE_SIZE + 3)
    batched = {s: jax.jit(jax.vmap(lambda c: assemble_and_factor([(c * Ge, dofs)], free, solver=s).solve(b)))(scales)
               for s in ("dense", "sparse")}
    np.testing.assert_allclose(batched["sparse"], batched["dense"], rtol=1e-11, atol=1e-11)
    # A singular matrix: NaNs (as the dense LU's infinities), not an exception in the callback.
    assert np.all(np.isnan(solve([(0.0 * Ge, dofs)], free, b, solver="sparse")))


def test_sparse_derivatives_match_dense():
    """jvp and grad of a loss through two solves with one factorisation, with respect to the
    element matrices and the right-hand side: sparse (custom_linear_solve) against dense."""
    m, nb = 3, 12
    Ge, dofs = chain_parts(nb, m, seed=4)
    n = m * nb
    free = jnp.asarray(np.arange(n) >= m)
    rng = np.random.default_rng(5)
    b, w = jnp.asarray(rng.normal(size=n)), jnp.asarray(rng.normal(size=n))
    dG, db = jnp.asarray(rng.normal(size=Ge.shape)), jnp.asarray(rng.normal(size=n))

    def loss(solver):
        def f(G, b):
            fac = assemble_and_factor([(G, dofs)], free, solver=solver)
            x = fac.solve(b)
            return jnp.dot(w, x) + jnp.sum(fac.solve(x * x) ** 2)

        return f

    out = {s: jax.jit(lambda *a, s=s: jax.jvp(loss(s), a[:2], a[2:]))(jnp.asarray(Ge), b, dG, db)
           for s in ("dense", "sparse")}
    np.testing.assert_allclose(out["sparse"], out["dense"], rtol=RTOL_ROUNDOFF)
    grads = {s: jax.jit(jax.grad(loss(s), argnums=(0, 1)))(jnp.asarray(Ge), b) for s in ("dense", "sparse")}
    for g_sparse, g_dense in zip(grads["sparse"], grads["dense"]):
        np.testing.assert_allclose(g_sparse, g_dense, rtol=RTOL_ROUNDOFF, atol=1e-12 * np.abs(g_dense).max())
    # The matrix derivative on the pattern: entries of constrained rows/columns get none.
    assert float(jnp.abs(grads["sparse"][0][0, :m]).max()) == 0.0


def rod_chain(n_el, L, EA, rhoA, tension):
    """A 3-D chain of two-node linear elements along x (3 DOFs a node): axial stiffness EA and a
    taut string's transverse stiffness ``tension``, consistent mass; K and M element blocks."""
    h = L / n_el
    k1 = np.array([[1.0, -1.0], [-1.0, 1.0]]) / h
    Pa = np.diag([1.0, 0.0, 0.0])
    Ke = np.kron(k1, EA * Pa + tension * (np.eye(3) - Pa))
    Me = np.kron(rhoA * h / 6 * np.array([[2.0, 1.0], [1.0, 2.0]]), np.eye(3))
    dofs = 3 * np.arange(n_el)[:, None] + np.arange(6)
    return np.broadcast_to(Ke, (n_el, 6, 6)), np.broadcast_to(Me, (n_el, 6, 6)), dofs


@pytest.mark.slow
def test_20000_dof_chain_sparse_solve_and_modes():
    """A fixed-free 3-D rod of 6,667 linear elements (20,004 DOFs): the sparse solve of an
    iteration matrix K + c M equals the dense (and block-tridiagonal) one on a 1,002-DOF copy
    and the block-tridiagonal one at full size, and the tip-loaded static solution is exact;
    its first modes from ``sparse_modes`` match the discrete closed form of linear elements with
    consistent mass, ω² = 6c²/h² (1 − cos θ)/(2 + cos θ), θ_k = (2k − 1)π/(2N) (axial c² = E/ρ,
    transverse c² = T/ρA, twice), and the continuous ω_k = (2k − 1)π c/(2L) to O(h²)."""
    L, EA, rhoA, T = 2.0, 7.0e6, 2.7, 1.0e5
    c_M = 1.0e6  # an iteration-matrix-like weight of M

    def problem(n_el):
        Ke, Me, dofs = rod_chain(n_el, L, EA, rhoA, T)
        n = 3 * (n_el + 1)
        free = np.arange(n) >= 3
        return Ke, Me, dofs, n, free

    # The small copy: sparse = dense = block-tridiagonal.
    Ke, Me, dofs, n, free = problem(333)
    G = Ke + c_M * Me
    b = np.random.default_rng(6).normal(size=n)
    A = dense_reference([(G, dofs)], free)
    xs = {s: solve([(G, dofs)], free, b, chain_block=3, solver=s) for s in SOLVERS}
    tol = roundoff_tol(A) * np.abs(xs["dense"]).max()
    for s in SOLVERS:
        np.testing.assert_allclose(xs[s], xs["dense"], rtol=0, atol=tol)

    # Full size.
    N = 6667
    Ke, Me, dofs, n, free = problem(N)
    assert n > 20_000
    solve_full = jax.jit(lambda G, b, s: assemble_and_factor([(G, dofs)], jnp.asarray(free), chain_block=3,
                                                        solver=s).solve(b), static_argnums=2)
    assert choose_solver([(Ke, dofs)], n) == "sparse" and n >= DENSE_MAX_DOFS
    b = jnp.asarray(np.random.default_rng(7).normal(size=n))
    G = jnp.asarray(Ke + c_M * Me)
    x_sparse = solve_full(G, b, "sparse")
    x_block = solve_full(G, b, "block_tridiagonal")
    # Dense reference on the full matrix: the residual, in the sparse product.
    A = assemble_sparse([(np.asarray(G), dofs)], n, free)
    np.testing.assert_allclose(A @ np.asarray(x_sparse), b, rtol=0, atol=1e-9 * np.abs(b).max())
    np.testing.assert_allclose(x_sparse, x_block, rtol=0, atol=1e-9 * float(jnp.abs(x_block).max()))
    # Static tip load F along x: u(x) = F x / EA, exact at the nodes of linear elements.
    F = 3.0e3
    f = np.zeros(n)
    f[-3] = F
    u = np.asarray(solve_full(jnp.asarray(Ke), jnp.asarray(f), "sparse"))
    x_nodes = np.linspace(0.0, L, N + 1)
    np.testing.assert_allclose(u[0::3], F * x_nodes / EA, rtol=1e-8, atol=1e-10 * F * L / EA)

    # Modes: the first nine are the transverse pairs k = 1…4 and the first axial one.
    K = assemble_sparse([(Ke, dofs)], n)
    M = assemble_sparse([(Me, dofs)], n)
    assert isinstance(K, sp.csc_matrix)
    h = L / N
    families = [(EA / rhoA, j) for j in range(1, 10)] + [(T / rhoA, j) for j in range(1, 10)] * 2
    continuous = np.array([(2 * j - 1) * np.pi / (2 * L) * np.sqrt(c2) for c2, j in families])
    order = np.argsort(continuous, kind="stable")[:9]
    c2 = np.array([families[i][0] for i in order])
    theta = np.array([(2 * families[i][1] - 1) * np.pi / (2 * N) for i in order])
    discrete = np.sqrt(6 * c2 / h**2 * (1 - np.cos(theta)) / (2 + np.cos(theta)))
    k = len(order)
    omega, phi = sparse_modes(K, M, k, free=free)
    np.testing.assert_allclose(omega, discrete, rtol=1e-9)
    # ω_h/ω − 1 = θ²/24 + O(θ⁴) (consistent mass overestimates): O(h²).
    rel = omega / continuous[order] - 1
    assert np.all(rel > 0) and np.all(rel < theta**2 / 20), (rel, theta**2 / 24)
    # Mass-normalised, zero on the clamped node.
    np.testing.assert_allclose(phi.T @ (M @ phi), np.eye(k), atol=1e-8)
    assert np.all(phi[:3] == 0)


def test_bad_solver_choices_raise():
    m, nb = 3, 6
    Ge, dofs = chain_parts(nb, m)
    n = m * nb
    free = jnp.ones(n, bool)
    parts = [(jnp.asarray(Ge), dofs)]
    with pytest.raises(ValueError, match="solver must be one of"):
        assemble_and_factor(parts, free, solver="cholesky")
    with pytest.raises(ValueError, match="chain_block"):
        assemble_and_factor(parts, free, solver="block_tridiagonal")
    with pytest.raises(ValueError, match="exactly one element group"):
        assemble_and_factor(parts * 2, free, chain_block=m, solver="block_tridiagonal")
    with pytest.raises(ValueError, match="element e's DOFs"):
        assemble_and_factor([(Ge, dofs[::-1])], free, chain_block=m, solver="block_tridiagonal")
    with pytest.raises(ValueError, match="a chain"):
        assemble_and_factor(parts, free, chain_block=2, solver="block_tridiagonal")
    with pytest.raises(ValueError, match="chain_block must be"):
        assemble_and_factor(parts, free, chain_block=0)
    with pytest.raises(ValueError, match="Ge must be"):
        assemble_and_factor([(Ge[:, :4], dofs)], free)
    with pytest.raises(ValueError, match="element_dofs must lie"):
        assemble_and_factor([(Ge, dofs + 100)], free, solver="sparse")
    # Traced element DOFs: no pattern, so "auto" warns when it must factor a large matrix dense.
    def pick(d):
        with pytest.warns(UserWarning, match="traced"):
            assert choose_solver([(Ge, d)], 2 * DENSE_MAX_DOFS) == "dense"
        return d

    jax.jit(pick)(dofs)
    # A chain that does not number its DOFs node by node: "auto" goes by size instead.
    assert choose_solver([(Ge, dofs[::-1])], n, chain_block=m) == "dense"
    # "auto" is resolved once into a solver object, which factors as its name does.
    from nrrncf_jax.linalg import BlockTridiagonal, Dense, linear_solver

    assert linear_solver("auto", [(Ge, dofs)], n, chain_block=m) == BlockTridiagonal(m)
    assert linear_solver("auto", [(Ge, dofs[::-1])], n, chain_block=m) == Dense()
    b = jnp.arange(n, dtype=float)
    for solver, cls in ((Dense(), DenseLU), (BlockTridiagonal(m), BlockTridiagonalLU)):
        fac, x_obj = jax.jit(lambda G, s=solver: (lambda f: (f, f.solve(b)))(s.factor([(G, dofs)], free)))(Ge)
        name = "dense" if isinstance(solver, Dense) else "block_tridiagonal"
        x_name = jax.jit(lambda G, s=name: assemble_and_factor([(G, dofs)], free, chain_block=m, solver=s).solve(b))(Ge)
        assert isinstance(fac, cls)
        np.testing.assert_array_equal(x_obj, x_name)  # the same operations, so the same bits
    assert isinstance(jax.jit(lambda G: assemble_and_factor([(G, dofs)], free, solver="sparse"))(Ge), SparseLU)


def test_sparse_cache_keeps_to_its_memory_budget(monkeypatch):
    """With a budget smaller than one factorisation only the newest is kept, and solves whose
    factors were dropped factor again: the same results as the dense solver (a vmapped batch, each
    member's factors dropped by the next member's before its solve)."""
    from nrrncf_jax.linalg import sparse

    monkeypatch.setattr(sparse, "CACHE_BYTES", 1)
    m, nb = 3, 12
    Ge, dofs = chain_parts(nb, m, seed=5)
    free = jnp.asarray(np.arange(m * nb) >= m)
    b = jnp.asarray(np.random.default_rng(4).normal(size=m * nb))
    scales = 1.0 + 0.1 * jnp.arange(4)
    out = {s: jax.jit(jax.vmap(lambda c: assemble_and_factor([(c * Ge, dofs)], free, solver=s).solve(b)))(scales)
           for s in ("dense", "sparse")}
    np.testing.assert_allclose(out["sparse"], out["dense"], rtol=1e-11, atol=1e-11)
    assert len(sparse._factors) == 1


def test_sparse_factors_live_on_one_host_thread():
    """SciPy frees a SuperLU object's memory only on the thread that made it (scipy#15921), and
    XLA runs callbacks on threads of its own: every cached factorisation, made, solved and
    dropped inside a compiled loop, belongs to the one SuperLU thread, so none leaks."""
    from nrrncf_jax.linalg import sparse

    m, nb = 3, 6
    Ge, dofs = chain_parts(nb, m, seed=7)
    free = jnp.asarray(np.arange(m * nb) >= m)
    b = jnp.ones(m * nb)

    def body(i, x):
        return assemble_and_factor([((1.0 + 0.01 * i) * Ge, dofs)], free, solver="sparse").solve(b + x)

    x = jax.jit(lambda: jax.lax.fori_loop(0, 2 * sparse.CACHE_SIZE + 3, body, jnp.zeros(m * nb)))()
    assert np.all(np.isfinite(x))
    worker = sparse._superlu_thread.submit(threading.get_ident).result()
    threads = {lu.thread for lu in sparse._factors.values() if lu is not None}
    assert threads == {worker}


def test_sparse_callbacks_read_xla_buffers_on_the_cpu():
    """On the CPU the factor and solve callbacks get XLA's own buffers (``buffer_callback``), not
    ``jax.Array`` copies placed by ``device_put`` that the callback then waits for: that wait
    deadlocked on one core (``sparse._host_call``). The compiled solve holds no other callback,
    so the pure_callback branch (for other platforms) is not lowered here; and the solve is
    right."""
    import re

    m, nb = 3, 5
    Ge, dofs = chain_parts(nb, m, seed=8)
    free = jnp.asarray(np.arange(m * nb) >= m)
    b = jnp.asarray(np.random.default_rng(9).normal(size=m * nb))
    solve = jax.jit(lambda G, b: assemble_and_factor([(G, dofs)], free, solver="sparse").solve(b))
    targets = set(re.findall(r"custom_call @(\w+)", solve.lower(Ge, b).as_text()))
    assert targets == {"xla_buffer_python_cpu_callback"}
    A = dense_reference([(Ge, dofs)], free)
    np.testing.assert_allclose(solve(Ge, b), np.linalg.solve(A, b), rtol=0,
                               atol=roundoff_tol(A) * np.abs(np.linalg.solve(A, b)).max())


@pytest.mark.parametrize("spec, shapes", [
    ("ij,jk->ik", [(3, 4), (4, 5)]),
    ("kij,vj->vik", [(4, 3, 3), (7, 3)]),
    ("kia,lib,ab->kl", [(4, 3, 3), (4, 3, 3), (3, 3)]),
    ("k,l,klij->ij", [(4,), (4,), (4, 4, 3, 3)]),
    ("i,i->", [(4,), (4,)]),
    ("ij->ji", [(2, 3)]),
    ("ii->", [(3, 3)]),  # a trace: einsum
    ("ij,jk->ik", [(80, 80), (80, 80)]),  # above MAX_FUSED: einsum
])
def test_contract_is_einsum(spec, shapes):
    """``linalg.contract``: the same contraction as ``einsum`` (to round-off: the products are
    summed in another order), fused where small, an ``einsum`` where large, under ``vmap`` too,
    and always an ``einsum`` inside ``as_einsum()``; a malformed spec is refused."""
    from nrrncf_jax.linalg.contract import MAX_FUSED, as_einsum, contract

    rng = np.random.default_rng(0)
    ops = [rng.normal(size=s) for s in shapes]
    expected = np.einsum(spec, *ops)
    scale = np.einsum(spec, *[np.abs(x) for x in ops])  # the sum of the terms' sizes
    got = np.asarray(contract(spec, *ops))
    assert got.shape == expected.shape
    np.testing.assert_allclose(got, expected, rtol=0, atol=64 * EPS * (np.max(scale) + 1.0))
    batched = jax.vmap(lambda x: contract(spec, x, *ops[1:]))(np.stack([ops[0], 2.0 * ops[0]]))
    np.testing.assert_allclose(np.asarray(batched[1]), 2.0 * expected, rtol=0, atol=128 * EPS * (np.max(scale) + 1.0))
    small = np.prod([n for s in shapes for n in s]) <= MAX_FUSED  # a bound on the product: the fused form
    text = jax.jit(lambda *x: contract(spec, *x)).lower(*ops).as_text()
    if small and "ii" not in spec:
        assert "dot_general" not in text
    with as_einsum():
        text = jax.jit(lambda *x: contract(spec, *x)).lower(*ops).as_text()
    assert ("dot_general" in text) == (len(shapes) > 1)
    with pytest.raises(ValueError, match="explicit einsum"):
        contract("ij,jk", *ops[:2]) if len(ops) > 1 else contract("ij", ops[0])
