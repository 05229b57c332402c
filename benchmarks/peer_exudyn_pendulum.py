"""The three-beam pendulum (paper Sec. 4.4, ``scenarios.pendulum``) against an independent code:
Exudyn (Gerstmayr; C++ with a Python interface, ``pip install exudyn``), its planar ANCF cable
(``ANCFCable2D``), in one invocation with this library's reduced pendulum at the CLI's defaults
and its full ANCF model (``results/peer_exudyn_pendulum.md``).

The Exudyn model is ``PendulumSpec()`` written with Exudyn's own items: each beam n
Euler-Bernoulli cable elements (ρA, EI, EA of the solid section r = 5 mm), gravity on every
element (``LoadMassProportional``), the first node's position held (the ground hinge), and each
beam's last node pinned to the next beam's first node (``RevoluteJoint2D`` on two nodes of their
own: the slopes are free, a hinge), released from rest straight along +x; generalized-α
(index 3, ρ∞ = 0.9 as the library's runs, Exudyn's default modified Newton) at fixed steps h,
Exudyn's sparse LU. It is converged in mesh and step over a grid of n (``--meshes``) and h
(``--steps``): each run's tips (the beams' free right ends) against the finest run's, the
largest distance over 0-2 s, and its ``SolveDynamic`` time (the model built before the clock
starts; the best of ``--repeats``). At the issue's setting (12 elements a beam, h = 2e-3) it
also runs with Exudyn's default dense LU, and with a looser Newton tolerance.

This library's runs, in the same process on the same core: the NR-RNCF pendulum at the CLI's
defaults (``nrrncf pendulum --formulation nr-rncf``: 5 VMs + 15 MDs a beam, rtol 1e-3, atol 1e-4,
the PI controller; without the error estimate) and at the old defaults (rtol 1e-4, plain), the
best of ``--repeats``; the full ANCF model at rtol 1e-6, its time-converged reference (10 C1
elements a beam, the NR-RNCF's mesh), and a finer full ANCF run (``--fine-ancf`` elements a
beam, rtol 3e-5) to tell the two codes' models apart from the 10-element mesh's error. Their tips
against the converged Exudyn run and the ANCF reference, and χ_rel (Eq. 40) over every node
against the ANCF reference, as the run records give it (``PendulumRun.compare``). Exudyn is not
a dependency: the script says so and stops when it is missing.

    pip install exudyn && python benchmarks/peer_exudyn_pendulum.py [--cache /tmp/peer_pendulum]

``--cache``: a folder that keeps the full ANCF runs (a few minutes each) between invocations;
the page says when one was read back.
"""
import argparse
import os
import sys
import time

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

from nrrncf_jax.integrate import AdaptiveStepSize, adaptive_step_size  # noqa: E402
from nrrncf_jax.post.metrics import chi_rel  # noqa: E402
from nrrncf_jax.scenarios.pendulum import PendulumSpec, run_pendulum  # noqa: E402

sys.path.insert(0, os.path.dirname(__file__))
from _machine import machine, missing, pin_to_one_core, report  # noqa: E402

SPEC = PendulumSpec()
T_END, DT_OUT = 2.0, 1e-3  # the library's outputs (run_pendulum's default)
DT_CMP = 4e-3  # comparison times 0, 4 ms, ..., 2 s: a step of every Exudyn run, every 4th library output
RHO_INF = 0.9  # run_pendulum's
LONG = 5.0  # [s]: an Exudyn run this long is timed once (it averages the machine's drifts)


def exudyn_pendulum(elements: int = 12, h: float = 2e-3, rho_inf: float = RHO_INF, sparse: bool = True,
                    newton_rtol: float = 1e-8, spec: PendulumSpec = SPEC) -> dict:
    """The pendulum in Exudyn (module docstring): ``elements`` ANCFCable2D elements a beam,
    generalized-α at fixed steps ``h`` (Exudyn's step reduction off: a failed step fails the run),
    its sparse (``EigenSparse``) or dense (``EXUdense``, Exudyn's default) LU, Newton's relative
    tolerance ``newton_rtol`` (Exudyn's default 1e-8). Returns ``ts``, ``tips`` (nt, beams, 2:
    the beams' right ends every ``DT_CMP``), ``wall`` (``SolveDynamic``'s seconds), ``dofs``,
    ``newton`` and ``jacobians`` (Newton iterations and Jacobian updates), ``ok``, ``version``."""
    import exudyn as exu
    from exudyn.beams import GenerateStraightLineANCFCable2D
    from exudyn.itemInterface import Cable2D, MarkerNodePosition, RevoluteJoint2D, SensorNode

    area, inertia = np.pi * spec.radius**2, np.pi * spec.radius**4 / 4
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    cable = Cable2D(physicsMassPerLength=spec.rho * area, physicsBendingStiffness=spec.E * inertia,
                    physicsAxialStiffness=spec.E * area)
    gravity = [0.0, -spec.gravity, 0.0]
    beams = []
    for k in range(spec.beams):  # beam k from x = kL to (k+1)L, its own nodes; beam 0's first node held in x, y
        beams.append(GenerateStraightLineANCFCable2D(
            mbs, [k * spec.length, 0, 0], [(k + 1) * spec.length, 0, 0], elements, cable, massProportionalLoad=gravity,
            fixedConstraintsNode0=[1, 1, 0, 0] if k == 0 else None, fixedConstraintsNode1=None)[0])
    for left, right in zip(beams[:-1], beams[1:]):  # a hinge: the two end positions pinned, their slopes free
        mbs.AddObject(RevoluteJoint2D(markerNumbers=[mbs.AddMarker(MarkerNodePosition(nodeNumber=left[-1])),
                                                     mbs.AddMarker(MarkerNodePosition(nodeNumber=right[0]))]))
    position = exu.OutputVariableType.Position
    sensors = [mbs.AddSensor(SensorNode(nodeNumber=nodes[-1], storeInternal=True, outputVariableType=position))
               for nodes in beams]
    mbs.Assemble()
    s = exu.SimulationSettings()
    s.timeIntegration.numberOfSteps = int(round(T_END / h))
    s.timeIntegration.endTime = T_END
    s.timeIntegration.adaptiveStep = False
    s.timeIntegration.generalizedAlpha.spectralRadius = rho_inf
    s.timeIntegration.newton.relativeTolerance = newton_rtol
    if sparse:
        s.linearSolver.solverType = exu.LinearSolverType.EigenSparse
    stats = bool(os.environ.get("EXU_STATS"))  # Exudyn's own account of its time, for a look by hand
    s.timeIntegration.verboseMode = 1 if stats else 0
    s.displayStatistics = s.displayComputationTime = stats
    s.solutionSettings.writeSolutionToFile = False
    s.solutionSettings.sensorsWritePeriod = DT_CMP
    t0 = time.perf_counter()
    ok = exu.SolveDynamic(mbs, s)
    wall = time.perf_counter() - t0
    it = mbs.sys["dynamicSolver"].it
    data = [np.asarray(mbs.GetSensorStoredData(k)) for k in sensors]
    return dict(ts=data[0][:, 0], tips=np.stack([d[:, 1:3] for d in data], axis=1), wall=wall,
                dofs=mbs.systemData.GetODE2Coordinates().size, newton=int(it.newtonStepsCount),
                jacobians=int(it.newtonJacobiCount), ok=bool(ok), version=exu.__version__)


def ancf_run(elements: int, rtol: float, cache: str | None) -> dict:
    """The full ANCF pendulum (``elements`` C1 elements a beam) at ``rtol``, atol = rtol / 10: a dict
    of ``ts, nodes, steps, rejected, newton_iters, dofs, compile_s, run_s`` and ``cached`` (whether
    it was read back from the folder ``cache``, where it is kept)."""
    keys = ("ts", "nodes", "steps", "rejected", "newton_iters", "dofs", "compile_s", "run_s")
    path = None if not cache else os.path.join(cache, f"pendulum_ancf_{elements}_{rtol:g}_{T_END:g}.npz")
    if path and os.path.exists(path):
        with np.load(path) as f:
            return {k: f[k] for k in keys} | {"cached": True}
    run = run_pendulum(PendulumSpec(elements=elements), t_end=T_END, dt_out=DT_OUT,
                       controller=AdaptiveStepSize(rtol, rtol / 10))
    out = {k: getattr(run, k) for k in keys} | {"cached": False}
    if path:
        os.makedirs(cache, exist_ok=True)
        np.savez(path, **{k: out[k] for k in keys})
    return out


def largest(a, b) -> float:
    """The largest distance [m] between two tip series (nt, beams, ≥2) in the plane, over time and tips."""
    return float(np.linalg.norm(a[..., :2] - b[..., :2], axis=-1).max())


def chord_strain(nodes) -> float:
    """The largest strain of a chord between neighbouring nodes (nt, beams, nodes, 3) of a straight
    mesh of equal elements, over time."""
    chords = np.linalg.norm(np.diff(nodes[..., :2], axis=2), axis=-1)
    return float((chords / chords[0]).max() - 1.0)


def tip_chi(ref, tips) -> float:
    """χ_rel [%] (Eq. 40) of the tips' displacements (nt, beams, ≥2) from their initial positions, in
    the plane, against ``ref``'s."""
    return float(chi_rel(ref[..., :2] - ref[0, :, :2], tips[..., :2] - tips[0, :, :2]))


def tip3(a, b) -> float:
    """The largest distance [m] between the last beam's tips over time."""
    return float(np.linalg.norm(a[:, -1, :2] - b[:, -1, :2], axis=-1).max())


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--meshes", type=int, nargs="+", default=[6, 12, 24, 48], help="Exudyn's elements a beam")
    p.add_argument("--steps", type=float, nargs="+", default=[4e-3, 2e-3, 1e-3, 5e-4, 2.5e-4],
                   help="Exudyn's fixed steps [s], each dividing 4 ms")
    p.add_argument("--repeats", type=int, default=3, help="runs of each model; its time is their best")
    p.add_argument("--fine-ancf", type=int, default=20,
                   help="elements a beam of a finer full ANCF run (rtol 3e-5), for the models' difference; 0: none")
    p.add_argument("--cache", default=None, help="a folder keeping the full ANCF runs between invocations")
    p.add_argument("--out", default=os.path.join(os.path.dirname(__file__), "results", "peer_exudyn_pendulum.md"))
    a = p.parse_args()
    if missing("exudyn", "pip install exudyn"):
        return 1
    for h in a.steps:
        if abs(DT_CMP / h - round(DT_CMP / h)) > 1e-9:
            raise SystemExit(f"every step must divide the comparison interval {DT_CMP:g} s, got {h:g}")
    pin_to_one_core()
    load0 = os.getloadavg()
    n_cmp = int(round(T_END / DT_CMP)) + 1
    t_cmp = np.linspace(0.0, T_END, n_cmp)

    # ---- Exudyn: the grid of meshes and steps (sparse LU), and Exudyn's other settings at the issue's ----
    def peer_run(n, h, **kw):
        runs = [exudyn_pendulum(n, h, **kw)]
        while len(runs) < a.repeats and runs[0]["wall"] < LONG:
            runs.append(exudyn_pendulum(n, h, **kw))
        r = runs[0]
        if not r["ok"]:
            print(f"Exudyn n = {n}, h = {h:g}, {kw}: failed", flush=True)
            return r | {"walls": [x["wall"] for x in runs], "steps": int(round(T_END / h))}
        if r["ts"].shape[0] != n_cmp or not np.allclose(r["ts"], t_cmp, atol=1e-9):
            raise RuntimeError(f"Exudyn's sensor times do not match the comparison times ({r['ts'].shape[0]} samples)")
        r |= {"walls": [x["wall"] for x in runs], "steps": int(round(T_END / h))}
        print(f"Exudyn n = {n}, h = {h:g}, {kw}: {min(r['walls']):.3f} s ({r['dofs']} DOFs, {r['newton']} Newton "
              f"iterations, {r['jacobians']} Jacobians)", flush=True)
        return r

    peer = {(n, h): peer_run(n, h) for n in a.meshes for h in a.steps}
    version = peer[a.meshes[0], a.steps[0]]["version"]
    finest = (max(a.meshes), min(a.steps))
    if not peer[finest]["ok"]:
        raise RuntimeError("the finest Exudyn run failed")
    conv = peer[finest]["tips"]
    issue = (12, 2e-3)  # the issue's peer setting
    variants = [("dense LU (Exudyn's default solver)", dict(sparse=False)),
                ("sparse LU, Newton's relative tolerance 1e-6", dict(newton_rtol=1e-6))]
    extra = [(label, peer_run(*issue, **kw)) for label, kw in variants]

    # ---- this library ----
    every = int(round(DT_CMP / DT_OUT))
    ref = ancf_run(SPEC.elements, 1e-6, a.cache)
    if not np.allclose(ref["ts"][::every], t_cmp):
        raise RuntimeError("the library's output times do not hold the comparison times")
    ref_tips, w_ref = ref["nodes"][::every, :, -1], ref["nodes"] - ref["nodes"][0]
    print(f"ANCF reference: {int(ref['steps'])} steps, {float(ref['run_s']):.1f} s"
          f"{' (cached)' if ref['cached'] else ''}", flush=True)
    fine = ancf_run(a.fine_ancf, 3e-5, a.cache) if a.fine_ancf else None
    ours = [("NR-RNCF, the CLI's default: 5 VMs + 15 MDs a beam, rtol 1e-3, PI", "rtol 1e-3",
             dict(controller=adaptive_step_size(1e-3, 1e-4, "pi"))),
            ("NR-RNCF, the old default: 5 VMs + 15 MDs a beam, rtol 1e-4, plain", "rtol 1e-4",
             dict(controller=AdaptiveStepSize(1e-4, 1e-5)))]
    lib = []
    for label, tol, kw in ours:
        runs = [run_pendulum(SPEC, t_end=T_END, dt_out=DT_OUT, formulation="nr-rncf", **kw)
                for _ in range(a.repeats)]
        r = runs[0]
        tips = r.tips[::every]
        lib.append(dict(label=label, tol=tol, dofs=r.dofs, steps=r.steps, rejected=r.rejected,
                        newton=r.newton_iters, compile_s=r.compile_s, runs=[x.run_s for x in runs],
                        to_peer=largest(tips, conv), to_peer3=tip3(tips, conv), to_ref=largest(tips, ref_tips),
                        tip_chi=tip_chi(ref_tips, tips),
                        chi=float(chi_rel(w_ref, r.displacement_series()))))
        print(label, {k: v for k, v in lib[-1].items() if k != "label"}, flush=True)

    # ---- the page ----
    def mm(x):
        return f"{1e3 * x:.2f}"

    def peer_row(model, r, h):
        if not r["ok"]:
            return f"| Exudyn {version} | {model} | {r['dofs']} | h = {h:g} | failed | | | | | | | | | |"
        return (f"| Exudyn {version} | {model} | {r['dofs']} | h = {h:g} | {r['steps']} | {r['newton']} | – | "
                f"{min(r['walls']):.3f} | {min(r['walls']):.3f}-{max(r['walls']):.3f} | {mm(tip3(r['tips'], conv))} | "
                f"{mm(largest(r['tips'], conv))} | {mm(largest(r['tips'], ref_tips))} | "
                f"{tip_chi(conv, r['tips']):.2f} | – |")

    lines = ["# The three-beam pendulum against an independent code (Exudyn)", "",
             f"Produced by `benchmarks/peer_exudyn_pendulum.py`. Machine: {machine()}.", "",
             f"`PendulumSpec()`: three beams of {SPEC.length:g} m, solid section r = {1e3 * SPEC.radius:g} mm, "
             f"E = {SPEC.E / 1e6:g} MPa, ρ = {SPEC.rho:g} kg/m³, ν = {SPEC.nu:g}; a ground hinge and two hinges "
             f"about Z; released from rest along +x, gravity −{SPEC.gravity:g} m/s² along Y; 0-{T_END:g} s. "
             f"One invocation, one core. Tips: the beams' right ends, compared every {1e3 * DT_CMP:g} ms; a "
             "distance is the largest over 0-2 s (of beam 3's tip, or of all three tips).", "",
             f"Exudyn {version}: each beam n `ANCFCable2D` elements (Euler-Bernoulli: EA, EI and ρA of the "
             "section; no shear, no rotary inertia), gravity as `LoadMassProportional`, the first node's "
             "position held, `RevoluteJoint2D` between the beams' end nodes; generalized-α (index 3, "
             f"ρ∞ = {RHO_INF:g}, Exudyn's default modified Newton) at fixed steps h, Exudyn's sparse LU "
             "(`EigenSparse`) unless the row says otherwise, its other settings its defaults (Newton's relative "
             f"tolerance 1e-8). wall: `SolveDynamic` alone (the model built before the clock starts), the best "
             f"of {a.repeats} (of one where the first took over {LONG:g} s). DOFs: its nodal coordinates "
             f"(3 (n+1) nodes × 4). The converged peer: n = {finest[0]}, h = {finest[1]:g}.", "",
             "This library: `run_pendulum(PendulumSpec(), formulation=\"nr-rncf\", ...)`, 10 C1 elements a beam "
             "reduced to 5 VMs + 15 MDs (the paper's basis), in floating frames; index-3 generalized-α "
             f"(ρ∞ = {RHO_INF:g}), adaptive steps, without the run's error estimate. wall: the record's `run_s` "
             f"(compilation apart, in its own column), the best of {a.repeats} (each compiled anew). The ANCF "
             "reference: `run_pendulum(PendulumSpec(), controller=AdaptiveStepSize(1e-6, 1e-7))`, the full model on "
             "the same mesh"
             + (" (read back from the cache, written by an earlier invocation of this script)" if ref["cached"]
                else " (run in this invocation)") + ". χ_rel: every node's displacement against the ANCF "
             "reference's, over every output (Eq. 40, as `PendulumRun.compare`).", "",
             "| code | model | DOFs | h or rtol | steps (rejected) | Newton it. | compile [s] | wall [s] | "
             "runs' range [s] | tip 3 to converged peer [mm] | tips 1-3 to converged peer [mm] | "
             "tips 1-3 to library ANCF ref. [mm] | χ_rel of the tips vs own converged run [%] | "
             "χ_rel vs ANCF ref. [%] |",
             "|---|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for (n, h), r in peer.items():
        lines.append(peer_row(f"ANCFCable2D, {n} elements a beam", r, h))
    for label, r in extra:
        lines.append(peer_row(f"ANCFCable2D, {issue[0]} elements a beam, {label}", r, issue[1]))
    for r in lib:
        lines.append(f"| this library | {r['label']} | {r['dofs']} | {r['tol']} | {r['steps']} ({r['rejected']}) | "
                     f"{r['newton']} | {r['compile_s']:.1f} | {min(r['runs']):.3f} | "
                     f"{min(r['runs']):.3f}-{max(r['runs']):.3f} | {mm(r['to_peer3'])} | {mm(r['to_peer'])} | "
                     f"{mm(r['to_ref'])} | {r['tip_chi']:.2f} | {r['chi']:.2f} |")
    for label, run, tol in ((f"full ANCF, {SPEC.elements} C1 elements a beam (reference)", ref, "rtol 1e-6"),
                            (f"full ANCF, {a.fine_ancf} C1 elements a beam", fine, "rtol 3e-5")):
        if run is None:
            continue
        tips = run["nodes"][::every, :, -1]
        lines.append(f"| this library | {label} | {int(run['dofs'])} | {tol} | {int(run['steps'])} "
                     f"({int(run['rejected'])}) | {int(run['newton_iters'])} | {float(run['compile_s']):.1f} | "
                     f"{float(run['run_s']):.1f} | {'cached' if run['cached'] else '–'} | {mm(tip3(tips, conv))} | "
                     f"{mm(largest(tips, conv))} | {mm(largest(tips, ref_tips))} | {tip_chi(ref_tips, tips):.2f} | – |")

    hs, ns = sorted(a.steps, reverse=True), sorted(a.meshes)
    lines += ["", "Exudyn's convergence: the largest distance of all three tips to the converged peer [mm], by "
              "mesh (rows) and step (columns).", "",
              "| elements a beam | " + " | ".join(f"h = {h:g}" for h in hs) + " |",
              "|---:|" + "---:|" * len(hs)]
    for n in ns:
        lines.append(f"| {n} | " + " | ".join(mm(largest(peer[n, h]["tips"], conv)) if peer[n, h]["ok"]
                                              else "failed" for h in hs) + " |")
    if len(ns) >= 2 and len(hs) >= 2:  # the finest run's own error, from its two nearest neighbours
        e_mesh = largest(peer[ns[-2], hs[-1]]["tips"], conv)
        e_step = largest(peer[ns[-1], hs[-2]]["tips"], conv)
        lines += ["", f"The converged peer's neighbours: {mm(e_mesh)} mm with half its elements ({ns[-2]} at "
                  f"h = {hs[-1]:g}), {mm(e_step)} mm at twice its step (h = {hs[-2]:g}, {ns[-1]} elements)."]

    ok = sorted((min(r["walls"]), n, h) for (n, h), r in peer.items()
                if r["ok"] and largest(r["tips"], conv) <= 0.01 and (n, h) != finest)
    d = lib[0]
    lines += ["", "## Answer", ""]
    if ok:
        wall, n, h = ok[0]
        lines.append("Exudyn runs within 1 cm of the converged peer at all three tips: "
                     + ", ".join(f"{n_} elements at h = {h_:g} ({w_:.3f} s)" for w_, n_, h_ in ok)
                     + f". The cheapest: {n} elements a beam, h = {h:g}, "
                     f"{mm(largest(peer[n, h]['tips'], conv))} mm, {wall:.3f} s. This library's reduced default: "
                     f"{min(d['runs']):.3f} s ({min(d['runs']) / wall:.2f}× that), its tips {mm(d['to_peer'])} mm "
                     f"from the converged peer and {mm(d['to_ref'])} mm from its own ANCF reference, χ_rel "
                     f"{d['chi']:.2f} % (the issue's bound: 1.2 %).")
    else:
        lines.append("No Exudyn run of the grid but the finest is within 1 cm of the converged peer at all three tips.")
    same = sorted((min(r["walls"]), n, h) for (n, h), r in peer.items()
                  if r["ok"] and tip_chi(conv, r["tips"]) <= d["tip_chi"] and (n, h) != finest)
    if same:
        wall, n, h = same[0]
        lines += ["", f"At equal accuracy by χ_rel of the tips (each code against its own converged run): the reduced "
                  f"default's tips are {d['tip_chi']:.2f} % from the ANCF reference's; the cheapest Exudyn run as "
                  f"close to its converged one: {n} elements a beam, h = {h:g}, "
                  f"{tip_chi(conv, peer[n, h]['tips']):.2f} %, {wall:.3f} s (the reduced default's time is "
                  f"{min(d['runs']) / wall:.2f}× it)."]
    if issue in peer and peer[issue]["ok"]:
        r = peer[issue]
        lines += ["", f"The issue's peer setting, {issue[0]} elements a beam at h = {issue[1]:g}: "
                  f"{min(r['walls']):.3f} s here (sparse LU), its tips {mm(largest(r['tips'], conv))} mm from the "
                  f"converged peer; the reduced default's time is {min(d['runs']) / min(r['walls']):.2f}× it. "
                  + "; ".join(f"{label[0].upper() + label[1:]}: {min(x['walls']):.3f} s"
                              for label, x in extra if x["ok"]) + "."]
    lines += ["", f"The two models' difference: the converged peer against the library's ANCF reference (10 "
              f"elements a beam) {mm(largest(ref_tips, conv))} mm at the tips (beam 3: {mm(tip3(ref_tips, conv))} mm)"
              + (f"; against its {a.fine_ancf}-element run {mm(largest(fine['nodes'][::every, :, -1], conv))} mm"
                 if fine is not None else "") + f". The chain stretches: the largest strain of a chord between "
              f"neighbouring nodes of the ANCF reference is {100 * chord_strain(ref['nodes']):.2f} %."]
    lines += ["", "The machine's load average (1 min) at the start and end of the invocation: "
              f"{load0[0]:.1f}, {os.getloadavg()[0]:.1f} (on {os.cpu_count()} cores; this process on one)."]
    report("\n".join(lines) + "\n", a.out, keep_notes="## Notes")
    return 0


if __name__ == "__main__":
    sys.exit(main())
