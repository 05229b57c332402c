"""The error estimate of a reduced mechanism's run (``multibody.error_estimate``) against the χ_rel
measured with the full run: the paper's three-beam pendulum.

    python benchmarks/error_estimate_mechanism.py [--t-ends 0.5 2] [--samples 16 41]
                                                  [--out benchmarks/results/error_estimate_mechanism.md]

The pendulum on the paper's 10-element mesh, rtol 1e-4, outputs every 0.01 s: the ANCF run (the
reference, as in ``pendulum.md``) and the NR-RNCF runs with the paper's basis (5 VMs + 15 MDs a
beam), the VMs alone, the joint's static modes added, and the extended Craig-Bampton basis; each
reduced run's estimate (``run_pendulum(estimator=...)``) over 0-t_end for each t_end: the static
correction at each number of samples, and the linearised error equation integrated over every
output (``method="dynamic"``), whose χ_rel runs over the outputs up to where its linearisation
held (``valid_until``). Columns: DOFs, the window the estimate covers, χ_rel measured over that
window, the estimate, the effectivity (estimate / measured), the estimate's run time against the
reduced run's. Then, for the paper's basis over the longest window, the error at each output
time (every 0.1 s): both estimates and the measured distance of all nodes from the ANCF run. One
core.
"""

import argparse
import os
import sys

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

from nrrncf_jax.post.metrics import chi_rel  # noqa: E402
from nrrncf_jax.reduction import ErrorEstimator  # noqa: E402
from nrrncf_jax.scenarios.pendulum import PendulumBasis, PendulumSpec, run_pendulum  # noqa: E402

sys.path.insert(0, os.path.dirname(__file__))
from _machine import machine, pin_to_one_core, report  # noqa: E402

BASES = {
    "5 VMs + 15 MDs (the paper's)": PendulumBasis(pairs="all"),
    "5 VMs alone": PendulumBasis(pairs=()),
    "5 VMs + 15 MDs + 2 joint modes": PendulumBasis(pairs="all", joint_modes=True),
    "extended Craig-Bampton (2 boundary + 5 VMs + 15 MDs + the constraint modes' MDs)":
        PendulumBasis(pairs="all", craig_bampton=True),
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--t-ends", type=float, nargs="+", default=[0.5, 2.0])
    ap.add_argument("--samples", type=int, nargs="+", default=[16, 41])
    ap.add_argument("--out", default="benchmarks/results/error_estimate_mechanism.md")
    args = ap.parse_args()
    pin_to_one_core()
    spec = PendulumSpec()
    rows, profile = [], {}
    for t_end in args.t_ends:
        ref = run_pendulum(spec, t_end=t_end, dt_out=0.01)
        for name, basis in BASES.items():
            for method, n in [("static", n) for n in args.samples] + [("dynamic", None)]:
                red = run_pendulum(spec, t_end=t_end, dt_out=0.01, formulation="nr-rncf", basis=basis,
                                   estimator=ErrorEstimator(method=method, samples=n or 2))
                e = red.estimate
                k = len(red.ts) if e.valid_until is None else int(np.searchsorted(red.ts, e.valid_until)) + 1
                measured = float(chi_rel(ref.nodes[:k] - ref.nodes[0], red.nodes[:k] - red.nodes[0]))
                label = f"static, {n} samples" if method == "static" else "dynamic"
                rows.append(f"| 0-{t_end:g} | {name} | {red.dofs} | {label} | 0-{red.ts[k - 1]:.2f} | {measured:.3f} | "
                            f"{e.chi_rel_percent:.3f} | {e.chi_rel_percent / measured:.2f} | {e.run_s:.3f} | "
                            f"{red.run_s:.3f} | {e.run_s / red.run_s:.2f} |")
                print(rows[-1], flush=True)
                if t_end == max(args.t_ends) and basis == BASES[next(iter(BASES))] and n in (None, max(args.samples)):
                    d = np.linalg.norm((red.nodes - ref.nodes).reshape(len(red.ts), -1), axis=1)
                    profile[method] = (e, d, red.ts)
    lines = []
    if len(profile) == 2:
        (es, d, ts), (ed, _, _) = profile["static"], profile["dynamic"]
        for t in np.arange(0.0, ts[-1] + 1e-9, 0.1):
            i = int(np.argmin(np.abs(ts - t)))
            j = int(np.argmin(np.abs(es.ts - t)))
            static = f"{es.error_norm[j]:.4f} (at {es.ts[j]:.2f})"
            dynamic = f"{ed.error_norm[i]:.4f}" if ed.valid_until is None or ts[i] <= ed.valid_until else \
                f"{ed.error_norm[i]:.1e} (past its validity)"
            lines.append(f"| {ts[i]:.2f} | {static} | {dynamic} | {d[i]:.4f} |")
    text = "\n".join([
        "# The error estimate of a reduced mechanism: the three-beam pendulum",
        "",
        f"Produced by `benchmarks/error_estimate_mechanism.py`. Machine: {machine()}.",
        "",
        "The paper's pendulum (10 elements a beam, rtol 1e-4, outputs every 0.01 s), each NR-RNCF run's "
        "estimate from the run alone (`multibody.error_estimate`, against the full-order RNCF counterpart: static, "
        "each beam's quasi-static correction in its frame at sampled times; dynamic, the linearised error equation "
        "of the whole mechanism integrated over the outputs, up to where its linearisation held) and χ_rel measured "
        "against the ANCF run over the window the estimate covers. Times: the compiled estimate's and the reduced "
        "run's [s].",
        "",
        "| run [s] | basis a beam | DOFs | estimate | window [s] | χ_rel measured [%] | estimate [%] | effectivity | "
        "estimate run [s] | reduced run [s] | ratio |",
        "|---|---|---:|---|---|---:|---:|---:|---:|---:|---:|",
        *rows,
        "",
        "The paper's basis over the longest run, every 0.1 s: the static estimate at its nearest sample, the "
        "error equation's |δx(t)|, and the measured distance of all nodes from the ANCF run |x(t) − x_ANCF(t)| [m].",
        "",
        "| t [s] | static [m] | dynamic [m] | measured [m] |",
        "|---:|---:|---:|---:|",
        *lines,
    ])
    report(text, args.out, keep_notes="## Notes")


if __name__ == "__main__":
    main()
