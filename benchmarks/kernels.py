"""The reduced cubic elastic force F(p) = f + K p + L p p + N p p p (Eq. 24) and its Jacobian
(Eq. 25), written three ways, timed in compiled loops on one core: how the kernel is written,
not only how much arithmetic it holds, decides its time on XLA's CPU backend.

    python benchmarks/kernels.py [--sizes 9 20 27] [--evals 2000] [--batch 16] [--out benchmarks/results/kernels.md]

Forms of the cubic part N p p p (N symmetric in its last three indices):

- ``packed``: the library's ``ElasticTensors.force``: N on the Km(Km+1)(Km+2)/6 distinct triples,
  multiplicities folded in, contracted with a gather ``p[j] p[k] p[l]`` of the triples;
- ``dense``: one matrix-vector product of N as a Km × Km³ matrix with p ⊗ p ⊗ p;
- ``nested``: three matrix-vector products, ((N p) p) p, with N as Km³ × Km, Km² × Km, ...

and of the Jacobian's cubic part 3 N p p: ``packed`` (the library's ``force_and_jacobian``, N on
the distinct (i, j) and (k, l) pairs), ``dense`` (N as Km² × Km² against p ⊗ p).

Each is timed as ``--evals`` evaluations inside one ``lax.fori_loop`` (p perturbed each time so
that nothing is hoisted out of the loop), compiled ahead of time and run to
``block_until_ready``, best of three runs; also vmapped over a batch of ``--batch`` coordinate
vectors (what a batched sweep evaluates). The forms are checked against each other to
round-off first. The arithmetic of each form is counted (multiply-adds × 2) and reported as
GFLOP/s. Km = 20 is one beam of the NR-RNCF pendulum (5 VMs + 15 MDs), Km = 9 the paper's spin-up
beam at ωs = 4, Km = 27 a larger basis.
"""

import argparse
import itertools
import os
import sys
import time

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _machine import machine, pin_to_one_core, report  # noqa: E402

from nrrncf_jax.reduction.tensors import ElasticTensors  # noqa: E402


def random_tensors(km: int, seed: int = 0) -> ElasticTensors:
    """Tensors of the reduced force's symmetries (the force is an energy's gradient: L symmetric in
    its last two indices, N in all four), random entries of order one."""
    rng = np.random.default_rng(seed)
    L = rng.standard_normal((km, km, km))
    L = 0.5 * (L + L.transpose(0, 2, 1))
    N = rng.standard_normal((km, km, km, km))
    N = sum(N.transpose(perm) for perm in itertools.permutations(range(4))) / 24  # an energy's: all four indices
    K = rng.standard_normal((km, km))
    return ElasticTensors(jnp.asarray(rng.standard_normal(km)), jnp.asarray(K + K.T), jnp.asarray(L), jnp.asarray(N))


def forms(t: ElasticTensors):
    """The force and Jacobian forms (name → function of p) and their flop counts."""
    km = t.n_coordinates
    N_flat = t.N.reshape(km, km**3)
    N_sq = t.N.reshape(km * km, km * km)
    L_flat = t.L.reshape(km, km * km)

    def lin(p):
        return t.f + t.K @ p + L_flat @ jnp.outer(p, p).reshape(-1)

    force = {
        "packed": t.force,
        "dense": lambda p: lin(p) + N_flat @ jnp.einsum("i,j,k->ijk", p, p, p).reshape(-1),
        "nested": lambda p: lin(p) + ((t.N @ p) @ p) @ p,
    }
    jac = {
        "packed": lambda p: t.force_and_jacobian(p)[1],
        "dense": lambda p: t.K + 2.0 * (t.L @ p) + 3.0 * (N_sq @ jnp.outer(p, p).reshape(-1)).reshape(km, km),
    }
    t3, t2 = t.N3.shape[0], t.N2u.shape[0]
    flops = {("force", "packed"): 2 * (km * t3 + km * km + km**3) + 3 * t3,
             ("force", "dense"): 2 * (km**4 + km**3 + km**2) + km**3,
             ("force", "nested"): 2 * (km**4 + km**3 + km**3 + km**2),
             ("jacobian", "packed"): 2 * (t2 * t2 + km**3) + t2,
             ("jacobian", "dense"): 2 * (km**4 + km**3) + km**2}
    return force, jac, flops


def timed_loop(fn, p0, evals: int, batch: int | None):
    """Seconds per evaluation of ``fn`` in a compiled loop (best of three), and the compile time."""
    # Every entry summed into the carry: XLA would otherwise compute only the entries kept.
    if batch is None:
        def body(i, acc):
            return acc + jnp.sum(fn(p0 + 1e-6 * i))
    else:
        f = jax.vmap(fn)
        P = p0 + 1e-2 * jnp.arange(batch)[:, None]

        def body(i, acc):
            return acc + jnp.sum(f(P + 1e-6 * i))
    init = jnp.zeros(())
    run = jax.jit(lambda a: jax.lax.fori_loop(0, evals, body, a))
    t0 = time.perf_counter()
    compiled = run.lower(init).compile()
    compile_s = time.perf_counter() - t0
    best = np.inf
    for _ in range(3):
        t0 = time.perf_counter()
        jax.block_until_ready(compiled(init))
        best = min(best, time.perf_counter() - t0)
    return best / evals, compile_s


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[9, 20, 27])
    ap.add_argument("--evals", type=int, default=2000)
    ap.add_argument("--batch", type=int, default=16)
    ap.add_argument("--all-cores", action="store_true", help="do not pin the process to one core")
    ap.add_argument("--out", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "results", "kernels.md"))
    a = ap.parse_args(argv)
    if not a.all_cores:
        pin_to_one_core()
    rows = []
    for km in a.sizes:
        t = random_tensors(km)
        force, jac, flops = forms(t)
        p = jnp.asarray(np.random.default_rng(1).standard_normal(km))
        # The forms agree to round-off (relative to the largest term's size).
        for kind, fns in (("force", force), ("jacobian", jac)):
            ref = np.asarray(fns["packed"](p))
            scale = np.abs(ref).max()
            for name, fn in fns.items():
                err = float(np.abs(np.asarray(fn(p)) - ref).max() / scale)
                if err > 1e-12:
                    raise AssertionError(f"Km = {km}: {kind} {name} differs from packed by {err:.2e}")
            for name, fn in fns.items():
                for batch in (None, a.batch):
                    s, c = timed_loop(fn, p, a.evals, batch)
                    per = s / (batch or 1)
                    gflops = flops[(kind, name)] / per / 1e9
                    rows.append((km, kind, name, "single" if batch is None else f"vmap {batch}", per * 1e6, c, gflops))
                    print(rows[-1], file=sys.stderr, flush=True)
    lines = ["# The reduced cubic force's kernels: packed gather against dense products", "",
             f"Produced by `python benchmarks/kernels.py --sizes {' '.join(map(str, a.sizes))} --evals {a.evals} "
             f"--batch {a.batch}`. Machine: {machine()}.", "",
             "Random tensors of the reduced force's symmetries (the times do not depend on the values); every form "
             "checked against the library's packed form to 1e-12 relative first. Time per evaluation inside one "
             "compiled `fori_loop` (best of three runs); with `vmap`, per member.", "",
             "| Km | what | form | evaluated | µs / evaluation | compile [s] | GFLOP/s |",
             "|---:|---|---|---|---:|---:|---:|"]
    for km, kind, name, how, us, c, g in rows:
        lines.append(f"| {km} | {kind} | {name} | {how} | {us:.2f} | {c:.2f} | {g:.2f} |")
    report("\n".join(lines) + "\n", a.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
