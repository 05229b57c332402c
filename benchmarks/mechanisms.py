"""The three mechanisms of issue 33 (``nrrncf_jax/examples/``):

- ``slider_crank``: full ANCF and NR-RNCF at the example's defaults and under tolerance and mesh
  refinement, rigid as the closed-form check (``results/mechanisms.md``). Each row: DOFs, steps
  (rejected), Newton iterations, compile and run seconds (ahead-of-time compilation, then a
  blocked run), the peak |w_mid| and x_B at 0.1 s, and their differences from the reference row
  (ANCF, 8 elements, rtol 1e-5); χ_rel (Eq. 40) of w_mid against that reference.
- ``rotor``: full ANCF and NR-RNCF, the momentum and energy balances and χ_rel of the hub's speed
  and a tip's deflection against the ANCF run at rtol 1e-5 (``results/mechanisms_rotor.md``).
- ``arm``: the two-link arm's trajectory optimisation on the reduced model, and the optimised
  trajectory checked on the full ANCF model with adaptive steps (``results/mechanisms_arm.md``).

    python benchmarks/mechanisms.py [--case slider_crank|rotor|arm|all]
"""

import argparse
import os
import platform
import sys

import jax
import numpy as np

jax.config.update("jax_enable_x64", True)

from nrrncf_jax.post.metrics import chi_rel  # noqa: E402
from nrrncf_jax.scenarios.mechanism_file import load_setup, run_setup  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
NODES = {"error_on": "nodes"}  # the step error on every nodal vector, with plain step control (``slider_crank``)
CASES = [  # (label, load_setup parameters, rtol, fixed step or None, run_setup options); the first is the reference
    ("ANCF, 8 elements", {"formulation": "ancf"}, 1e-6, None, NODES),
    ("ANCF, 12 elements", {"formulation": "ancf", "elements": 12}, 1e-5, None, NODES),
    ("ANCF, 8 elements", {"formulation": "ancf"}, 1e-4, None, NODES),
    ("ANCF, 8 elements", {"formulation": "ancf"}, 1e-3, None, NODES),
    ("ANCF, 8 elements", {"formulation": "ancf"}, 2e-5, None, {}),
    ("NR-RNCF pinned, 1 VM + 1 MD (default)", {"formulation": "nr-rncf"}, 2e-5, None, {}),
    ("NR-RNCF pinned, 1 VM + 1 MD", {"formulation": "nr-rncf"}, 1e-4, None, NODES),
    ("NR-RNCF pinned, 1 VM + 1 MD", {"formulation": "nr-rncf"}, 1e-4, 2e-4, {}),
    ("NR-RNCF pinned, 2 VMs + 3 MDs", {"formulation": "nr-rncf", "vms": 2}, 2e-5, None, {}),
    ("NR-RNCF cantilever, 4 VMs + 10 MDs", {"formulation": "nr-rncf", "vms": 4, "conditions": "clamped"}, 2e-5, None,
     {}),
    ("NR-RNCF cantilever, 2 VMs + 3 MDs", {"formulation": "nr-rncf", "vms": 2, "conditions": "clamped"}, 2e-5, None,
     {}),
    ("NR-RNCF Craig-Bampton, 1 VM", {"formulation": "nr-rncf", "basis": "craig-bampton"}, 2e-5, None, {}),
    ("NR-RNCF Craig-Bampton, 2 VMs", {"formulation": "nr-rncf", "basis": "craig-bampton", "vms": 2}, 2e-5, None, {}),
    ("rigid", {"formulation": "rigid"}, 1e-4, None, NODES),
]


def _write(out: str, text: str, notes_from: str) -> None:
    """Write ``text`` to ``out``, keeping the notes that follow the tables in the old file (from
    the first line starting with ``notes_from``): they are written by hand from the figures."""
    notes = ""
    if os.path.exists(out):
        with open(out) as f:
            old = f.read()
        at = old.find("\n" + notes_from)
        notes = old[at:] if at >= 0 else ""
    with open(out, "w") as f:
        f.write(text + notes)


def _machine() -> str:
    return (f"Machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores visible, JAX "
            f"{jax.__version__} on CPU, Python {sys.version.split()[0]}.")


def rotor(out: str) -> None:
    from scipy.integrate import cumulative_simpson

    from nrrncf_jax.examples.rotor import impulse

    rows, ref, times = [], None, {}
    for formulation, rtol in (("ancf", 1e-5), ("ancf", 1e-4), ("nr-rncf", 1e-5), ("nr-rncf", 1e-4)):
        setup = load_setup("rotor", {"formulation": formulation})
        run = run_setup(setup, n_out=401, controller=setup.controller(rtol))
        ref = run if ref is None else ref
        s, ts = run.series, run.ts
        H = impulse(ts, setup.info["torque"], setup.info["spin_time"])
        W = cumulative_simpson(s["power"], x=ts, initial=0.0)
        dH = np.abs(s["H_z"] - H).max() / H[-1]
        dE = np.abs(s["energy"] - s["energy"][0] - W).max() / W[-1]
        times[(formulation, rtol)] = run.run_s
        speedup = "" if formulation == "ancf" else f"{times[('ancf', rtol)] / run.run_s:.1f}"
        rows.append(f"| {formulation} | {rtol:g} | {run.dofs} | {run.steps} ({run.rejected}) | {run.newton_iters} | "
                    f"{run.compile_s:.1f} | {run.run_s:.2f} | {speedup} | {s['omega'][-1]:.5f} | "
                    f"{np.abs(s['tip']).max():.4f} | {dH:.1e} | {dE:.1e} | "
                    f"{float(chi_rel(ref.series['omega'], s['omega'])):.2f} | "
                    f"{float(chi_rel(ref.series['tip'], s['tip'])):.2f} | {np.abs(s['M_root']).max():.1f} | "
                    f"{float(chi_rel(ref.series['M_root'], s['M_root'])):.2f} |")
        print(rows[-1], flush=True)
    text = "\n".join([
        "# Mechanisms: the torque-driven rotor (issue 33)", "", f"Produced by `benchmarks/mechanisms.py --case rotor`. "
        f"{_machine()}", "",
        "Rigid hub (0.5 kg m² about Z, radius 0.5 m) on a hinge to the ground; three paper beams (L = 8 m aluminium "
        "tubes, 8 C1 elements each) clamped at 120°; motor torque τ₀ (1 − cos 2πt/T)/2, τ₀ = 2000 N m, T = 2 s, then "
        "zero; 0-4 s, generalized-α ρ∞ = 0.9. NR-RNCF: each beam in its frame at the root, 4 in-plane cantilever modes "
        "and their modal derivatives, welded to the hub. ΔH: max |H_z − impulse| / final impulse; ΔE: max |E − E₀ − "
        "W| / final work (W by Simpson's rule on 401 outputs). χ_rel against the first row. Speed-up: ANCF run time "
        "at the same rtol over the row's. M_root: beam 0's root bending moment "
        "(`post.stress.SectionResultant`, M3).", "",
        "| beams | rtol | DOFs | steps (rejected) | Newton it. | compile [s] | run [s] | speed-up | ω(4 s) [rad/s] | "
        "peak abs tip [m] | ΔH | ΔE | χ_rel ω [%] | χ_rel tip [%] | peak abs M_root [N m] | χ_rel M_root [%] |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|", *rows, ""])
    _write(out, text, "Reading:")


def arm(out: str, steps: int = 40, refine_steps: int = 25) -> None:
    from nrrncf_jax.examples.two_link_arm import mechanism, optimise_trajectory

    setup = mechanism("nr-rncf", elements=4)
    opt = optimise_trajectory(setup, steps=steps, learning_rate=0.01)
    # the reduced model's optimum refined on the full model (its residual is a few per cent of the
    # initial one, where the reduced model's own error shows)
    full = optimise_trajectory(mechanism("ancf", elements=4), steps=refine_steps, learning_rate=0.003,
                               coeffs=opt.final)
    target = np.asarray(setup.info["target"])
    rows = []
    for label, coeffs in (("initial", opt.initial), ("optimised (reduced)", opt.final),
                          ("refined (full)", full.final)):
        for formulation in ("nr-rncf", "ancf"):
            run = run_setup(mechanism(formulation, elements=4, coeffs=coeffs), n_out=321)
            after = run.ts >= setup.info["move_time"] - 1e-12
            amp = np.sqrt(np.sum((run.series["tip"] - target) ** 2, axis=1))[after].max()
            rows.append(f"| {label} | {formulation} | {run.dofs} | {run.steps} ({run.rejected}) | {run.run_s:.2f} | "
                        f"{1e3 * amp:.3f} | {np.abs(run.series['torque_1']).max():.2f} | "
                        f"{np.abs(run.series['torque_2']).max():.2f} |")
            print(rows[-1], flush=True)
    text = "\n".join([
        "# Mechanisms: the flexible two-link arm's trajectory optimisation (issue 33)", "",
        f"Produced by `benchmarks/mechanisms.py --case arm`. {_machine()}", "",
        "Two aluminium links, 1 m, solid circle r = 10 mm, 4 C1 elements each, a 0.1 kg payload at the tip; the "
        "hinges move by 90° and 60° in T = 1 s (`motion.RestToRest`, 3 correction coefficients each), 0-1.6 s, "
        "ρ∞ = 0.5. Objective: mean over t ≥ T of |x_tip − x*|², on the reduced model (3 in-plane modes and their "
        "derivatives a link) with constant steps 2 ms, gradients by forward mode through the simulation; Adam "
        f"(optax), learning rate 0.01, {steps} steps, the best iterate kept.", "",
        f"Optimisation: {opt.seconds:.0f} s for {len(opt.history)} objective-and-gradient evaluations (each one run "
        f"with 6 tangents; compile included); objective {opt.history[0]:.3e} → {min(opt.history):.3e} m²; residual "
        f"amplitude max_(t≥T) |x_tip − x*| {1e3 * opt.amplitude_initial:.3f} → {1e3 * opt.amplitude_final:.3f} mm "
        f"({opt.reduction:.1f}× smaller). Coefficients found [rad]: {np.round(opt.final, 5).tolist()}.", "",
        f"Refined on the full ANCF model (183 DOFs, constant steps 2 ms), from the reduced optimum: Adam, learning "
        f"rate 0.003, {refine_steps} steps, {full.seconds:.0f} s; objective {full.history[0]:.3e} → "
        f"{min(full.history):.3e} m²; coefficients [rad]: {np.round(full.final, 5).tolist()}.", "",
        "The trajectories rerun with adaptive steps (rtol 1e-5), reduced and full ANCF (the first two "
        "trajectories were optimised on the reduced model only):", "",
        "| trajectory | links | DOFs | steps (rejected) | run [s] | residual amplitude [mm] | peak abs τ₁ [N m] | "
        "peak abs τ₂ [N m] |", "|---|---|---:|---:|---:|---:|---:|---:|", *rows, ""])
    _write(out, text, "Reading:")


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--case", choices=["slider_crank", "rotor", "arm", "all"], default="all")
    args = p.parse_args(argv)
    if args.case in ("rotor", "all"):
        rotor(os.path.join(HERE, "results", "mechanisms_rotor.md"))
    if args.case in ("arm", "all"):
        arm(os.path.join(HERE, "results", "mechanisms_arm.md"))
    if args.case in ("slider_crank", "all"):
        slider_crank(os.path.join(HERE, "results", "mechanisms.md"))


def slider_crank(out: str) -> None:
    rows, ref = [], None
    for label, params, rtol, dt, options in CASES:
        setup = load_setup("slider_crank", params)  # NODES: plain step control; else the model's (PI)
        controller = setup.controller(rtol, dt, "plain" if options else None)
        run = run_setup(setup, n_out=401, controller=controller, **options)
        if ref is None:
            ref = run
        w, wr = run.series["w_mid"], ref.series["w_mid"]
        attempted = run.steps + run.rejected
        control = "nodal vectors, plain" if options else "sensors w_mid, x_B; PI"
        rows.append(f"| {label} | {run.dofs} | {rtol:g} | {'adaptive' if dt is None else f'h = {dt:g}'} | "
                    f"{control if dt is None else '–'} | "
                    f"{run.steps} ({run.rejected}) | {run.newton_iters} | {run.compile_s:.1f} | {run.run_s:.3f} | "
                    f"{1e6 * run.run_s / attempted:.0f} | {1e3 * np.abs(w).max():.3f} | {run.series['x_B'][-1]:.6f} | "
                    f"{float(chi_rel(wr, w)):.2f} |")
        print(rows[-1], flush=True)
    text = "\n".join([
        "# Mechanisms: the flexible slider-crank", "",
        f"Produced by `benchmarks/mechanisms.py --case slider_crank`. {_machine()}", "",
        "Crank 0.152 m rigid, driven at 150 rad/s; rod 0.304 m, E = 1e10 Pa, solid circle r = 5 mm; slider 0.033 kg; "
        "0-0.1 s, rigid-mechanism initial velocities; generalized-α ρ∞ = 0.5, atol = rtol/10 m (adaptive) or fixed "
        "steps h (rtol then Newton's test only). Step error: on every nodal vector with the plain controller, or "
        "on the sensors w_mid and x_B (`error_on`, `Mechanism.observed_error`) with Gustafsson's PI controller, "
        "the example's default. Bases (`multibody.reduce`, in-plane): *pinned*, the rod's frame "
        "along the chord between its pins, simply supported modes; *cantilever*, the frame clamped at the crank "
        "pin; *Craig-Bampton*, clamped at the crank pin with the slider pin's in-plane position as boundary "
        "coordinates, fixed-interface modes and the modal derivatives of both. Each row is one `load_setup` + "
        "`run_setup` (ahead-of-time compile, then one blocked run). µs a step: run time over attempted steps. "
        "Reference row: the first (ANCF, 8 elements, rtol 1e-6: within 0.02 % of the run at 1e-7, "
        "`work_precision.md`).", "",
        "| rod | DOFs | rtol | steps | step error, controller | accepted (rejected) | Newton it. | compile [s] | "
        "run [s] | µs a step | "
        "peak abs w_mid [mm] | x_B(0.1 s) [m] | χ_rel w_mid [%] |",
        "|---|---:|---:|---|---|---:|---:|---:|---:|---:|---:|---:|---:|", *rows, ""])
    _write(out, text, "**Notes")


if __name__ == "__main__":
    main()
