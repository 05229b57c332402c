"""The flexible slider-crank against an independent code: Exudyn (Gerstmayr; C++ with a Python
interface, ``pip install exudyn``), its planar ANCF cable (``ANCFCable2D``), in one invocation
with this library's full ANCF rod and its reduced rod (``results/peer_exudyn.md``).

The Exudyn model is the same mechanism written with Exudyn's own elements: 8 Euler-Bernoulli
cable elements (ρA, EI, EA of the rod), the crank pin's motion prescribed (a rigid crank driven at
a constant rate moves its pin on a circle whatever the rod does, so the crank's inertia does not
enter the rod's or the slider's motion), the slider a mass point held on the x axis and pinned
to the rod's end, the rigid mechanism's velocities at t = 0, generalized-α with ρ∞ = 0.5 at fixed
steps h. Its w_mid (the rod midpoint's distance from the chord of its ends) and x_B are compared
with this library's full ANCF rod at rtol 1e-6 (the reference of ``mechanisms.md``). Exudyn is
not a dependency: the script says so and stops when it is missing.

    pip install exudyn && python benchmarks/peer_exudyn.py
"""

import os
import sys
import time

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

from nrrncf_jax.post.metrics import chi_rel  # noqa: E402
from nrrncf_jax.scenarios.mechanism_file import load_setup, run_setup  # noqa: E402

sys.path.insert(0, os.path.dirname(__file__))
from _machine import machine, missing, pin_to_one_core, report  # noqa: E402

OMEGA, CRANK, ROD, E, RHO, RADIUS, SLIDER = 150.0, 0.152, 0.304, 1.0e10, 2770.0, 0.005, 0.033
T_END, N_OUT = 0.1, 201  # outputs every 0.5 ms: a whole number of every Exudyn step below


def exudyn_slider_crank(elements: int = 8, h: float = 1e-4, rho_inf: float = 0.5):
    """``(ts, x_B, w_mid, wall seconds, version)`` of the slider-crank in Exudyn (module docstring)."""
    import exudyn as exu
    from exudyn.beams import GenerateStraightLineANCFCable2D
    from exudyn.itemInterface import (
        Cable2D,
        CoordinateConstraint,
        MarkerNodeCoordinate,
        MarkerNodePosition,
        MassPoint2D,
        NodePoint2D,
        NodePointGround,
        RevoluteJoint2D,
        SensorNode,
    )

    r, L, area, inertia = CRANK, ROD, np.pi * RADIUS**2, np.pi * RADIUS**4 / 4
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    ground = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=mbs.AddNode(NodePointGround()), coordinate=0))
    cable = Cable2D(physicsMassPerLength=RHO * area, physicsBendingStiffness=E * inertia,
                    physicsAxialStiffness=E * area)
    nodes = GenerateStraightLineANCFCable2D(mbs, [r, 0, 0], [r + L, 0, 0], elements, cable)[0]
    w_rod = -r * OMEGA / L  # the rigid mechanism at θ = 0: the rod turns about the slider's pin
    for k, n in enumerate(nodes):
        mbs.SetNodeParameter(n, "initialVelocities", [0.0, w_rod * (L * k / elements - L), 0.0, w_rod])
    pin = [(lambda mbs, t, i, off: r * np.cos(OMEGA * t) - r, lambda mbs, t, i, off: -r * OMEGA * np.sin(OMEGA * t)),
           (lambda mbs, t, i, off: r * np.sin(OMEGA * t), lambda mbs, t, i, off: r * OMEGA * np.cos(OMEGA * t))]
    for c, (position, velocity) in enumerate(pin):  # node 0's displacement: the crank pin's circle
        mbs.AddObject(CoordinateConstraint(markerNumbers=[ground, mbs.AddMarker(MarkerNodeCoordinate(
            nodeNumber=nodes[0], coordinate=c))], offsetUserFunction=position, offsetUserFunction_t=velocity))
    slider = mbs.AddNode(NodePoint2D(referenceCoordinates=[r + L, 0.0]))
    mbs.AddObject(MassPoint2D(physicsMass=SLIDER, nodeNumber=slider))
    mbs.AddObject(RevoluteJoint2D(markerNumbers=[mbs.AddMarker(MarkerNodePosition(nodeNumber=nodes[-1])),
                                                 mbs.AddMarker(MarkerNodePosition(nodeNumber=slider))]))
    mbs.AddObject(CoordinateConstraint(markerNumbers=[ground, mbs.AddMarker(MarkerNodeCoordinate(
        nodeNumber=slider, coordinate=1))]))
    position = exu.OutputVariableType.Position
    sensors = [mbs.AddSensor(SensorNode(nodeNumber=n, storeInternal=True, outputVariableType=position))
               for n in (nodes[0], nodes[elements // 2], nodes[-1])]
    mbs.Assemble()
    s = exu.SimulationSettings()
    s.timeIntegration.numberOfSteps = int(round(T_END / h))
    s.timeIntegration.endTime = T_END
    s.timeIntegration.generalizedAlpha.spectralRadius = rho_inf
    s.timeIntegration.verboseMode = 0
    s.displayStatistics = False
    s.solutionSettings.writeSolutionToFile = False
    s.solutionSettings.sensorsWritePeriod = T_END / (N_OUT - 1)
    t0 = time.perf_counter()
    exu.SolveDynamic(mbs, s)
    wall = time.perf_counter() - t0
    a, m, b = (np.asarray(mbs.GetSensorStoredData(k))[:, 1:3] for k in sensors)
    ts = np.asarray(mbs.GetSensorStoredData(sensors[0]))[:, 0]
    chord, arm = b - a, m - a
    w_mid = (chord[:, 0] * arm[:, 1] - chord[:, 1] * arm[:, 0]) / np.linalg.norm(chord, axis=1)
    return ts, b[:, 0], w_mid, wall, exu.__version__


def main():
    if missing("exudyn", "pip install exudyn"):
        return 1
    pin_to_one_core()
    rows, ref = [], None
    nodes = {"error_on": "nodes"}  # the step error on every nodal vector, with plain step control
    ours = [("this library: full ANCF, 8 C1 elements (reference)", {"formulation": "ancf"}, 1e-6, None, nodes),
            ("this library: full ANCF, 8 C1 elements", {"formulation": "ancf"}, 1e-4, None, nodes),
            ("this library: NR-RNCF default (pinned, 1 VM + 1 MD; error on w_mid, x_B, PI)",
             {"formulation": "nr-rncf"}, None, None, {}),
            ("this library: NR-RNCF, error on every nodal vector", {"formulation": "nr-rncf"}, 1e-4, None, nodes),
            ("this library: NR-RNCF, fixed steps", {"formulation": "nr-rncf"}, 1e-4, 2e-4, {})]
    for label, params, rtol, dt, options in ours:
        setup = load_setup("slider_crank", params)
        run = run_setup(setup, n_out=N_OUT, controller=setup.controller(rtol, dt, "plain" if options else None),
                        **options)
        rtol = setup.rtol if rtol is None else rtol
        ref = run if ref is None else ref
        rows.append((label, run.dofs, f"rtol {rtol:g}" if dt is None else f"h = {dt:g}", run.steps, run.compile_s,
                     run.run_s, run.series["w_mid"], run.series["x_B"]))
        print(rows[-1][:6], flush=True)
    version = ""
    for h in (1e-4, 5e-5, 2e-5):
        walls = []
        for _ in range(3):
            ts, x_B, w_mid, wall, version = exudyn_slider_crank(h=h)
            walls.append(wall)
        if ts.shape[0] != N_OUT or not np.allclose(ts, ref.ts, atol=1e-12):
            raise RuntimeError(f"Exudyn's sensor times do not match the outputs ({ts.shape[0]} samples)")
        rows.append((f"Exudyn {version}: ANCFCable2D, 8 elements", 2 * 9 * 2 + 2, f"h = {h:g}", int(round(T_END / h)),
                     0.0, min(walls), w_mid, x_B))
        print(rows[-1][:6], flush=True)
    wr, xr = ref.series["w_mid"], ref.series["x_B"]
    lines = ["# The slider-crank against an independent code (Exudyn)", "",
             f"Produced by `benchmarks/peer_exudyn.py`. Machine: {machine()}.", "",
             "One invocation, one core. χ_rel (Eq. 40) against the first row: w_mid itself, x_B's change from its "
             "initial value. Exudyn: its own planar Euler-Bernoulli cable elements, the crank pin prescribed, fixed "
             "steps of generalized-α with ρ∞ = 0.5, run time the best of 3 (`SolveDynamic`, no compilation). This "
             "library: `run_setup` (compile and run timed apart). DOFs: Exudyn's nodal coordinates (9 nodes × 4 "
             "and the slider's 2).", "",
             "| model | DOFs | steps | accepted steps | compile [s] | run [s] | peak abs w_mid [mm] | x_B(0.1 s) [m] | "
             "χ_rel w_mid [%] | χ_rel x_B [%] |",
             "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|"]
    for label, dofs, steps, n, comp, run_s, w, x in rows:
        lines.append(f"| {label} | {dofs} | {steps} | {n} | {comp:.1f} | {run_s:.3f} | {1e3 * np.abs(w).max():.3f} | "
                     f"{x[-1]:.6f} | {float(chi_rel(wr, w)):.2f} | {float(chi_rel(xr - xr[0], x - x[0])):.3f} |")
    report("\n".join(lines) + "\n", os.path.join(os.path.dirname(__file__), "results", "peer_exudyn.md"),
           keep_notes="## Notes")
    return 0


if __name__ == "__main__":
    sys.exit(main())
