"""ANCF vs RNCF full-order spin-up of the paper beam (paper Tables 2-3 sizes).

    python benchmarks/spinup_full.py [--speeds 4 10 20 40] [--t-end 30] [--out benchmarks/results/spinup_full.md]

For each ωs: DOFs, accepted/rejected steps, Newton iterations, compile and run time (measured
apart, ahead-of-time compilation then a blocked run), tip extremes, and χ_rel (Eq. 40) of ANCF
against RNCF on the tip displacement and on all nodal displacements q − q̂ (rotating frame).
"""

import argparse
import sys

import jax

jax.config.update("jax_enable_x64", True)

from _machine import machine  # noqa: E402

from nrrncf_jax import chi_rel  # noqa: E402
from nrrncf_jax.integrate import AdaptiveStepSize  # noqa: E402
from nrrncf_jax.scenarios import run_spinup  # noqa: E402
from nrrncf_jax.scenarios.spinup import default_elements  # noqa: E402


def main(argv=None):
    p = argparse.ArgumentParser()
    p.add_argument("--speeds", type=float, nargs="+", default=[4.0, 10.0, 20.0, 40.0])
    p.add_argument("--t-end", type=float, default=30.0)
    p.add_argument("--rtol", type=float, default=1e-4)
    p.add_argument("--out", default="benchmarks/results/spinup_full.md")
    a = p.parse_args(argv)

    rows = []
    for w in a.speeds:
        n_el = default_elements(w)
        res = {}
        for form in ("rncf", "ancf"):
            print(f"omega_s = {w:g}: {form.upper()} ({n_el} elements) ...", file=sys.stderr, flush=True)
            res[form] = run_spinup(form, "paper", w, T_s=15.0, t_end=a.t_end, elements=n_el,
                                   controller=AdaptiveStepSize(a.rtol, 1e-6), save_displacements=True, progress=True)
        r, an = res["rncf"], res["ancf"]
        chi_tip = float(chi_rel(r.tip, an.tip))
        chi_all = float(chi_rel(r.displacements, an.displacements))
        for form, x in res.items():
            rows.append((f"{w:g}", form.upper(), n_el, x.dofs, x.steps, x.rejected, x.newton_iters,
                         f"{x.compile_s:.1f}", f"{x.run_s:.2f}", f"{x.tip[:, 1].min():.4f}", f"{x.tip[:, 1].max():.4f}",
                         f"{x.tip[:, 0].min():.4f}", "(ref)" if form == "rncf" else f"{chi_tip:.3f} / {chi_all:.3f}"))
        rows.append((f"{w:g}", "ANCF/RNCF", "", "", "", "", "", "", f"{an.run_s / r.run_s:.1f}x", "", "", "", ""))

    head = ("ωs [rad/s]", "model", "elements", "DOFs", "steps", "rejected", "Newton it.", "compile [s]", "run [s]",
            "tip uy min [m]", "tip uy max [m]", "tip ux min [m]", "χ_rel % tip / all")
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    text = (f"# Full-order spin-up, paper beam (T_s = 15 s, 0-{a.t_end:g} s, rtol = {a.rtol:g}, ρ∞ = 0.9)\n\n"
            f"Machine: {machine()}\n\n" + "\n".join(lines) + "\n\n"
            "χ_rel: Eq. 40 of ANCF against RNCF, on the tip displacement and on all nodal displacements "
            "q − q̂ in the rotating frame, sampled every 0.01 s.\n")
    print(text)
    with open(a.out, "w") as f:
        f.write(text)


if __name__ == "__main__":
    main()
