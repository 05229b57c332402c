"""A batch of small dense solves: LAPACK one member at a time, jaxlib's batched LAPACK
call, and an LU written in XLA operations whose ``vmap`` is one batched computation (issue 35's
third item, measured before it is built into the integrator).

    python benchmarks/investigations/batched_lu.py [--sizes 20 99] [--batches 1 16 64]
        [--out benchmarks/results/batched_lu.md]

For each order n (20: a reduced body; 99: the NR-RNCF pendulum's iteration matrix with its
joints) and batch size b: b random well-conditioned systems A x = r solved by
- ``lax.map`` of one LAPACK getrf of [A | r] and a triangular solve per member (the library's
  ``linalg.dense.solve_once`` under ``vmap``);
- ``vmap`` of the same (jaxlib's batched getrf: one call, members looped inside it);
- ``vmap`` of an LU with partial pivoting written as an XLA loop over the n columns (each step a
  pivot search, a row swap and a rank-1 update of the whole masked matrix), then two triangular
  solves: one batched computation, no LAPACK;
- on a GPU also ``vmap`` of ``solve_once`` itself, whose GPU form is the square batched getrf
  and ``lu_solve`` (there the first two rows call cuSOLVER, not LAPACK).

Each is compiled first, then timed as the best of 5 repeats of 20 calls (``block_until_ready``);
the table gives µs a member. The in-graph LU's residual |A x − r| / (|A| |x|) is checked against
the LAPACK one's. One core.
"""

import argparse
import os
import sys
import time

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import jax.scipy.linalg as jsl  # noqa: E402
import numpy as np  # noqa: E402
from jax import lax  # noqa: E402

sys.path[:0] = [os.path.dirname(__file__), os.path.dirname(os.path.dirname(os.path.abspath(__file__)))]
from _machine import machine, pin_to_one_core, report  # noqa: E402

from nrrncf_jax.linalg.dense import solve_once  # noqa: E402


def lapack_solve(A, r):
    lu, _ = jsl.lu_factor(jnp.concatenate([A, r[:, None]], axis=1))
    return jsl.solve_triangular(lu[:, :-1], lu[:, -1], lower=False)


def graph_lu(A):
    """LU with partial pivoting as an XLA loop over the columns: ``(lu, perm)`` with
    A[perm] = L U (L unit lower, in lu's strict lower triangle)."""
    n = A.shape[-1]
    idx = jnp.arange(n)

    def column(k, carry):
        a, perm = carry
        p = jnp.argmax(jnp.where(idx >= k, jnp.abs(a[:, k]), -1.0))
        swap = jnp.where(idx == k, p, jnp.where(idx == p, k, idx))  # rows k and p exchanged
        a, perm = a[swap], perm[swap]
        below = idx > k
        ell = jnp.where(below, a[:, k] / a[k, k], 0.0)
        a = a - jnp.outer(ell, jnp.where(below, a[k], 0.0))
        a = a.at[:, k].set(jnp.where(below, ell, a[:, k]))
        return a, perm

    return lax.fori_loop(0, n, column, (A, idx))


def graph_solve(A, r):
    lu, perm = graph_lu(A)
    y = jsl.solve_triangular(lu, r[perm], lower=True, unit_diagonal=True)
    return jsl.solve_triangular(lu, y, lower=False)


def timed(f, *args, repeats=5, calls=20):
    jax.block_until_ready(f(*args))
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(calls):
            out = f(*args)
        jax.block_until_ready(out)
        best = min(best, (time.perf_counter() - t0) / calls)
    return best


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[20, 99])
    ap.add_argument("--batches", type=int, nargs="+", default=[1, 16, 64])
    ap.add_argument("--out", default="benchmarks/results/batched_lu.md")
    args = ap.parse_args()
    pin_to_one_core()
    rng = np.random.default_rng(0)
    methods = {
        "LAPACK, lax.map (library)": jax.jit(lambda A, r: lax.map(lambda ar: lapack_solve(*ar), (A, r))),
        "LAPACK, batched call (vmap)": jax.jit(jax.vmap(lapack_solve)),
        "XLA loop LU (vmap)": jax.jit(jax.vmap(graph_solve)),
    }
    platform = jax.devices()[0].platform
    if platform != "cpu":  # on a CPU the library's solve is the lax.map row; elsewhere its own batched form
        methods["library solve_once (vmap)"] = jax.jit(jax.vmap(solve_once))
    rows = []
    for n in args.sizes:
        for b in args.batches:
            A = rng.standard_normal((b, n, n)) + n * np.eye(n) * rng.uniform(0.5, 1.5, (b, 1, 1))
            A[:, :, 0] *= 1e-3  # a small first column: pivoting must swap rows
            r = rng.standard_normal((b, n))
            A, r = jnp.asarray(A), jnp.asarray(r)
            ref = np.asarray(methods["LAPACK, lax.map (library)"](A, r))
            for name, f in methods.items():
                x = np.asarray(f(A, r))
                res = np.max(np.linalg.norm(np.einsum("bij,bj->bi", A, x) - r, axis=1)
                             / (np.linalg.norm(A, axis=(1, 2)) * np.linalg.norm(x, axis=1)))
                t = timed(f, A, r)
                rows.append((n, b, name, 1e6 * t / b, res, float(np.max(np.abs(x - ref)) / np.max(np.abs(ref)))))
                print(rows[-1], flush=True)
    lines = [f"# A batch of small dense solves on the {platform.upper()} (issue 35)", "",
             f"Produced by `benchmarks/investigations/batched_lu.py`. Machine: {machine()}.", "",
             "b random systems of order n, each solved by LU with partial pivoting; µs a member (best of 5 "
             "repeats of 20 calls, compiled first). Residual: max over members of |A x − r| / (|A| |x|); "
             "difference: max |x − x_LAPACK| / max |x_LAPACK|.", "",
             "| n | b | method | µs a member | residual | difference |", "|---:|---:|---|---:|---:|---:|"]
    lines += [f"| {n} | {b} | {name} | {t:.1f} | {res:.1e} | {d:.1e} |" for n, b, name, t, res, d in rows]
    report("\n".join(lines) + "\n", args.out, keep_notes="## Notes")


if __name__ == "__main__":
    main()
