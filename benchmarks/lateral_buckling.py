"""The dynamic lateral buckling of the validation set (Bauchau et al. 2016, problem (c);
``examples/lateral_buckling.py``) over 0-0.8 s: full order (ANCF) on 2, 4 and 8 beam elements (and
4 at a tenfold tighter step tolerance, to tell the time-integration error from the mesh's), and
reduced (NR-RNCF) on 4.

For each run: DOFs, steps (rejected), compile and run seconds (``run_setup``: ahead-of-time
compilation, then a blocked run; one core pinned); when the beam leaves its plane (the first
output time at which |mid_y| > 1 mm) and the link's compression then; the mid-span's sideways
displacement and the tip's twist at a few times; their peaks while the crank turns (0-0.4 s) and
while it is held (0.4-0.8 s); and the largest differences from the finest full-order run. A figure
of the tip's vertical displacement, the mid-span's sideways one and the tip's twist over time
(``results/figures/lateral_buckling.png``).

    python benchmarks/lateral_buckling.py  ->  benchmarks/results/lateral_buckling.md
"""

import os
import sys

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _machine import machine, pin_to_one_core, report  # noqa: E402

from nrrncf_jax.examples.lateral_buckling import IMPERFECTION, prandtl_load  # noqa: E402
from nrrncf_jax.scenarios.mechanism_file import load_setup, run_setup  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
CASES = [  # (label, parameters of examples/lateral_buckling.py, rtol); the reference is REF
    ("ANCF", {"elements": 2}, 1e-4), ("ANCF", {"elements": 4}, 1e-4), ("ANCF", {"elements": 8}, 1e-4),
    ("ANCF", {"elements": 4}, 1e-5),
    ("NR-RNCF, 3 VMs + force and moment attachment modes + all their MDs + every section's own modes "
     "(the default)", {"formulation": "nr-rncf", "elements": 4}, 1e-4),
    ("NR-RNCF, 1 VM + force and moment attachment modes + all their MDs",
     {"formulation": "nr-rncf", "elements": 4, "vms": 1, "interface_sections": False}, 1e-4),
]
REF = 2
TIMES = (0.1, 0.15, 0.2, 0.3, 0.5, 0.8)
N_OUT = 161  # every 5 ms


def _at(run, name, t):
    return float(np.interp(t, run.ts, run.series[name]))


def _peak(run, name, t0, t1):
    inside = (run.ts >= t0) & (run.ts <= t1)
    return float(np.abs(run.series[name][inside]).max())


def _onset(run):
    """The first output time at which |mid_y| exceeds 1 mm, and the link's compression then."""
    k = int(np.argmax(np.abs(run.series["mid_y"]) > 1e-3))
    return run.ts[k], -run.series["link_N"][k]


def _figure(runs, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(3, 1, figsize=(7, 7.5), sharex=True)
    for (label, params, rtol), run in runs:
        name = f"{label.split(',')[0]}, {params['elements']} el., rtol {rtol:g}"
        for ax, key, scale in zip(axes, ("tip_z", "mid_y", "tip_twist"), (1e3, 1e3, 1.0)):
            ax.plot(run.ts, run.series[key] * scale, lw=1, label=name)
    for ax, text in zip(axes, ("tip vertical [mm]", "mid-span sideways [mm]", "tip twist [rad]")):
        ax.set_ylabel(text)
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("t [s]")
    axes[0].legend(fontsize=7)
    fig.suptitle("Lateral buckling (Bauchau et al. 2016, problem c)", fontsize=10)
    fig.tight_layout()
    os.makedirs(os.path.dirname(path), exist_ok=True)
    fig.savefig(path, dpi=110)


def main() -> None:
    pin_to_one_core()
    runs = []
    for label, params, rtol in CASES:
        setup = load_setup("lateral_buckling", params)
        run = run_setup(setup, n_out=N_OUT, controller=setup.controller(rtol))
        runs.append(((label, params, rtol), run))
        print(label, params, rtol, run.summary(), flush=True)
    ref = runs[REF][1]
    head = ("| model | beam elements | rtol | DOFs | steps (rejected) | compile [s] | run [s] | "
            "leaves the plane at [s] | link compression then [kN] | peak abs mid_y 0-0.4 s [mm] | "
            "peak abs tip twist 0-0.4 s [rad] | "
            "peak abs mid_y 0.4-0.8 s [mm] | peak abs tip twist 0.4-0.8 s [rad] | max abs Δmid_y vs ref [mm] | "
            "max abs Δtwist vs ref [rad] |")
    rows = [head, "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for k, ((label, params, rtol), run) in enumerate(runs):
        t_on, P_on = _onset(run)
        d_y = np.abs(run.series["mid_y"] - ref.series["mid_y"]).max() * 1e3
        d_tw = np.abs(run.series["tip_twist"] - ref.series["tip_twist"]).max()
        rows.append(f"| {label}{' (ref)' if k == REF else ''} | {params['elements']} | {rtol:g} | {run.dofs} | "
                    f"{run.steps} ({run.rejected}) | {run.compile_s:.1f} | {run.run_s:.1f} | {t_on:.3f} | "
                    f"{P_on / 1e3:.2f} | {_peak(run, 'mid_y', 0, 0.4) * 1e3:.2f} | "
                    f"{_peak(run, 'tip_twist', 0, 0.4):.4f} | {_peak(run, 'mid_y', 0.4, 0.8) * 1e3:.2f} | "
                    f"{_peak(run, 'tip_twist', 0.4, 0.8):.4f} | {d_y:.2f} | {d_tw:.4f} |")
    times = ["| model | beam elements | rtol | " + " | ".join(f"mid_y({t:g} s) [mm]" for t in TIMES) + " | "
             + " | ".join(f"tip twist({t:g} s) [rad]" for t in TIMES) + " | "
             + " | ".join(f"tip_z({t:g} s) [mm]" for t in (0.2, 0.8)) + " |",
             "|---|---:|---:|" + "---:|" * (2 * len(TIMES) + 2)]
    for (label, params, rtol), run in runs:
        times.append(f"| {label.split(',')[0]} | {params['elements']} | {rtol:g} | "
                     + " | ".join(f"{_at(run, 'mid_y', t) * 1e3:.3f}" for t in TIMES) + " | "
                     + " | ".join(f"{_at(run, 'tip_twist', t):.4f}" for t in TIMES) + " | "
                     + " | ".join(f"{_at(run, 'tip_z', t) * 1e3:.3f}" for t in (0.2, 0.8)) + " |")
    figure = os.path.join(HERE, "results", "figures", "lateral_buckling.png")
    _figure(runs, figure)
    text = "\n".join([
        "# Dynamic lateral buckling (validation set, problem c)", "",
        "Written by `benchmarks/lateral_buckling.py` (`examples/lateral_buckling.py`: the beam, link and crank of "
        "MBDyn's deck, C offset from the tip by "
        f"{IMPERFECTION * 1e3:g} mm, the crank turned by π along a half cosine over 0.4 s and held; ρ∞ = 0.5). "
        f"Prandtl's critical load {prandtl_load() / 1e3:.3f} kN. Link and crank: 2 and 1 elements in every run. "
        f"Reference (Δ columns): row {REF + 1}.", "",
        f"{machine()}.", "",
        "\n".join(rows), "",
        "Values at a few times (linear interpolation between outputs every 5 ms):", "",
        "\n".join(times), "",
        "![tip and mid-span over time](figures/lateral_buckling.png)", ""])
    report(text, os.path.join(HERE, "results", "lateral_buckling.md"), keep_notes="## Notes")


if __name__ == "__main__":
    main()
