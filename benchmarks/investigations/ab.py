"""A/B comparison of results and speed between a git revision (A, the base) and the working tree (B).

    python benchmarks/investigations/ab.py --base REV [--cases rncf ancf nr_rncf sweep grad] [--repeats 2]
                            [--out benchmarks/results/ab.md]

The base revision is checked out with ``git worktree add --detach`` in a temporary directory
(removed at the end). The cases run in subprocesses, once per revision and repeat, with
``PYTHONPATH`` at the revision's tree; each subprocess reports ``nrrncf_jax.__file__`` and its
results are rejected unless that file lies in the expected tree. The runs alternate between the
revisions (A B, then B A, ...) so that a drift of the machine's load falls on both; each time is
the best of ``--repeats``. Compile time is cold in every subprocess (no persistent compilation
cache).

Cases (representative runs of the other benchmarks, the paper beam spun up by Eq. 43, T_s = 15 s,
ρ∞ = 0.9, rtol = 1e-4, atol = 1e-6, outputs every 0.01 s; all of them, A and B, twice each: about
6 minutes on the shared 2-core CPU at load average 4):

- ``rncf``: full RNCF, ωs = 4 rad/s, 6 elements, 0-30 s (``spinup_full.md``'s and ``table3.md``'s
  first row);
- ``ancf``: full ANCF, the same beam and manoeuvre, 0-``ANCF_T_END`` s (ANCF takes ten times the
  steps);
- ``nr_rncf``: the NR-RNCF model from ``nr_rncf`` (24 candidate modes, automatic selection) of the
  ``rncf`` case and its run, with χ_rel (Eq. 40, all nodal displacements) against the full RNCF
  run (``table3.md``'s NR-RNCF row);
- ``sweep``: ``simulate_batch`` over 8 speeds ωs = 1 … 4 rad/s, 0-``SWEEP_T_END`` s, of that
  NR-RNCF model (as ``sweep.py``: one basis, the motion swapped per member);
- ``grad``: ``jax.grad`` of Σ uy_tip² (every 0.1 s, 0-30 s) through ``simulate(adjoint="reverse")``
  of that NR-RNCF model with respect to ωs (as ``optimal_spinup.py`` differentiates it);
- ``pendulum``: the three-beam pendulum with NR-RNCF bodies in floating frames (5 VMs + 15 MDs a
  beam, 10 elements, 0-2 s; ``pendulum.md``'s NR-RNCF row), an index-3 run of a constrained system;
- ``pendulum_rncf``: the same pendulum at full order in floating frames (4 elements, 0-0.5 s).

The cases on the RNCF model and its NR-RNCF basis (``rncf``, ``nr_rncf``, ``sweep``, ``grad``) run
in one subprocess per revision and repeat, in that order, since the basis (``nr_rncf``'s offline
stage) costs most of their time; ``ancf`` runs in its own, and the two pendulums in a third.
Compile and run seconds are each case's own (ahead-of-time compilation, then a blocked run).
The script and its subprocesses run on one core (the lowest allowed; ``--all-cores`` not to), as
the other benchmarks: unpinned, the small cases' times on a 2-core VM scattered twofold between
runs of the same code (``results/ab.md``, its notes).

Results compared: accepted and rejected steps and Newton iterations (must be equal), and to
``TOL`` relative: the tip's extremes (min and max of each displacement component in the rotating
frame, relative to the largest of them, so that a component that stays at round-off, uz of an
in-plane spin-up, does not count), χ_rel, the gradient and the sweep's per-member extremes.
The exit status is 1 if any result differs beyond that. Speed is reported, not enforced: B/A of
the best run times, all run times, and "beyond noise" where every run of one revision was faster
than every run of the other.

Only public API present in both revisions is used: ``RotatingFrameModel(body, motion)``,
``InertialFrameModel(body, motion)``, ``SpinUp(omega_s, T_s)``, ``simulate``, ``simulate_timed``,
``simulate_batch`` (with the solver and controller as objects where the revision takes them,
``_integrator``), ``nr_rncf``, ``chi_rel``, ``scenarios.beam_preset(...).body(n)``.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
BENCH = os.path.dirname(HERE)  # benchmarks/: _machine and results/
TREE = os.path.dirname(BENCH)
TOL = 1e-9
CASES = ("rncf", "ancf", "nr_rncf", "sweep", "grad", "pendulum", "pendulum_rncf")
PENDULUM_GROUP = ("pendulum", "pendulum_rncf")
ANCF_T_END = 10.0
SWEEP_T_END = 20.0
TIP_NAMES = [f"tip u{c} {m}" for c in "xyz" for m in ("min", "max")]


# ---- the worker: one case, in the tree on PYTHONPATH -------------------------------------------------

def _tip_extremes(tip):
    """[ux min, ux max, uy min, uy max, uz min, uz max] of a (..., 3) tip history."""
    import numpy as np

    tip = np.asarray(tip).reshape(-1, 3)
    return [float(f(tip[:, i])) for i in range(3) for f in (np.min, np.max)]


def _paper_rncf(n_el, omega_s, T_s, inertial=False):
    from nrrncf_jax import InertialFrameModel, RotatingFrameModel, SpinUp
    from nrrncf_jax.scenarios import beam_preset

    body = beam_preset("paper").body(n_el)
    cls = InertialFrameModel if inertial else RotatingFrameModel
    return cls(body, SpinUp(omega_s, T_s)), body.n_vectors - body.vectors_per_node


def _full_spinup(inertial, t_end):
    """The full-order spin-up (ωs = 4, 6 elements): solution, all nodal displacements (nt, n, 3),
    output times, compile and run seconds."""
    import jax.numpy as jnp
    import numpy as np

    from nrrncf_jax import simulate_timed

    model, tip = _paper_rncf(6, 4.0, 15.0, inertial)
    ts = np.arange(0.0, t_end + 0.005, 0.01)
    sol, compile_s, run_s = simulate_timed(model, *_integrator(), jnp.asarray(ts),
                                           observe=lambda t, q, v: model.displacements(t, q))
    return model, tip, sol, np.asarray(sol.ys), ts, compile_s, run_s


def _integrator():
    """``(solver, controller)`` at the defaults both revisions share (generalized-α with ρ∞ = 0.9,
    rtol = 1e-4, atol = 1e-6) where the revision takes them as objects
    (``simulate(model, solver, controller, ts)``); ``()`` for the older keyword form."""
    import nrrncf_jax as nr

    if hasattr(nr, "AdaptiveStepSize"):
        return nr.GeneralizedAlpha(0.9), nr.AdaptiveStepSize(1e-4, 1e-6)
    return ()


def _stats(sol):
    return {"steps": int(sol.num_steps), "rejected": int(sol.num_rejected), "newton": int(sol.num_newton)}


def _swap_motion(model, omega_s, T_s=15.0):
    """``model`` spun up to ``omega_s`` in ``T_s`` (for a reduced model: its basis kept)."""
    import equinox as eqx

    from nrrncf_jax import SpinUp

    return eqx.tree_at(lambda m: m.motion, model, SpinUp(omega_s, T_s))


def case_rncf(shared):
    model, tip, sol, w, ts, c, r = _full_spinup(False, 30.0)
    shared["rncf"] = (model, tip, w, ts)
    return {**_stats(sol), "tip": _tip_extremes(w[:, tip])}, c, r, {}


def case_ancf(shared):
    _, tip, sol, w, _, c, r = _full_spinup(True, ANCF_T_END)
    return {**_stats(sol), "tip": _tip_extremes(w[:, tip])}, c, r, {}


def _pendulum(formulation, elements, t_end):
    """The three-beam pendulum (``scenarios.pendulum.run_pendulum``, the same call in both
    revisions): results, compile and run seconds."""
    import numpy as np

    from nrrncf_jax.scenarios.pendulum import PendulumSpec, run_pendulum

    run = run_pendulum(PendulumSpec(elements=elements), formulation=formulation, t_end=t_end)
    tip = np.asarray(run.tips)[:, -1, :]  # the third beam's free end
    res = {"steps": int(run.steps), "rejected": int(run.rejected), "newton": int(run.newton_iters),
           "dofs": int(run.dofs), "tip": _tip_extremes(tip)}
    return res, run.compile_s, run.run_s, {}


def case_pendulum(shared):
    """The NR-RNCF pendulum (5 VMs + 15 MDs a beam, 10 elements, 0-2 s): the floating-frame
    system with reduced bodies."""
    return _pendulum("nr-rncf", 10, 2.0)


def case_pendulum_rncf(shared):
    """The full-order RNCF pendulum (4 elements, 0-0.5 s): floating frames with every nodal
    coordinate kept."""
    return _pendulum("rncf", 4, 0.5)


def _reduction(shared):
    """The NR-RNCF basis of the ``rncf`` case (built once per subprocess) and its offline seconds."""
    import jax.numpy as jnp

    from nrrncf_jax import nr_rncf

    if "reduction" not in shared:
        if "rncf" not in shared:
            case_rncf(shared)
        full, _, _, ts = shared["rncf"]
        t0 = time.perf_counter()
        shared["reduction"] = nr_rncf(full, jnp.asarray(ts)), time.perf_counter() - t0
    return shared["reduction"]


def case_nr_rncf(shared):
    import jax
    import jax.numpy as jnp
    import numpy as np

    from nrrncf_jax import chi_rel, simulate_timed

    red, offline = _reduction(shared)
    _, tip, w_full, ts = shared["rncf"]
    sol, c, r = simulate_timed(red.model, *_integrator(), jnp.asarray(ts), observe=lambda t, p, v: p)
    w = np.asarray(jax.vmap(lambda p: red.model.displacements(0.0, p))(sol.ys))
    res = {**_stats(sol), "dofs": int(red.dofs), "chi_rel": float(chi_rel(w_full, w)), "tip": _tip_extremes(w[:, tip])}
    return res, c, r, {"offline_s": offline}


def case_sweep(shared):
    """``simulate_batch`` of the NR-RNCF model over 8 speeds ωs = 1 … 4 rad/s (its basis built at 4),
    0-``SWEEP_T_END`` s, in one jit (compiled ahead of time, then run)."""
    import jax
    import jax.numpy as jnp
    import numpy as np

    from nrrncf_jax import simulate_batch

    red, _ = _reduction(shared)
    _, tip, _, _ = shared["rncf"]
    ts = np.arange(0.0, SWEEP_T_END + 0.005, 0.01)
    model_fn = jax.tree_util.Partial(_swap_motion, red.model)
    sweep = jax.jit(lambda omegas: simulate_batch(model_fn, omegas, *_integrator(), ts, observe=lambda t, p, v: p))
    omegas = jnp.linspace(1.0, 4.0, 8)
    t0 = time.perf_counter()
    compiled = sweep.lower(omegas).compile()
    c = time.perf_counter() - t0
    t0 = time.perf_counter()
    sol = jax.block_until_ready(compiled(omegas))
    r = time.perf_counter() - t0
    w = np.asarray(jax.vmap(jax.vmap(lambda p: red.model.displacements(0.0, p)[tip]))(sol.ys))  # (8, nt, 3)
    res = {"steps": int(np.sum(sol.num_steps)), "rejected": int(np.sum(sol.num_rejected)),
           "newton": int(np.sum(sol.num_newton)), "member_steps": [int(x) for x in np.asarray(sol.num_steps)],
           "tip": [x for m in w for x in _tip_extremes(m)]}
    return res, c, r, {}


def case_grad(shared):
    """d/dωs of Σ uy_tip² (outputs every 0.1 s, 0-30 s) of the NR-RNCF model by ``jax.grad`` through
    ``simulate(adjoint="reverse")`` (as ``optimal_spinup.py`` differentiates the reduced model);
    steps etc. of the forward run."""
    import jax
    import jax.numpy as jnp
    import numpy as np

    from nrrncf_jax import simulate

    red, _ = _reduction(shared)
    _, tip, _, _ = shared["rncf"]
    ts = jnp.asarray(np.arange(0.0, 30.05, 0.1))

    def run(w, adjoint):
        model = _swap_motion(red.model, w)
        return simulate(model, *_integrator(), ts, observe=lambda t, p, v: model.displacements(t, p)[tip],
                        adjoint=adjoint)

    grad = jax.jit(jax.grad(lambda w: jnp.sum(run(w, "reverse").ys[:, 1] ** 2)))
    w0 = jnp.asarray(4.0)
    t0 = time.perf_counter()
    compiled = grad.lower(w0).compile()
    c = time.perf_counter() - t0
    t0 = time.perf_counter()
    g = float(jax.block_until_ready(compiled(w0)))
    r = time.perf_counter() - t0
    sol = run(w0, "forward")
    return {**_stats(sol), "grad": g, "tip": _tip_extremes(np.asarray(sol.ys))}, c, r, {}


def worker(cases: list[str]) -> None:
    """Run ``cases`` in this process (in this order, sharing the RNCF run and its basis) and print one
    JSON line: the imported package's file and each case's results and seconds."""
    import jax

    jax.config.update("jax_enable_x64", True)
    import nrrncf_jax

    shared, out = {}, {}
    for case in cases:
        res, c, r, extra = globals()[f"case_{case}"](shared)
        out[case] = {"results": res, "compile_s": c, "run_s": r, "extra": extra}
    print(json.dumps({"file": os.path.realpath(nrrncf_jax.__file__), "cases": out}))


# ---- the driver ----------------------------------------------------------------------------------------

def _log(msg):
    print(msg, file=sys.stderr, flush=True)


def _run_group(cases: list[str], tree: str) -> dict:
    env = dict(os.environ, PYTHONPATH=tree, NRRNCF_JAX_CACHE="off", JAX_ENABLE_X64="1")
    env.pop("JAX_COMPILATION_CACHE_DIR", None)
    with tempfile.TemporaryDirectory(prefix="ab_cwd_") as cwd:  # nothing importable from the cwd
        t0 = time.perf_counter()
        out = subprocess.run([sys.executable, os.path.abspath(__file__), "--worker", *cases], capture_output=True,
                             text=True, env=env, cwd=cwd)
        wall = time.perf_counter() - t0
    if out.returncode != 0:
        raise RuntimeError(f"cases {cases} in {tree} failed:\n{out.stderr[-4000:]}")
    d = json.loads(out.stdout.strip().splitlines()[-1])
    want = os.path.join(os.path.realpath(tree), "nrrncf_jax") + os.sep
    if not d["file"].startswith(want):
        raise RuntimeError(f"cases {cases}: the subprocess imported {d['file']}, not the package in {tree}")
    return {case: {**v, "wall_s": wall} for case, v in d["cases"].items()}


def _rel_diff(a: dict, b: dict) -> tuple[float, str, list[str]]:
    """The largest relative difference of the float results, which one it is, and the names of
    unequal integer results."""
    worst, where, unequal = 0.0, "", []
    for key in sorted(set(a) | set(b)):
        x, y = a.get(key), b.get(key)
        if x is None or y is None:
            unequal.append(key)
        elif isinstance(x, int) or (isinstance(x, list) and x and isinstance(x[0], int)):
            if x != y:
                unequal.append(key)
        elif key == "tip":
            if len(x) != len(y):
                unequal.append(key)
                continue
            scale = max(max(abs(v) for v in x), max(abs(v) for v in y), 1e-300)
            for i, (u, v) in enumerate(zip(x, y)):
                if abs(u - v) / scale > worst:
                    member = f"member {i // 6 + 1} " if len(x) > 6 else ""
                    worst, where = abs(u - v) / scale, member + TIP_NAMES[i % 6]
        else:
            d = abs(x - y) / max(abs(x), abs(y), 1e-300)
            if d > worst:
                worst, where = d, key
    return worst, where, unequal


def _speed(A: list, B: list) -> str:
    """Whether B is slower or faster than A beyond the spread of the repeats: B's best run above A's
    worst, or B's worst below A's best."""
    a, b = [x["run_s"] for x in A], [x["run_s"] for x in B]
    if min(b) > max(a):
        return " (slower beyond noise)"
    if max(b) < min(a):
        return " (faster beyond noise)"
    return ""


def _fmt_tip(t):
    return " / ".join(f"{v:.5g}" for v in t[:6]) + (" …" if len(t) > 6 else "")


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--base", help="the base revision (A); the working tree is B")
    p.add_argument("--cases", nargs="+", default=list(CASES), choices=CASES)
    p.add_argument("--repeats", type=int, default=2)
    p.add_argument("--out", default=os.path.join(BENCH, "results", "ab.md"))
    p.add_argument("--all-cores", action="store_true", help="do not pin the runs to one core")
    p.add_argument("--worker", nargs="+", choices=CASES, help=argparse.SUPPRESS)
    a = p.parse_args(argv)
    if a.worker:
        worker(a.worker)
        return 0
    if not a.base:
        p.error("--base REV is required")
    if not a.all_cores and hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})  # the subprocesses inherit it

    sha = subprocess.run(["git", "rev-parse", "--verify", f"{a.base}^{{commit}}"], cwd=TREE, capture_output=True,
                         text=True, check=True).stdout.strip()
    dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=TREE, capture_output=True,
                           text=True).stdout.strip()
    base_dir = tempfile.mkdtemp(prefix="ab_base_")
    os.rmdir(base_dir)
    subprocess.run(["git", "worktree", "add", "--detach", base_dir, sha], cwd=TREE, check=True, capture_output=True)
    trees = {"A": base_dir, "B": TREE}
    runs = {(c, r): [] for c in a.cases for r in trees}
    # The cases on the RNCF model and its NR-RNCF basis share one subprocess; ANCF runs in its own,
    # and the pendulums in a third.
    groups = [g for g in ([c for c in CASES if c in a.cases and c != "ancf" and c not in PENDULUM_GROUP],
                          ["ancf"] if "ancf" in a.cases else [], [c for c in PENDULUM_GROUP if c in a.cases]) if g]
    t_start = time.perf_counter()
    load0 = os.getloadavg()[0]
    try:
        for rep in range(a.repeats):
            order = ("A", "B") if rep % 2 == 0 else ("B", "A")
            for group in groups:
                for rev in order:
                    _log(f"[{time.perf_counter() - t_start:5.0f} s] repeat {rep + 1}: {' '.join(group)} on {rev} ...")
                    for case, d in _run_group(group, trees[rev]).items():
                        runs[(case, rev)].append(d)
    finally:
        subprocess.run(["git", "worktree", "remove", "--force", base_dir], cwd=TREE, capture_output=True)
    total = time.perf_counter() - t_start
    load1 = os.getloadavg()[0]

    sys.path.insert(0, BENCH)
    import jax  # noqa: F401  (the machine line names the JAX version)
    from _machine import machine, report

    head = ("case", "rev", "steps", "rejected", "Newton it.", "χ_rel [%] / gradient",
            "tip extremes ux, uy, uz min / max [m]", "compile [s]", "run [s] (best; all)", "max rel. diff A/B",
            "run B/A")
    lines = ["| " + " | ".join(head) + " |", "|---|---|" + "---:|" * 4 + "---|" + "---:|" * 4]
    failed, notes = [], []
    for case in a.cases:
        A, B = runs[(case, "A")], runs[(case, "B")]
        diff, where, unequal = _rel_diff(A[0]["results"], B[0]["results"])
        for rev, rr in (("A", A), ("B", B)):
            for other in rr[1:]:  # each revision must repeat itself exactly
                d, _, u = _rel_diff(rr[0]["results"], other["results"])
                if d or u:
                    notes.append(f"- {case}: revision {rev} is not deterministic between repeats "
                                 f"(max rel. diff {d:.1e}, unequal {u})")
        bad = diff > TOL or unequal
        if bad:
            failed.append(case)
        best = {rev: min(x["run_s"] for x in rr) for rev, rr in (("A", A), ("B", B))}
        for rev, rr in (("A", A), ("B", B)):
            res = rr[0]["results"]
            chi = f"{res['chi_rel']:.6g}" if "chi_rel" in res else ("" if "grad" not in res else
                                                                 f"{res['grad']:.10g}")
            cells = (case if rev == "A" else "", rev, res["steps"], res["rejected"], res["newton"], chi,
                     _fmt_tip(res["tip"]), f"{min(x['compile_s'] for x in rr):.2f}",
                     f"{best[rev]:.3f}; " + ", ".join(f"{x['run_s']:.3f}" for x in rr),
                     "" if rev == "A" else (f"**{diff:.1e}**" if bad else f"{diff:.1e}")
                     + (f" ({where})" if diff else "") + (f"; unequal: {', '.join(unequal)}" if unequal else ""),
                     "" if rev == "A" else f"{best['B'] / best['A']:.2f}" + _speed(A, B))
            lines.append("| " + " | ".join(str(c) for c in cells) + " |")
        for rev, rr in (("A", A), ("B", B)):
            extra = rr[0].get("extra") or {}
            if "member_steps" in rr[0]["results"]:
                extra = {**extra, "member steps": rr[0]["results"]["member_steps"]}
            if "dofs" in rr[0]["results"]:
                extra = {**extra, "reduced DOFs": rr[0]["results"]["dofs"]}
            if extra:
                notes.append(f"- {case}, {rev}: " + ", ".join(
                    f"{k} {v:.2f}" if isinstance(v, float) else f"{k} {v}" for k, v in extra.items()))

    verdict = ("**Results differ** beyond " f"{TOL:g} relative (or in step counts) in: {', '.join(failed)}."
               if failed else f"All results equal: the same step counts, and floats within {TOL:g} relative.")
    text = "\n".join([
        f"# A/B: base {a.base} ({sha[:10]}) against the working tree", "",
        f"Produced by `benchmarks/investigations/ab.py --base {a.base}`. Machine: {machine()} "
        f"(load average {load0:.1f} at the "
        f"start, {load1:.1f} at the end; {total:.0f} s in all).", "",
        "A = the base revision (a `git worktree` of it), B = the working tree"
        + (" (with uncommitted changes to tracked files)" if dirty else "") + f". Each case ran {a.repeats} times "
        "per revision, each run in its own subprocess, alternating A B / B A; compile and run are the best of the "
        "repeats (all run times listed). Max rel. diff: the largest relative difference of the results (tip "
        "extremes relative to the case's largest, χ_rel, gradient); step, rejection and Newton counts must be "
        "equal.", "",
        *lines, "",
        verdict, "",
        *(["Notes:", "", *notes, ""] if notes else []),
        "Cases: " + "; ".join(f"`{c}`" for c in a.cases) + " (see the docstring of "
        "`benchmarks/investigations/ab.py`). Run B/A "
        "is the ratio of the best run times; 'beyond noise' where every run of one revision was faster than every "
        "run of the other. This is a shared 2-core machine: repeat runs of one revision differ by the spread "
        "listed.", "",
    ])
    report(text, a.out)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
