"""Reference conditions of a reduced body (issue 60): clamped, pinned and mean-axis
(``multibody.reduce(..., conditions=...)``) at equal numbers of vibration modes, on the flexible
slider-crank (``examples/slider_crank.py``, measured as ``benchmarks/mechanisms.py`` measures it)
and on the paper's three-beam pendulum (``scenarios.pendulum``).

    taskset -c 1 python benchmarks/reference_conditions.py [--case slider_crank|pendulum|all]
        [--vms 1 2 3 4] [--pendulum-vms 3 5] [--t-end 2] [--out benchmarks/results/reference_conditions.md]

Slider-crank: each row one ``mechanism(formulation="nr-rncf", vms=n, conditions=c)`` (in-plane
modes and all their modal derivatives, the example's run settings: rtol 2e-5, the step error on the
sensors w_mid and x_B, PI control, ρ∞ = 0.5), run with ``run_setup`` (ahead-of-time compilation,
then one blocked run); χ_rel (Eq. 40) of w_mid and x_B against the full ANCF rod (8 elements, rtol
1e-6, the step error on every nodal vector: ``mechanisms.md``'s reference row). Two more rows give
the rod's joints' loads their own modes: the attachment modes of forces on the pins (inertia-relief
ones for mean-axis, ``interface_modes``) with the modal derivatives of the transverse ones
(``interface_mds=("fy",)``). Pendulum: each beam reduced alike (its in-plane modes and all their
MDs), at rtol 1e-4 against the full ANCF pendulum on the same mesh and tolerance, χ_rel over every
node's displacement (``benchmarks/pendulum.py``'s measure).
"""

import argparse
import contextlib
import functools
import os
import sys
import time

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402
from _machine import machine, report  # noqa: E402

from nrrncf_jax.examples import slider_crank  # noqa: E402
from nrrncf_jax.integrate import AdaptiveStepSize  # noqa: E402
from nrrncf_jax.post.metrics import chi_rel  # noqa: E402
from nrrncf_jax.scenarios.mechanism_file import run_setup  # noqa: E402
from nrrncf_jax.scenarios.pendulum import (  # noqa: E402
    PendulumBasis,
    PendulumSpec,
    build_reduced_pendulum,
    run_chain,
    run_pendulum,
)

CONDITIONS = ("clamped", "pinned", "mean-axis")
LABEL = {"clamped": "clamped (cantilever)", "pinned": "pinned (chord frame)", "mean-axis": "mean-axis (free-free)"}


@contextlib.contextmanager
def _reduce_with(**options):
    """The slider-crank example's ``reduce`` with ``options`` added (the example takes no
    interface-mode parameters; its defaults stay as they are)."""
    original = slider_crank.reduce
    slider_crank.reduce = functools.partial(original, **options)
    try:
        yield
    finally:
        slider_crank.reduce = original


def _row(cells) -> str:
    return "| " + " | ".join(str(c) for c in cells) + " |"


def slider_crank_table(vms_list) -> list[str]:
    t0 = time.perf_counter()
    full = slider_crank.mechanism("ancf")
    ref = run_setup(full, n_out=401, error_on="nodes", controller=full.controller(1e-6, step_control="plain"))
    print(f"reference: {ref.steps} steps, {time.perf_counter() - t0:.0f} s", flush=True)
    w_ref, x_ref = ref.series["w_mid"], ref.series["x_B"]
    cases = [(c, n, {}, "all") for n in vms_list for c in CONDITIONS]
    cases += [("clamped", 1, {"interface_modes": True, "interface_mds": ("fy",)}, "all"),
              ("mean-axis", 1, {"interface_modes": True, "interface_mds": ("fy",)}, "all")]
    rows = []
    for conditions, n, options, mds in cases:
        with _reduce_with(**options):
            setup = slider_crank.mechanism("nr-rncf", vms=n, mds=mds, conditions=conditions)
        run = run_setup(setup, n_out=401)
        k = run.dofs - 21  # the crank's and the slider's 7 coordinates, the rod's frame's 7
        extra = " + pin attachment modes, MDs of fy" if options else ""
        rows.append(_row([LABEL[conditions] + extra, n, k, run.dofs, f"{run.steps} ({run.rejected})",
                          run.newton_iters, f"{run.compile_s:.1f}", f"{run.run_s:.3f}",
                          f"{1e3 * np.abs(run.series['w_mid']).max():.3f}",
                          f"{float(chi_rel(w_ref, run.series['w_mid'])):.2f}",
                          f"{float(chi_rel(x_ref - x_ref[0], run.series['x_B'] - run.series['x_B'][0])):.3f}"]))
        print(rows[-1], flush=True)
    return [
        "## The slider-crank", "",
        "Crank 0.152 m rigid, driven at 150 rad/s; rod 0.304 m, E = 1e10 Pa, solid circle r = 5 mm, 8 C1 elements; "
        "slider 0.033 kg; 0-0.1 s from the rigid mechanism's velocities. Reduced rod: in-plane modes (`plane_normal`) "
        "and all their MDs, deflated by SVD; the example's run settings (rtol 2e-5, step error on w_mid and x_B, PI, "
        "ρ∞ = 0.5). Reference: the full ANCF rod, rtol 1e-6, step error on every nodal vector, "
        f"{ref.steps} steps ({ref.rejected} rejected), peak |w_mid| {1e3 * np.abs(w_ref).max():.3f} mm. "
        "k: the rod's deformation coordinates after deflation.", "",
        "| conditions | VMs | k | DOFs | accepted (rejected) | Newton it. | compile [s] | run [s] | "
        "peak abs w_mid [mm] | χ_rel w_mid [%] | χ_rel x_B − x_B(0) [%] |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|", *rows, ""]


def pendulum_table(vms_list, t_end: float) -> list[str]:
    spec, rtol = PendulumSpec(elements=10), 1e-4
    t0 = time.perf_counter()
    full = run_pendulum(spec, t_end=t_end, dt_out=0.01, controller=AdaptiveStepSize(rtol, rtol / 10))
    print(f"full pendulum: {full.steps} steps, {time.perf_counter() - t0:.0f} s", flush=True)
    d_full = full.nodes - full.nodes[0]
    rows = []
    for n in vms_list:
        for conditions in CONDITIONS:
            system = build_reduced_pendulum(spec, PendulumBasis(n, "all", conditions=conditions))[0]
            r = run_chain(system, t_end=t_end, dt_out=0.01, controller=AdaptiveStepSize(rtol, rtol / 10))
            k = system.bodies[0].k
            rows.append(_row([LABEL[conditions], n, k, r.dofs, f"{r.steps} ({r.rejected})", r.newton_iters,
                              f"{r.compile_s:.1f}", f"{r.run_s:.2f}",
                              f"{float(chi_rel(d_full, r.nodes - r.nodes[0])):.3f}",
                              f"{np.linalg.norm(r.tips - full.tips, axis=2).max():.2e}"]))
            print(rows[-1], flush=True)
    return [
        "## The three-beam pendulum", "",
        f"The paper's pendulum (three 1 m beams, E = 5 MPa, hinges about Z, released from rest under gravity), "
        f"10 C1 elements a beam, 0-{t_end:g} s, rtol {rtol:g}, atol {rtol / 10:g}, ρ∞ = 0.9, step error on every "
        f"nodal vector. Full ANCF: {full.dofs} DOFs, {full.steps} steps ({full.rejected} rejected), run "
        f"{full.run_s:.1f} s. Each beam reduced alike at its two ends (in-plane modes and all their MDs; pinned: "
        "the frame along the chord, the last beam's free end held to it as well).", "",
        "| conditions | VMs | k a beam | DOFs | accepted (rejected) | Newton it. | compile [s] | run [s] | "
        "χ_rel nodes [%] | largest tip distance [m] |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|", *rows, ""]


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--case", choices=["slider_crank", "pendulum", "all"], default="all")
    p.add_argument("--vms", type=int, nargs="+", default=[1, 2, 3, 4])
    p.add_argument("--pendulum-vms", type=int, nargs="+", default=[3, 5])
    p.add_argument("--t-end", type=float, default=2.0, help="the pendulum's end time [s]")
    p.add_argument("--out", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "results",
                                                 "reference_conditions.md"))
    a = p.parse_args(argv)
    lines = ["# Reference conditions: clamped, pinned, mean-axis (issue 60)", "",
             f"Produced by `benchmarks/reference_conditions.py{' ' + ' '.join(sys.argv[1:]) if sys.argv[1:] else ''}`"
             f". Machine: {machine()}.", ""]
    if a.case in ("slider_crank", "all"):
        lines += slider_crank_table(a.vms)
    if a.case in ("pendulum", "all"):
        lines += pendulum_table(a.pendulum_vms, a.t_end)
    report("\n".join(lines), a.out, keep_notes="## Notes")


if __name__ == "__main__":
    main()
