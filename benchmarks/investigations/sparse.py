"""The iteration matrix's linear solvers: dense vs block-tridiagonal vs sparse, by size, and the
first 100 modes of a 20,000-DOF model by the sparse shift-invert eigensolver.

    python benchmarks/investigations/sparse.py [--sizes 2000 20000 100000] [--repeats 3] [--modes 100]
                                [--out benchmarks/results/sparse.md]

1. Chains of beam-sized elements (18 DOFs a node, 36-DOF elements, as the RNCF beam) at about
   2,000 / 20,000 / 100,000 DOFs: ``assemble_and_factor`` + one solve, jit-compiled, with each
   solver. The sparse solver is given the chain as a general mesh (no ``chain_block``), as a
   body that is not one chain gets it. Compile time (trace, the sparse pattern and XLA) apart
   from run time (best of ``--repeats``, ``block_until_ready``); a second solve with the same
   factors (modified Newton) apart. Memory: XLA's buffers of the compiled factor+solve
   (``memory_analysis``: temporaries and output; the element matrices, the same for all, left
   out) and, for the sparse solver, SuperLU's factors on the host.
2. Where ``"auto"`` switches from dense to sparse (``linalg.DENSE_MAX_DOFS``): a 2-D mesh of
   triangles with 9 DOFs a node (a membrane's pattern, no chain), 500 to 3,000 DOFs.
3. SuperLU's column ordering at 20,000 DOFs (``linalg.sparse.PERMC_SPEC``), and the other
   candidate, ``jax.experimental.sparse.linalg.spsolve`` (SciPy's ``spsolve`` on a CPU: a new
   factorisation per solve).
4. The first ``--modes`` modes of a fixed-free 3-D rod of linear elements at 20,001 DOFs
   (``sparse_modes``), against the discrete closed form.

Element matrices are random (SPD plus a skew part, as an iteration matrix with gyroscopic
terms), so the timing does not wait for a 45-second build of a 20,000-DOF beam; a direct solver's
cost depends on the pattern, not on the values.
"""

import argparse
import os
import sys
import time

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
import scipy.sparse.linalg as spla  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from _machine import machine, report  # noqa: E402

from nrrncf_jax.linalg import (  # noqa: E402
    DENSE_MAX_DOFS,
    SparsityPattern,
    assemble_and_factor,
    assemble_sparse,
    sparse_modes,
)
from nrrncf_jax.linalg import sparse as sparse_module  # noqa: E402

M_NODE = 18  # DOFs a node of the RNCF beam (6 nodal vectors × 3)
DENSE_LIMIT = 5000  # dense factor+solve above this many DOFs is extrapolated, not run


def random_elements(n_el, nd, seed=0):
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(n_el, nd, nd))
    return np.einsum("eij,ekj->eik", X, X) / nd + np.eye(nd) + 0.05 * (X - X.transpose(0, 2, 1))


def chain(n_target):
    nb = max(2, round(n_target / M_NODE))
    dofs = M_NODE * np.arange(nb - 1)[:, None] + np.arange(2 * M_NODE)
    return random_elements(nb - 1, 2 * M_NODE), dofs, nb * M_NODE


def mesh_2d(n_target, per=9):
    """Triangles on an nx × ny grid of nodes, ``per`` DOFs a node, numbered row by row."""
    nodes = n_target / per
    nx = int(np.ceil(np.sqrt(nodes)))
    ny = max(2, round(nodes / nx))
    nid = np.arange(nx * ny).reshape(ny, nx)
    a, b, c, d = nid[:-1, :-1].ravel(), nid[:-1, 1:].ravel(), nid[1:, :-1].ravel(), nid[1:, 1:].ravel()
    tri = np.concatenate([np.stack([a, b, d], 1), np.stack([a, d, c], 1)])
    dofs = (per * tri[:, :, None] + np.arange(per)).reshape(len(tri), -1)
    return random_elements(len(tri), 3 * per, seed=1), dofs, nx * ny * per


def best(f, repeats):
    ts = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        jax.block_until_ready(f())
        ts.append(time.perf_counter() - t0)
    return min(ts)


def measure(Ge, dofs, n, solver, repeats, chain_block=None):
    """Compile time, factor+solve time, second-solve time [s] and memory [bytes] of one solver."""
    free = jnp.asarray(np.arange(n) >= (chain_block or M_NODE))  # the first node clamped
    b = jnp.asarray(np.random.default_rng(2).normal(size=n))
    Ge = jnp.asarray(Ge)

    def factor(G):
        return assemble_and_factor([(G, dofs)], free, chain_block=chain_block, solver=solver)

    SparsityPattern._cache.clear()  # the pattern is built in the trace, as on a first call
    t0 = time.perf_counter()
    compiled = jax.jit(lambda G, b: factor(G).solve(b)).lower(Ge, b).compile()
    t_compile = time.perf_counter() - t0
    jax.block_until_ready(compiled(Ge, b))
    t_run = best(lambda: compiled(Ge, b), repeats)
    fac = jax.block_until_ready(jax.jit(factor)(Ge))
    solve = jax.jit(lambda fac, b: fac.solve(b))
    jax.block_until_ready(solve(fac, b))
    t_solve = best(lambda: solve(fac, b), repeats)
    mem = compiled.memory_analysis()
    nbytes = mem.temp_size_in_bytes + mem.output_size_in_bytes
    host = 0
    if solver == "sparse":
        lu = sparse_module._factors.get(int(fac.handle))
        if lu is not None:
            host = lu.nbytes  # ScaledSuperLU: values and row indices of L and U, and the permutations
    return t_compile, t_run, t_solve, nbytes, host


def mb(x):
    return f"{x / 2**20:,.0f}" if x >= 2**20 else f"{x / 2**20:.2f}"


def chain_table(sizes, repeats):
    lines = ["| DOFs | solver | compile [s] | factor + solve [ms] | second solve [ms] | memory [MB] | note |",
             "|---|---|---|---|---|---|---|"]
    dense_ref = None
    for n_target in sizes:
        Ge, dofs, n = chain(n_target)
        for solver in ("dense", "block_tridiagonal", "sparse"):
            label = {"block_tridiagonal": "block-tridiagonal"}.get(solver, solver)
            if solver == "dense" and n > DENSE_LIMIT:
                need = 2 * n * n * 8
                est = f"; n³ from {dense_ref[0]:,} DOFs: ~{dense_ref[1] * (n / dense_ref[0]) ** 3:,.0f} s" \
                    if dense_ref else ""
                lines.append(f"| {n:,} | {label} | – | – | – | {mb(need)} (needed) | skipped: matrix + LU "
                             f"{need / 2**30:.1f} GB{est} |")
                continue
            t_c, t_r, t_s, nbytes, host = measure(Ge, dofs, n, solver, repeats,
                                                  M_NODE if solver == "block_tridiagonal" else None)
            if solver == "dense":
                dense_ref = (n, t_r)
            note = f"+ {mb(host)} MB SuperLU factors on the host" if host else ""
            lines.append(f"| {n:,} | {label} | {t_c:.2f} | {1e3 * t_r:,.1f} | {1e3 * t_s:,.2f} | {mb(nbytes)} | "
                         f"{note} |")
            print(lines[-1], flush=True)
    return lines


def crossover_table(sizes, repeats):
    lines = ["| DOFs | dense factor + solve [ms] | sparse factor + solve [ms] | dense / sparse |",
             "|---|---|---|---|"]
    for n_target in sizes:
        Ge, dofs, n = mesh_2d(n_target)
        t = {s: measure(Ge, dofs, n, s, repeats)[1] for s in ("dense", "sparse")}
        lines.append(f"| {n:,} | {1e3 * t['dense']:,.1f} | {1e3 * t['sparse']:,.1f} | "
                     f"{t['dense'] / t['sparse']:.1f} |")
        print(lines[-1], flush=True)
    return lines


def ordering_table(repeats):
    lines = ["| mesh (≈20,000 DOFs) | ordering | SuperLU factor [ms] | L + U entries | solve [ms] |",
             "|---|---|---|---|---|"]
    for name, (Ge, dofs, n) in (("beam-sized chain", chain(20000)), ("2-D triangles, 9 DOFs a node",
                                                                     mesh_2d(20000))):
        A = assemble_sparse([(Ge, dofs)], n)
        b = np.random.default_rng(3).normal(size=n)
        for spec, kw in (("COLAMD (SciPy's default)", dict(permc_spec="COLAMD")),
                         ("NATURAL", dict(permc_spec="NATURAL", diag_pivot_thresh=0.1,
                                          options=dict(SymmetricMode=True))),
                         (f"{sparse_module.PERMC_SPEC}, symmetric mode (used)",
                          dict(permc_spec=sparse_module.PERMC_SPEC, diag_pivot_thresh=sparse_module.DIAG_PIVOT_THRESH,
                               options=dict(SymmetricMode=True)))):
            ts, lu = [], None
            for _ in range(repeats):
                t0 = time.perf_counter()
                lu = spla.splu(A, **kw)
                ts.append(time.perf_counter() - t0)
            t_solve = best(lambda: lu.solve(b), repeats)
            lines.append(f"| {name} | {spec} | {1e3 * min(ts):,.0f} | {lu.L.nnz + lu.U.nnz:,} | {1e3 * t_solve:.1f} |")
            print(lines[-1], flush=True)
    return lines


def spsolve_row(repeats):
    from jax.experimental.sparse.linalg import spsolve

    Ge, dofs, n = chain(20000)
    A = assemble_sparse([(Ge, dofs)], n).tocsr()
    A.sort_indices()
    f = jax.jit(lambda d, b: spsolve(d, A.indices, A.indptr, b))
    d, b = jnp.asarray(A.data), jnp.asarray(np.random.default_rng(4).normal(size=n))
    jax.block_until_ready(f(d, b))
    return n, best(lambda: f(d, b), repeats)


def modes_row(k):
    """First k modes of a fixed-free 3-D rod (axial EA, transverse tension T, consistent mass)."""
    N, L, EA, rhoA, T = 6666, 2.0, 7.0e6, 2.7, 1.0e5
    h = L / N
    k1 = np.array([[1.0, -1.0], [-1.0, 1.0]]) / h
    Pa = np.diag([1.0, 0.0, 0.0])
    Ke = np.broadcast_to(np.kron(k1, EA * Pa + T * (np.eye(3) - Pa)), (N, 6, 6))
    Me = np.broadcast_to(np.kron(rhoA * h / 6 * np.array([[2.0, 1.0], [1.0, 2.0]]), np.eye(3)), (N, 6, 6))
    dofs = 3 * np.arange(N)[:, None] + np.arange(6)
    n = 3 * (N + 1)
    t0 = time.perf_counter()
    K, M = assemble_sparse([(Ke, dofs)], n), assemble_sparse([(Me, dofs)], n)
    t_asm = time.perf_counter() - t0
    t0 = time.perf_counter()
    omega, _ = sparse_modes(K, M, k, free=np.arange(n) >= 3)
    t_modes = time.perf_counter() - t0
    j = np.arange(1, k + 1)
    theta = (2 * j - 1) * np.pi / (2 * N)
    w = {c2: np.sqrt(6 * c2 / h**2 * (1 - np.cos(theta)) / (2 + np.cos(theta))) for c2 in (EA / rhoA, T / rhoA)}
    exact = np.sort(np.concatenate([w[EA / rhoA], w[T / rhoA], w[T / rhoA]]))[:k]
    return n, t_asm, t_modes, float(np.max(np.abs(omega / exact - 1)))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[2000, 20000, 100000])
    ap.add_argument("--crossover", type=int, nargs="+", default=[500, 1000, 2000, 3000])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--modes", type=int, default=100)
    ap.add_argument("--out", default="benchmarks/results/sparse.md")
    a = ap.parse_args(argv)
    t_start = time.perf_counter()
    load0 = os.getloadavg()[0]
    chains = chain_table(a.sizes, a.repeats)
    cross = crossover_table(a.crossover, a.repeats)
    orders = ordering_table(max(1, a.repeats - 1))
    n_sp, t_sp = spsolve_row(a.repeats)
    n_m, t_asm, t_modes, err = modes_row(a.modes)
    load1 = os.getloadavg()[0]
    text = "\n".join([
        "# Linear solvers of the iteration matrix: dense, block-tridiagonal, sparse", "",
        "Produced by `benchmarks/investigations/sparse.py`. Machine: " + machine()
        + f" (load average {load0:.1f} at the start, "
        f"{load1:.1f} at the end; {time.perf_counter() - t_start:.0f} s in all).", "",
        "## Factor + solve by size: chains of beam-sized elements (18 DOFs a node)", "",
        "`assemble_and_factor` and one solve, jit-compiled; best of "
        f"{a.repeats}. The sparse solver gets the chain as a general mesh (no `chain_block`). "
        "Memory: XLA's buffers of the compiled factor+solve (temporaries and output).", "",
        *chains, "",
        "## Where `\"auto\"` switches from dense to sparse", "",
        "A 2-D mesh of triangles, 9 DOFs a node (no chain). `DENSE_MAX_DOFS` = "
        f"{DENSE_MAX_DOFS:,}: below it `\"auto\"` factors dense, which also batches under `vmap` and runs on "
        "accelerators; above it dense costs O(n³) time and O(n²) memory.", "",
        *cross, "",
        "## The sparse solver's choices", "",
        "SuperLU's fill-reducing column ordering (`scipy.sparse.linalg.splu`):", "",
        *orders, "",
        f"`jax.experimental.sparse.linalg.spsolve` (on a CPU SciPy's `spsolve`: a new factorisation for every "
        f"solve, no reuse across modified-Newton iterations, no `vmap`) on the {n_sp:,}-DOF chain: "
        f"{1e3 * t_sp:,.0f} ms per solve, against one factorisation plus cheap solves above.", "",
        "Iterative solvers (lineax's GMRES/BiCGStab are the same algorithms) were ruled out by a one-off "
        "measurement, not repeated here: SciPy's GMRES(50) and BiCGStab with a Jacobi preconditioner on the paper "
        "beam's iteration matrix at 20,016 DOFs (1,111 elements, ω = 40 rad/s) needed 710 BiCGStab iterations "
        "(30 s) at h = 1e-4 and did not converge to 1e-10 in 2,000 iterations at h = 1e-3 or 1e-2 "
        "(SuperLU: 0.2 s to factor, 6 ms to solve).", "",
        f"## First {a.modes} modes at {n_m:,} DOFs", "",
        "A fixed-free 3-D rod of linear elements (axial stiffness and a taut string's transverse stiffness, "
        "consistent mass), `sparse_modes` (shift-invert Lanczos, `eigsh` with one SuperLU factorisation):", "",
        "| DOFs | modes | assembly (`assemble_sparse`, K and M) [s] | `sparse_modes` [s] | "
        "max rel. error vs discrete closed form |",
        "|---|---|---|---|---|",
        f"| {n_m:,} | {a.modes} | {t_asm:.2f} | {t_modes:.1f} | {err:.1e} |", "",
    ])
    report(text, a.out)


if __name__ == "__main__":
    sys.exit(main())
