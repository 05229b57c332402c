"""The two problems of the validation set (Bauchau et al., Multibody System Dynamics 37 (2016) 29-48;
``VALIDATION_SET.md``) that had no independent peer yet, the Princeton beam (a) and the dynamic
lateral buckling (c), computed by Exudyn's 3-D geometrically exact beams and compared with this
library's runs of the same problems in one invocation (``results/peer_exudyn_beams.md``,
``results/figures/peer_exudyn_beams.png``). The approach and the helpers are
``peer_exudyn_3d.py``'s (the four-bar and the rotating shaft):

- beams: ``ObjectBeamGeometricallyExact`` (2-node, shear-deformable, Simo-Reissner strains constant
  in each element) on Euler-parameter nodes (``NodeRigidBodyEP``), the section as the library's
  ``sectional`` builds it from the same sectional stiffnesses: diag(EA, GA_y, GA_z, GJ, EI_y, EI_z),
  GA = 5/6 EA/(2(1 + ν)) where the example gives none, the inertia per length
  ρA/EA · diag(EI_y + EI_z, EI_y, EI_z) (the equivalent rectangle's);
- the Princeton beam (``examples/princeton_beam.py``): clamped at x = 0 (a ``GenericJoint``, all
  six axes), a tip force ``LoadForceVector`` P (0, −sin θ, −cos θ) fixed in space, ``SolveStatic``
  in 10 load steps (Exudyn scales the loads along them); flap −z, lag −y of the tip node, twist
  ``SectionAngle``'s measure about x on the tip node's rotation;
- the lateral buckling (``examples/lateral_buckling.py``, every point, section and the drive as it
  defines them): the beam clamped at R, the eccentric ball at C (an ``ObjectJointSpherical`` on a
  ``MarkerBodyRigid`` of the beam's last element at its end, 0.1 mm along the section's y, so fixed
  in the tip's section frame as MBDyn's offset hinge and the library's ``ball(eccentric=True)``),
  the link from C down to B (its nodes' frames the example's ``DOWN``), a ``GenericJoint`` at B with
  the rotation about y free, the crank from G to B, driven at G by a ``GenericJoint`` with all six
  axes locked and the rotation offset φ(t) = (π/2)(1 − cos(π t/T)) about −y (then π), its rate
  given too; at rest in the reference at t = 0, no gravity, no damping; generalized-α (index 3) at
  fixed steps, ρ∞ = 0.5 as the example's. Sensors: the tip and mid-span nodes' positions and
  rotations, the link's section force (``ForceLocal``, the mean of the two elements at its middle
  node) and the drive's torque (``TorqueLocal`` of the driving joint, about −y).

Exudyn is not a dependency: the script says so and stops when it is missing. The page's
``## Notes (by hand)``, read from a full run's figures, is kept when the script runs again.

    pip install exudyn && taskset -c 1 python benchmarks/peer_exudyn_beams.py [--quick] [--no-reduced]
        [--no-refined] [--out results/peer_exudyn_beams.md]
"""

import argparse
import os
import sys
import time

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

from nrrncf_jax.examples import lateral_buckling as lb  # noqa: E402
from nrrncf_jax.examples import princeton_beam as pb  # noqa: E402
from nrrncf_jax.integrate import constrained_equilibrium  # noqa: E402
from nrrncf_jax.multibody.joints import normals  # noqa: E402
from nrrncf_jax.multibody.sensors import observe  # noqa: E402
from nrrncf_jax.scenarios.mechanism_file import load_setup, run_setup  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _machine import machine, missing, pin_to_one_core, report  # noqa: E402
from peer_exudyn_3d import NEWTON_RTOL, _beam_section, _ep, _settings  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
NU = 0.3  # the library's sectional default: G A = EA/(2(1 + ν)), k = 5/6 where no GA is given

# ---- the Princeton beam ----
PR_ANGLES = tuple(range(0, 91, 15))
PR_LOAD_STEPS = 10  # the library's static CLI default and validation.py's
PR_NEWTON_RTOLS = (1e-8, 1e-7, 1e-6)
"""Newton's relative tolerances tried in turn: Exudyn's static default 1e-8 first; on the finest meshes its residual
stalls at round-off in a few cases (the stiff EA), and the next one is taken (the table says how often)."""
PR_MESHES = (4, 8, 16, 32, 64, 128, 256)

# ---- the lateral buckling ----
LB_T_END, LB_RHO_INF, LB_DT_OUT = 2 * lb.T_DRIVE, 0.5, 1e-3
LB_LINK, LB_CRANK = 4, 2  # the peer's link and crank elements (a check with 8 and 4 below)
WINDOWS = ((0.0, 0.2), (0.2, 0.4), (0.4, 0.8))
WINDOW_NAMES = ("(the crank pushes B up: the onset near 0.13 s and the first buckling's peak)",
                "(the crank comes down: the load falls below the critical one and the beam swings)",
                "(the crank held: the beam vibrates sideways, undamped)")
LB_QS = ("tip_y", "tip_z", "tip_twist", "mid_y", "mid_twist", "link_N", "drive_torque")
LB_CRIT = ("tip_z", "tip_twist", "mid_y", "mid_twist")  # the outputs "within 1 %" is judged on


def section_of(S: dict, nu: float = NU):
    """(stiffness diagonal, ρA, inertia diagonal) of the library's ``sectional(**S)``: the
    equivalent rectangle's E = EA/A, G = E/(2(1 + ν)), shear k = 5/6 unless GA_y, GA_z are given;
    the inertia per length ρ(I_y + I_z), ρI_y, ρI_z = ρA/EA (EI_y + EI_z, EI_y, EI_z)."""
    GA = S["EA"] / (2.0 * (1.0 + nu))
    r = S["rhoA"] / S["EA"]
    return ([S["EA"], S.get("GA_y") or 5.0 / 6.0 * GA, S.get("GA_z") or 5.0 / 6.0 * GA, S["GJ"], S["EI_y"],
             S["EI_z"]], S["rhoA"], [r * (S["EI_y"] + S["EI_z"]), r * S["EI_y"], r * S["EI_z"]])


_U, _W = normals((1.0, 0.0, 0.0))  # SectionAngle(marker, x)'s u and w = x × u (multibody.markers.hinge_angle)


def twist_of(R):
    """``SectionAngle(tip, (1, 0, 0))``'s measure on a node's rotation matrix R (…, 3, 3): the
    angle of R u in the plane (u, w) normal to x, atan2(R u · w, R u · u)."""
    Ru = np.asarray(R) @ _U
    return np.arctan2(Ru @ _W, Ru @ _U)


# ================================================================================================
# The Princeton beam
# ================================================================================================

def exudyn_princeton(elements: int, load: float, angle_deg: float, load_steps: int = PR_LOAD_STEPS,
                     newton_rtol: float = PR_NEWTON_RTOLS[0]) -> dict:
    """The Princeton beam in Exudyn (module docstring) on ``elements`` beams: the tip's flap, lag
    [m] and twist [rad] at the full load, and the solve's wall time."""
    import exudyn as exu
    from exudyn.itemInterface import (
        GenericJoint,
        LoadForceVector,
        MarkerBodyRigid,
        MarkerNodePosition,
        MarkerNodeRigid,
        NodeRigidBodyEP,
        ObjectBeamGeometricallyExact,
        ObjectGround,
    )

    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    ep0 = [1.0, 0.0, 0.0, 0.0]
    nodes = [mbs.AddNode(NodeRigidBodyEP(referenceCoordinates=[pb.LENGTH * k / elements, 0.0, 0.0] + ep0))
             for k in range(elements + 1)]
    sec = _beam_section(exu, section_of(pb.SECTION))
    for k in range(elements):
        mbs.AddObject(ObjectBeamGeometricallyExact(nodeNumbers=[nodes[k], nodes[k + 1]], length=pb.LENGTH / elements,
                                                   sectionData=sec))
    ground = mbs.AddObject(ObjectGround())
    root = [mbs.AddMarker(MarkerBodyRigid(bodyNumber=ground, localPosition=[0.0] * 3)),
            mbs.AddMarker(MarkerNodeRigid(nodeNumber=nodes[0]))]
    mbs.AddObject(GenericJoint(markerNumbers=root, constrainedAxes=[1] * 6))
    th = np.radians(angle_deg)
    mbs.AddLoad(LoadForceVector(markerNumber=mbs.AddMarker(MarkerNodePosition(nodeNumber=nodes[-1])),
                                loadVector=[0.0, -load * np.sin(th), -load * np.cos(th)]))
    mbs.Assemble()
    s = exu.SimulationSettings()
    s.staticSolver.numberOfLoadSteps = load_steps
    s.staticSolver.newton.relativeTolerance = newton_rtol
    s.staticSolver.verboseMode = 0
    s.solution.file.write = False
    s.linearSolver.solverType = exu.LinearSolverType.EigenSparse
    t0 = time.perf_counter()
    exu.SolveStatic(mbs, s)
    wall = time.perf_counter() - t0
    OV = exu.OutputVariableType
    p = mbs.GetNodeOutput(nodes[-1], OV.Position)
    R = np.asarray(mbs.GetNodeOutput(nodes[-1], OV.RotationMatrix)).reshape(3, 3)
    return {"flap": -float(p[2]), "lag": -float(p[1]), "twist": float(twist_of(R)), "wall": wall,
            "dofs": mbs.systemData.ODE2Size(), "version": exu.__version__, "rtol": newton_rtol}


def peer_princeton(elements: int, load: float, angle_deg: float, **kw) -> dict:
    """``exudyn_princeton`` at the first of ``PR_NEWTON_RTOLS`` whose Newton converges."""
    import exudyn as exu

    for tol in PR_NEWTON_RTOLS[:-1]:
        try:
            return exudyn_princeton(elements, load, angle_deg, newton_rtol=tol, **kw)
        except exu.SolverError:
            pass
    return exudyn_princeton(elements, load, angle_deg, newton_rtol=PR_NEWTON_RTOLS[-1], **kw)


def library_princeton(elements: int) -> dict:
    """This library's ``examples/princeton_beam.py`` at every load and angle on ``elements``: its
    static solve (``constrained_equilibrium(system, t=1, load_steps=10)``, as ``nrrncf static``),
    the sensors there. The tip load's magnitude is a Python float of the force law, a static
    argument of the compiled solve, so each load compiles once and its angles reuse it: the first
    solve of a load is timed with its compilation, then every angle (that one again too) alone."""
    out, compile_s = {}, {}
    for P in pb.LOADS:
        first = None
        for angle in PR_ANGLES:
            setup = pb.mechanism(load=P, angle_deg=float(angle), elements=elements)
            solve = lambda: jax.block_until_ready(  # noqa: E731
                constrained_equilibrium(setup.system, t=1.0, load_steps=PR_LOAD_STEPS))
            if first is None:
                t0 = time.perf_counter()
                solve()
                first = time.perf_counter() - t0
            t0 = time.perf_counter()
            eq = solve()
            run_s = time.perf_counter() - t0
            values = observe(setup.system, setup.sensors)(1.0, eq.z, 0.0 * eq.z)
            out[(P, angle)] = {"flap": -float(values["tip_z"]), "lag": -float(values["tip_y"]),
                               "twist": float(values["twist"]), "run_s": run_s, "dofs": setup.system.n_dof,
                               "iters": int(np.sum(eq.iterations))}
        compile_s[P] = first - out[(P, PR_ANGLES[0])]["run_s"]
        print("library princeton", elements, P, f"compile {compile_s[P]:.1f} s", flush=True)
    return {"cases": out, "compile_s": compile_s, "elements": elements}


def _pr_err(cases, ref, q, P):
    """max over the angles of |x − x*| / max over the angles |x*|, at load P."""
    scale = max(abs(ref[(P, a)][q]) for a in PR_ANGLES)
    return max(abs(cases[(P, a)][q] - ref[(P, a)][q]) for a in PR_ANGLES) / scale


def _pct(a, b, floor):
    return "–" if abs(b) < floor else f"{100 * (a / b - 1):+.3f}"


def princeton_section(lines, args):
    meshes = args.pr_meshes
    peer = {}
    for ne in meshes:
        t0 = time.perf_counter()
        for P in pb.LOADS:
            for a in PR_ANGLES:
                peer[(ne, P, a)] = peer_princeton(ne, P, a)
        print("exudyn princeton", ne, f"{time.perf_counter() - t0:.1f} s", flush=True)
    fine, coarse, coarser = meshes[-1], meshes[-2], meshes[-3]
    qs = ("flap", "lag", "twist")
    rich = {(P, a): {q: peer[(fine, P, a)][q] + (peer[(fine, P, a)][q] - peer[(coarse, P, a)][q]) / 3.0 for q in qs}
            for P in pb.LOADS for a in PR_ANGLES}
    orders = {q: [] for q in qs}
    for P in pb.LOADS:
        for a in PR_ANGLES:
            x = [peer[(n, P, a)] for n in (coarser, coarse, fine)]
            for q in qs:
                d1, d2 = x[0][q] - x[1][q], x[1][q] - x[2][q]
                if abs(d2) > 1e-12 and abs(rich[(P, a)][q]) > 1e-6:
                    orders[q].append(np.log2(abs(d1 / d2)))
    # checks of the converged peer's own settings, on the hardest case
    hard = (pb.LOADS[-1], 45)
    base = peer[(fine, *hard)]
    chk_steps = peer_princeton(fine, *hard, load_steps=3)
    d_steps = max(abs(chk_steps[q] - base[q]) for q in qs)
    mid = meshes[-4] if len(meshes) >= 4 else meshes[0]  # 1e-10 stalls at round-off on the finer meshes
    chk_tol = exudyn_princeton(mid, *hard, newton_rtol=1e-10)
    d_tol = max(abs(chk_tol[q] - peer[(mid, *hard)][q]) for q in qs)
    retried = {ne: sum(peer[(ne, P, a)]["rtol"] > PR_NEWTON_RTOLS[0] for P in pb.LOADS for a in PR_ANGLES)
               for ne in meshes}
    version = base["version"]

    # the peer's convergence table
    lines += ["## (a) The Princeton beam, static", "",
              f"Exudyn {version}: `ObjectBeamGeometricallyExact` on `NodeRigidBodyEP`, `SolveStatic` in "
              f"{PR_LOAD_STEPS} load steps (adaptive), Newton's relative tolerance {PR_NEWTON_RTOLS[0]:g} (Exudyn's "
              f"default; where it stalls at round-off, {PR_NEWTON_RTOLS[1]:g} and then {PR_NEWTON_RTOLS[2]:g}: "
              + (", ".join(f"{k} of the 21 cases on {ne} elements" for ne, k in retried.items() if k) or "none")
              + "). Section: "
              "EA, k GA (k = 5/6, GA = EA/2.6), GJ, EI_flap = 2.42873, EI_lag = 36.2794 N·m² (`examples/"
              "princeton_beam.py`'s SECTION, as its `sectional` builds the beam). The tip load P (0, −sin θ, −cos θ) "
              "is fixed in space. Flap = −z, lag = −y of the tip; twist: the tip section's angle about x, "
              "`SectionAngle`'s measure, atan2(−(R e_z)_y, (R e_z)_z) (nose down negative). x*: the Richardson "
              f"extrapolation (order 2) from {coarse} and {fine} elements; the error measure for a load: "
              "max over the seven angles of |x − x*| / max over the angles |x*| (so the vanishing lag at 0° and "
              "twist at 0° and 90° do not divide by zero).", "",
              "### The peer's own convergence", "",
              "| elements | DOFs | wall, 21 solves [s] | max err flap [%] | max err lag [%] | max err twist [%] | "
              "flap(3 lbf, 45°) [mm] | lag [mm] | twist [deg] |", "|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    peer_err = {}
    for ne in meshes:
        cases = {(P, a): peer[(ne, P, a)] for P in pb.LOADS for a in PR_ANGLES}
        peer_err[ne] = {q: max(_pr_err(cases, rich, q, P) for P in pb.LOADS) for q in qs}
        wall = sum(c["wall"] for c in cases.values())
        c = peer[(ne, *hard)]
        lines.append(f"| {ne} | {c['dofs']} | {wall:.2f} | {100 * peer_err[ne]['flap']:.4f} | "
                     f"{100 * peer_err[ne]['lag']:.4f} | {100 * peer_err[ne]['twist']:.4f} | {1e3 * c['flap']:.4f} | "
                     f"{1e3 * c['lag']:.4f} | {np.degrees(c['twist']):.5f} |")
    r = rich[hard]
    lines.append(f"| Richardson ({coarse}, {fine}) | | | | | | {1e3 * r['flap']:.4f} | {1e3 * r['lag']:.4f} | "
                 f"{np.degrees(r['twist']):.5f} |")
    lines += ["", "Observed order in the mesh (" + f"{coarser}, {coarse}, {fine} elements, every case whose value "
              "is not zero): " + ", ".join(f"{q} {min(v):.2f}-{max(v):.2f}" for q, v in orders.items() if v)
              + f". Checks at 3 lbf, 45°: 3 load steps instead of {PR_LOAD_STEPS} ({fine} elements) change flap, lag "
              f"and twist by at most {d_steps:.1e} (m, rad), Newton's tolerance 1e-10 instead of "
              f"{PR_NEWTON_RTOLS[0]:g} ({mid} elements) by {d_tol:.1e}."]

    # this library
    libs = [library_princeton(args.pr_elements)]
    if args.refined:
        libs.append(library_princeton(2 * args.pr_elements))
    floor = {"flap": 1e-6, "lag": 1e-6, "twist": 1e-7}
    n0, n1 = libs[0]["elements"], libs[-1]["elements"]
    lines += ["", "### This library against the converged peer", "",
              f"This library: `examples/princeton_beam.py`'s `mechanism(load, angle_deg, elements)` on {n0} C1 "
              f"elements (its default){f' and {n1}' if len(libs) > 1 else ''}, `constrained_equilibrium(system, "
              f"t=1, load_steps={PR_LOAD_STEPS})` (as `nrrncf static`), its sensors `tip_z`, `tip_y`, `twist`. "
              f"Δ: library / x* − 1 in % (– where x* is zero: lag at 0°, twist at 0° and 90°). Dowell's experiment: "
              "`VALIDATION_SET.md` names it (Dowell, Traybar & Hodges 1977) but gives no values, and none are in "
              "this repository, so no experimental column.", "",
              "| P [N] | θ [deg] | flap x* [mm] | flap [mm] | Δ [%] |" + (f" Δ {n1} el. [%] |" if len(libs) > 1 else "")
              + " lag x* [mm] | lag [mm] | Δ [%] |" + (f" Δ {n1} el. [%] |" if len(libs) > 1 else "")
              + " twist x* [deg] | twist [deg] | Δ [%] |" + (f" Δ {n1} el. [%] |" if len(libs) > 1 else ""),
              "|" + "---:|" * (2 + 3 * (3 + (len(libs) > 1)))]
    worst = {n["elements"]: {q: 0.0 for q in qs} for n in libs}
    for P in pb.LOADS:
        for a in PR_ANGLES:
            row = f"| {P} | {a} |"
            for q, scale, unit in (("flap", 1e3, "{:.4f}"), ("lag", 1e3, "{:.4f}"),
                                   ("twist", np.degrees(1.0), "{:.5f}")):
                x = rich[(P, a)][q]
                row += f" {unit.format(scale * x)} | {unit.format(scale * libs[0]['cases'][(P, a)][q])} |"
                for k, lib in enumerate(libs):
                    y = lib["cases"][(P, a)][q]
                    row += f" {_pct(y, x, floor[q])} |"
                    if abs(x) >= floor[q]:
                        worst[lib["elements"]][q] = max(worst[lib["elements"]][q], abs(y / x - 1))
            lines.append(row)
    lib_err = {lib["elements"]: {q: max(_pr_err(lib["cases"], rich, q, P) for P in pb.LOADS) for q in qs}
               for lib in libs}
    lines += ["", "Largest |Δ| over the 21 cases (pointwise, where x* is not zero) and the load's-scale error "
              "(as the peer's table):", "",
              "| model | flap |Δ| [%] | lag |Δ| [%] | twist |Δ| [%] | err flap [%] | err lag [%] | err twist [%] |",
              "|---|---:|---:|---:|---:|---:|---:|"]
    for lib in libs:
        n = lib["elements"]
        lines.append(f"| library, {n} C1 elements | {100 * worst[n]['flap']:.3f} | {100 * worst[n]['lag']:.3f} | "
                     f"{100 * worst[n]['twist']:.3f} | {100 * lib_err[n]['flap']:.4f} | "
                     f"{100 * lib_err[n]['lag']:.4f} | {100 * lib_err[n]['twist']:.4f} |")

    # timings, and the peer at 1 %
    ok = [ne for ne in meshes if max(peer_err[ne].values()) <= 0.01]
    best = min(ok) if ok else None
    lines += ["", "### Timings", "",
              "| run | DOFs | compile [s] (per load: 1, 2, 3 lbf) | solve per case [s] (mean; min-max) | "
              "21 cases [s] |", "|---|---:|---|---|---:|"]
    for lib in libs:
        runs = [c["run_s"] for c in lib["cases"].values()]
        comp = lib["compile_s"]
        lines.append(f"| library, {lib['elements']} elements | {next(iter(lib['cases'].values()))['dofs']} | "
                     + ", ".join(f"{comp[P]:.1f}" for P in pb.LOADS) + f" | {np.mean(runs):.3f}; "
                     f"{min(runs):.3f}-{max(runs):.3f} | {sum(runs):.2f} (+ {sum(comp.values()):.1f} compiling) |")
    for ne in ([best] if best is not None and best != fine else []) + [fine]:
        walls = [peer[(ne, P, a)]["wall"] for P in pb.LOADS for a in PR_ANGLES]
        label = f"peer, {ne} elements" + (" (the cheapest within 1 %)" if ne == best else "")
        lines.append(f"| {label} | {peer[(ne, *hard)]['dofs']} | – | {np.mean(walls):.4f}; "
                     f"{min(walls):.4f}-{max(walls):.4f} | {sum(walls):.2f} |")
    if best is not None:
        lines += ["", f"The cheapest Exudyn mesh of the grid within 1 % of x* (every output, every load, the error "
                  f"measure above): {best} elements (errors flap {100 * peer_err[best]['flap']:.3f} %, lag "
                  f"{100 * peer_err[best]['lag']:.3f} %, twist {100 * peer_err[best]['twist']:.3f} %)."]
    return {"peer": peer, "rich": rich, "libs": libs, "worst": worst, "lib_err": lib_err, "peer_err": peer_err,
            "best": best, "meshes": meshes}


# ================================================================================================
# The lateral buckling
# ================================================================================================

def _drive(t: float):
    """The crank's angle about −y and its rate (``motion.HalfCosine(π, T)``)."""
    if t >= lb.T_DRIVE:
        return np.pi, 0.0
    w = np.pi / lb.T_DRIVE
    return 0.5 * np.pi * (1.0 - np.cos(w * t)), 0.5 * np.pi * w * np.sin(w * t)


def exudyn_lateral_buckling(elements: int, h: float, link_elements: int = LB_LINK, crank_elements: int = LB_CRANK,
                            rho_inf: float = LB_RHO_INF, newton_rtol: float = NEWTON_RTOL, t_end: float = LB_T_END,
                            out: float = LB_DT_OUT, imperfection: float = lb.IMPERFECTION) -> dict:
    """The lateral buckling in Exudyn (module docstring): ``elements`` beams in the beam (even: a
    node at mid-span), ``link_elements`` (even) and ``crank_elements``, fixed steps ``h``. Returns
    the example's sensors sampled every ``out``."""
    import exudyn as exu
    from exudyn.itemInterface import (
        GenericJoint,
        MarkerBodyRigid,
        MarkerNodeRigid,
        NodeRigidBodyEP,
        ObjectBeamGeometricallyExact,
        ObjectGround,
        ObjectJointSpherical,
        SensorBody,
        SensorNode,
        SensorObject,
    )

    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    p = {k: np.asarray(v) for k, v in lb.points(imperfection).items()}

    def bar(S, start, R, length, n):
        ep = _ep(R)
        nodes = [mbs.AddNode(NodeRigidBodyEP(referenceCoordinates=list(start + R[:, 0] * length * k / n) + ep))
                 for k in range(n + 1)]
        sec = _beam_section(exu, section_of(S))
        beams = [mbs.AddObject(ObjectBeamGeometricallyExact(nodeNumbers=[nodes[k], nodes[k + 1]], length=length / n,
                                                            sectionData=sec)) for k in range(n)]
        return nodes, beams

    I3 = np.eye(3)
    beam, beam_el = bar(lb.BEAM_SECTION, p["R"], I3, lb.L_BEAM, elements)
    link, link_el = bar(lb.LINK_SECTION, p["C"], lb.DOWN, lb.L_LINK, link_elements)
    crank, _ = bar(lb.CRANK_SECTION, p["G"], I3, lb.L_CRANK, crank_elements)
    ground = mbs.AddObject(ObjectGround())

    def on_ground(x):
        return mbs.AddMarker(MarkerBodyRigid(bodyNumber=ground, localPosition=list(x)))

    def on_node(n):
        return mbs.AddMarker(MarkerNodeRigid(nodeNumber=n))

    mbs.AddObject(GenericJoint(markerNumbers=[on_ground(p["R"]), on_node(beam[0])], constrainedAxes=[1] * 6))
    # C: fixed in the tip's section frame, d along its y (the last element's end is the tip node's frame)
    c_beam = mbs.AddMarker(MarkerBodyRigid(bodyNumber=beam_el[-1],
                                           localPosition=[0.5 * lb.L_BEAM / elements, imperfection, 0.0]))
    mbs.AddObject(ObjectJointSpherical(markerNumbers=[c_beam, on_node(link[0])]))
    # B: the link's frame (DOWN) and the crank's (identity) share y, the hinge's axis
    mbs.AddObject(GenericJoint(markerNumbers=[on_node(link[-1]), on_node(crank[-1])],
                               constrainedAxes=[1, 1, 1, 1, 0, 1]))
    drive = mbs.AddObject(GenericJoint(markerNumbers=[on_ground(p["G"]), on_node(crank[0])], constrainedAxes=[1] * 6,
                                       offsetUserFunction=lambda mbs, t, i, q: [0, 0, 0, 0, -_drive(t)[0], 0],
                                       offsetUserFunction_t=lambda mbs, t, i, q: [0, 0, 0, 0, -_drive(t)[1], 0]))
    OV = exu.OutputVariableType

    def node_sensor(n, ov):
        return mbs.AddSensor(SensorNode(nodeNumber=n, storeInternal=True, outputVariableType=ov))

    s_tip, s_tip_R = node_sensor(beam[-1], OV.Position), node_sensor(beam[-1], OV.RotationMatrix)
    s_mid, s_mid_R = node_sensor(beam[elements // 2], OV.Position), node_sensor(beam[elements // 2], OV.RotationMatrix)
    s_N = [mbs.AddSensor(SensorBody(bodyNumber=link_el[k], localPosition=[0, 0, 0], storeInternal=True,
                                    outputVariableType=OV.ForceLocal))
           for k in (link_elements // 2 - 1, link_elements // 2)]
    s_T = mbs.AddSensor(SensorObject(objectNumber=drive, storeInternal=True, outputVariableType=OV.TorqueLocal))
    mbs.Assemble()
    settings = _settings(exu, h, t_end, rho_inf, out, newton_rtol)
    settings.linearSolver.solverType = exu.LinearSolverType.EigenSparse
    t0 = time.perf_counter()
    exu.SolveDynamic(mbs, settings)
    wall = time.perf_counter() - t0

    def data(k):
        return np.asarray(mbs.GetSensorStoredData(k))

    tip, mid = data(s_tip), data(s_mid)
    ts = np.arange(0.0, t_end + 1e-9, out)

    def on(d, col):  # onto the output grid (the stored times are on it to round-off)
        return np.interp(ts, d[:, 0], d[:, col] if np.ndim(col) == 0 else col)

    res = {"ts": ts, "tip_y": on(tip, 2), "tip_z": on(tip, 3),
           "tip_twist": on(tip, twist_of(data(s_tip_R)[:, 1:].reshape(-1, 3, 3))),
           "mid_y": on(mid, 2), "mid_twist": on(mid, twist_of(data(s_mid_R)[:, 1:].reshape(-1, 3, 3))),
           "link_N": on(tip, 0.5 * (data(s_N[0])[:, 1] + data(s_N[1])[:, 1])),
           # the driving joint's torque in J0 = the ground's axes, about −y: while the crank pushes B up it is
           # the link's compression times the crank's lever, positive (the driver does work on the mechanism)
           "drive_torque": on(tip, -data(s_T)[:, 2]),
           "wall": wall, "dofs": mbs.systemData.ODE2Size(), "steps": int(round(t_end / h)),
           "version": exu.__version__}
    return res


def _window(ts, w):
    return (ts >= w[0] - 1e-9) & (ts <= w[1] + 1e-9)


def _lb_err(y, ref, ts, w):
    """max over the window of |y − x*| / max over the window |x*|."""
    m = _window(ts, w)
    return float(np.max(np.abs(y[m] - ref[m])) / np.max(np.abs(ref[m])))


def _peak(y, ts, w):
    return float(np.max(np.abs(y[_window(ts, w)])))


def _onset(ts, r):
    """The first output time at which |mid_y| exceeds 1 mm, and the link's compression then."""
    k = int(np.argmax(np.abs(r["mid_y"]) > 1e-3))
    return float(ts[k]), float(-r["link_N"][k])


UNITS = {"tip_y": (1e3, "mm"), "tip_z": (1e3, "mm"), "tip_twist": (1.0, "rad"), "mid_y": (1e3, "mm"),
         "mid_twist": (1.0, "rad"), "link_N": (1e-3, "kN"), "drive_torque": (1.0, "N·m")}


def lateral_buckling_section(lines, args):
    ts = np.arange(0.0, LB_T_END + 1e-9, LB_DT_OUT)
    h0, ne0 = args.lb_h, args.lb_step_mesh
    grid = [(ne, h0) for ne in args.lb_meshes] + [(ne0, h) for h in args.lb_steps]
    grid += [(ne, h) for ne, h in args.lb_extra]
    runs = {}
    for ne, h in dict.fromkeys(grid):
        runs[(ne, h)] = exudyn_lateral_buckling(ne, h)
        print("exudyn lateral buckling", ne, h, f"{runs[(ne, h)]['wall']:.1f} s", flush=True)
    n_f, n_c, n_cc = args.lb_meshes[-1], args.lb_meshes[-2], args.lb_meshes[-3]
    fine, coarse, coarser = runs[(n_f, h0)], runs[(n_c, h0)], runs[(n_cc, h0)]
    w1 = WINDOWS[0]
    # observed order in the mesh on the first buckling: max over it of the differences of successive meshes
    m1 = _window(ts, w1)
    order = {q: float(np.log2(np.max(np.abs(coarser[q] - coarse[q])[m1]) / np.max(np.abs(coarse[q] - fine[q])[m1])))
             for q in LB_CRIT}
    rich_ok = all(1.5 <= order[q] <= 2.6 for q in ("mid_y", "tip_twist"))
    first = ts <= w1[1] + 1e-9
    if rich_ok:  # extrapolated on the first buckling, where the histories converge; the finest run after it
        ref = {q: np.where(first, fine[q] + (fine[q] - coarse[q]) / 3.0, fine[q]) for q in LB_QS}
        ref_label = f"Richardson ({n_c}, {n_f}) to {w1[1]:g} s, {n_f} elements after"
    else:
        ref = {q: fine[q] for q in LB_QS}
        ref_label = f"{n_f} elements"
    for r in runs.values():
        r["err"] = {(q, k): _lb_err(r[q], ref[q], ts, w) for q in LB_QS for k, w in enumerate(WINDOWS)}
    # the peer's own spread in each window: its second-finest mesh against x*, and a step against half of it
    h_a, h_b = sorted(args.lb_steps)[1], sorted(args.lb_steps)[0]
    spread_mesh = {(q, k): _lb_err(coarse[q], ref[q], ts, w) for q in LB_QS for k, w in enumerate(WINDOWS)}
    spread_step = {(q, k): _lb_err(runs[(ne0, h_a)][q], runs[(ne0, h_b)][q], ts, w)
                   for q in LB_QS for k, w in enumerate(WINDOWS)}
    # checks: link and crank meshes, Newton's tolerance
    chk = args.lb_check_mesh
    base = runs.get((chk, h0)) or exudyn_lateral_buckling(chk, h0)
    chk_lc = exudyn_lateral_buckling(chk, h0, link_elements=2 * LB_LINK, crank_elements=2 * LB_CRANK)
    chk_tol = exudyn_lateral_buckling(chk, h0, newton_rtol=1e-7)
    d_lc = max(_lb_err(chk_lc[q], base[q], ts, w1) for q in LB_CRIT)
    d_tol = max(_lb_err(chk_tol[q], base[q], ts, w1) for q in LB_CRIT)
    d_steps = {h: max(_lb_err(runs[(ne0, h)][q], runs[(ne0, h_b)][q], ts, w1) for q in LB_CRIT)
               for h in sorted(args.lb_steps, reverse=True)[:-1]}

    lines += ["", "## (c) The dynamic lateral buckling, 0-0.8 s", "",
              f"Exudyn {fine['version']}: the model of the module docstring; sections as `examples/"
              "lateral_buckling.py`'s (EA, GA_y, GA_z, GJ, EI_y, EI_z, ρA of the beam, link and crank, the inertia "
              f"of the equivalent rectangle), generalized-α (index 3) with ρ∞ = {LB_RHO_INF} at fixed steps h, "
              f"Newton's relative tolerance {NEWTON_RTOL:g}, sparse solver; link and crank on {LB_LINK} and "
              f"{LB_CRANK} elements. Outputs every {1e3 * LB_DT_OUT:g} ms, as the library's (n_out = {len(ts)}). "
              "The drive torque is the driving joint's torque about −y (Exudyn's `TorqueLocal` of the joint, in the "
              "ground's axes, about +y, negated; while the crank pushes B up it is the link's compression times the "
              "crank's lever, positive, as the library's `DriverEffort`); link_N the link's section force at its "
              "middle, tension positive.", "",
              "Three windows: " + "; ".join(f"{a:g}-{b:g} s {WINDOW_NAMES[k]}" for k, (a, b) in enumerate(WINDOWS))
              + ". Only on the first do the histories converge pointwise (the peer's own table below): from about "
              "0.2 s the beam swings sideways through its plane, and there the phase of the swings moves with the "
              "mesh and the step in both codes, so the errors of the later windows measure a phase, and their peaks "
              "(the envelope) are what to compare. Errors: max over a window of |x − x*| / max over it |x*|; x*: "
              f"{ref_label}, h = {1e3 * h0:g} ms"
              + (" (order 2 in the mesh on the first window, observed below)." if rich_ok else
                 " (the observed order is not 2, so no extrapolation)."), "",
              "### The peer's own convergence", "",
              "| elements | h [ms] | DOFs | steps | wall [s] | leaves the plane at [s] | peak mid_y 0-0.2 s [mm] | "
              "peak tip twist 0-0.2 s [rad] | err 0-0.2 s: tip_z / tip twist / mid_y / mid twist / tip_y [%] | "
              "err mid_y, tip twist 0.2-0.4 s [%] | err mid_y, tip twist 0.4-0.8 s [%] | peak mid_y 0.4-0.8 s [mm] |",
              "|---:|---:|---:|---:|---:|---:|---:|---:|---|---|---|---:|"]
    for (ne, h) in sorted(runs, key=lambda k: (k[0], -k[1])):
        r = runs[(ne, h)]
        e = r["err"]
        lines.append(f"| {ne} | {1e3 * h:g} | {r['dofs']} | {r['steps']} | {r['wall']:.1f} | {_onset(ts, r)[0]:.3f} | "
                     f"{1e3 * _peak(r['mid_y'], ts, w1):.2f} | {_peak(r['tip_twist'], ts, w1):.4f} | "
                     + " / ".join(f"{100 * e[(q, 0)]:.2f}" for q in LB_CRIT + ("tip_y",)) + " | "
                     + f"{100 * e[('mid_y', 1)]:.1f}, {100 * e[('tip_twist', 1)]:.1f} | "
                     + f"{100 * e[('mid_y', 2)]:.1f}, {100 * e[('tip_twist', 2)]:.1f} | "
                     + f"{1e3 * _peak(r['mid_y'], ts, WINDOWS[2]):.2f} |")
    lines.append(f"| x* | | | | | {_onset(ts, ref)[0]:.3f} | {1e3 * _peak(ref['mid_y'], ts, w1):.2f} | "
                 f"{_peak(ref['tip_twist'], ts, w1):.4f} | | | | {1e3 * _peak(ref['mid_y'], ts, WINDOWS[2]):.2f} |")
    lines += ["", f"Observed order in the mesh on 0-0.2 s (max differences of {n_cc}/{n_c} and {n_c}/{n_f} elements): "
              + ", ".join(f"{q} {o:.2f}" for q, o in order.items()) + f". The step on {ne0} elements, against "
              f"h = {1e3 * h_b:g} ms, moves the outputs on 0-0.2 s by at most "
              + ", ".join(f"{100 * d:.3f} % (h = {1e3 * h:g} ms)" for h, d in d_steps.items())
              + f". Link and crank on {2 * LB_LINK} and {2 * LB_CRANK} elements instead of {LB_LINK} and {LB_CRANK} "
              f"({chk} beam elements): at most {100 * d_lc:.3f} %; Newton's tolerance 1e-7 instead of "
              f"{NEWTON_RTOL:g}: at most {100 * d_tol:.3f} % (0-0.2 s, the same measure, tip_z, twists and mid_y)."]

    # ---- this library ----
    n = args.lb_elements
    cases = [(f"ANCF {n} el. (the example's default)", {"elements": n}, None)]
    if args.refined:
        cases += [(f"ANCF {2 * n} el.", {"elements": 2 * n}, None),
                  (f"ANCF {2 * n} el., rtol 1e-5", {"elements": 2 * n}, 1e-5)]
    if args.reduced:
        cases.append(("NR-RNCF default (4 el. reduced)", {"formulation": "nr-rncf"}, None))
    lib = []
    for label, params, rtol in cases:
        setup = load_setup("lateral_buckling", params)
        run = run_setup(setup, n_out=len(ts), controller=setup.controller(rtol))
        if not np.allclose(run.ts, ts, atol=1e-12):
            raise RuntimeError("the output times do not match")
        lib.append((label, run, {q: np.asarray(run.series[q]) for q in LB_QS}))
        print(label, run.steps, f"{run.compile_s:.1f} {run.run_s:.2f}", flush=True)

    lines += ["", "### This library against the converged peer", "",
              f"This library: `run_setup(load_setup(\"lateral_buckling\", params), n_out={len(ts)})`, the example's "
              "defaults (rtol 1e-4 unless a row says, ρ∞ = 0.5, link and crank on 2 and 1 elements). A rerun at "
              "another rtol reuses the compiled program (the tolerance is an argument of it).", "",
              "| model | DOFs | steps (rejected) | compile [s] | run [s] | leaves the plane at [s] | "
              "compression then [kN] |", "|---|---:|---:|---:|---:|---:|---:|"]
    for label, run, s in lib:
        t_on, P_on = _onset(ts, s)
        lines.append(f"| {label} | {run.dofs} | {run.steps} ({run.rejected}) | {run.compile_s:.1f} | "
                     f"{run.run_s:.2f} | {t_on:.3f} | {P_on / 1e3:.2f} |")
    t_on, P_on = _onset(ts, ref)
    lines.append(f"| peer x* | | | | | {t_on:.3f} | {P_on / 1e3:.2f} |")
    lines += ["", "Peaks (max |x| over the window) and errors (max |x − x*| / max |x*| over the window, %); beside "
              f"x*, the peer's own spread: its {n_c} elements against x* (mesh) and h = {1e3 * h_a:g} against "
              f"{1e3 * h_b:g} ms on {ne0} elements (step).", "",
              "| output | window | peer x* peak | peer spread: mesh / step [%] | "
              + " | ".join(f"{label}: peak | err [%]" for label, _, _ in lib) + " |",
              "|---|---|---:|---|" + "---:|---:|" * len(lib)]
    for q in LB_QS:
        scale, unit = UNITS[q]
        for k, w in enumerate(WINDOWS):
            row = (f"| {q} [{unit}] | {w[0]:g}-{w[1]:g} s | {scale * _peak(ref[q], ts, w):.4g} | "
                   f"{100 * spread_mesh[(q, k)]:.2f} / {100 * spread_step[(q, k)]:.2f} |")
            for _, _, s in lib:
                row += f" {scale * _peak(s[q], ts, w):.4g} | {100 * _lb_err(s[q], ref[q], ts, w):.2f} |"
            lines.append(row)

    # ---- the peer at 1 % ----
    ok = [k for k, r in runs.items() if max(r["err"][(q, 0)] for q in LB_CRIT) <= 0.01]
    best = min(ok, key=lambda k: runs[k]["wall"]) if ok else None
    walls = []
    if best is not None:
        walls = [runs[best]["wall"]] + [exudyn_lateral_buckling(*best)["wall"] for _ in range(2)]
        r = runs[best]
        lines += ["", "### The peer at 1 %", "",
                  "The cheapest Exudyn run of the grid within 1 % of x* on 0-0.2 s in tip_z, tip twist, mid_y and mid "
                  f"twist: {best[0]} elements, h = {1e3 * best[1]:g} ms ({r['dofs']} coordinates, {r['steps']} steps), "
                  "errors " + ", ".join(f"{q} {100 * r['err'][(q, 0)]:.2f} %" for q in LB_CRIT)
                  + f" (tip_y {100 * r['err'][('tip_y', 0)]:.2f} %). Its wall time over 0-0.8 s (`SolveDynamic`, best "
                  f"of 3): {min(walls):.2f} s (runs {', '.join(f'{w:.2f}' for w in walls)}). This library's ANCF "
                  f"default: run {lib[0][1].run_s:.2f} s after a compilation of {lib[0][1].compile_s:.1f} s, errors "
                  + ", ".join(f"{q} {100 * _lb_err(lib[0][2][q], ref[q], ts, w1):.2f} %" for q in LB_CRIT)
                  + " on the same window."]
    else:
        lines += ["", "No Exudyn run of the grid is within 1 % of x* on 0-0.2 s."]
    return {"ts": ts, "ref": ref, "ref_label": ref_label, "lib": lib, "runs": runs, "best": best, "walls": walls,
            "order": order, "rich_ok": rich_ok, "spread_mesh": spread_mesh, "spread_step": spread_step}


# ================================================================================================

def notes(pr, lbs):
    out = ["## Notes", ""]
    rich, libs = pr["rich"], pr["libs"]
    n0 = libs[0]["elements"]
    w = pr["worst"][n0]
    hard = (pb.LOADS[-1], 45)
    flat = max(rich, key=lambda k: abs(libs[0]["cases"][k]["flap"] / rich[k]["flap"] - 1) if rich[k]["flap"] > 1e-6
               else 0.0)  # the case of the largest flap difference
    out.append(f"- **Princeton beam.** The library's full model on its default {n0} elements lies within "
               f"{100 * w['flap']:.3f} % (flap), {100 * w['lag']:.3f} % (lag) and {100 * w['twist']:.3f} % (twist) of "
               "the converged peer over the 21 load cases (the issue's target: 0.5 %). At 3 lbf and 45° (the "
               f"largest twist): flap {1e3 * libs[0]['cases'][hard]['flap']:.3f} against "
               f"{1e3 * rich[hard]['flap']:.3f} mm, lag {1e3 * libs[0]['cases'][hard]['lag']:.3f} against "
               f"{1e3 * rich[hard]['lag']:.3f} mm, twist {np.degrees(libs[0]['cases'][hard]['twist']):.4f}° against "
               f"{np.degrees(rich[hard]['twist']):.4f}°. The largest difference is the flap at {flat[0]} N and "
               f"{flat[1]}° ({1e3 * libs[0]['cases'][flat]['flap']:.3f} against {1e3 * rich[flat]['flap']:.3f} mm).")
    if len(libs) > 1:
        n1 = libs[1]["elements"]
        w1 = pr["worst"][n1]
        out.append(f"  On {n1} elements: {100 * w1['flap']:.3f}, {100 * w1['lag']:.3f} and {100 * w1['twist']:.3f} % "
                   f"(flap at {flat[0]} N, {flat[1]}°: {1e3 * libs[1]['cases'][flat]['flap']:.3f} mm).")
    out.append("- **Princeton beam, not compared.** Dowell's experiment: `VALIDATION_SET.md` names it but gives no "
               "values. Both codes load the tip with a force fixed in space at the section's centroid, as the "
               "example does.")
    ref, lib, ts = lbs["ref"], lbs["lib"], lbs["ts"]
    out.append("- **Lateral buckling, 0-0.2 s (the onset and the first buckling's peak).** Against the converged "
               "peer: " + "; ".join(
                   f"{label} " + ", ".join(f"{q} {100 * _lb_err(s[q], ref[q], ts, WINDOWS[0]):.2f} %"
                                           for q in LB_CRIT + ("tip_y", "link_N", "drive_torque"))
                   for label, _, s in lib)
               + ". The peer's own spread there (its second-finest mesh against x*): "
               + ", ".join(f"{q} {100 * lbs['spread_mesh'][(q, 0)]:.2f} %" for q in LB_CRIT)
               + ". Onset (|mid_y| > 1 mm): " + ", ".join(f"{label} {_onset(ts, s)[0]:.3f} s" for label, _, s in lib)
               + f", peer {_onset(ts, ref)[0]:.3f} s.")
    for k, name in ((1, "0.2-0.4 s (the crank comes down, the beam swings)"), (2, "0.4-0.8 s (held)")):
        wd = WINDOWS[k]
        out.append(f"- **Lateral buckling, {name}.** Peaks of mid_y: "
                   + ", ".join(f"{label} {1e3 * _peak(s['mid_y'], ts, wd):.2f}" for label, _, s in lib)
                   + f" mm against the peer's {1e3 * _peak(ref['mid_y'], ts, wd):.2f} mm; of the tip twist: "
                   + ", ".join(f"{_peak(s['tip_twist'], ts, wd):.4f}" for _, _, s in lib)
                   + f" against {_peak(ref['tip_twist'], ts, wd):.4f} rad. Errors of the histories, mid_y and tip "
                   "twist: " + ", ".join(f"{label} {100 * _lb_err(s['mid_y'], ref['mid_y'], ts, wd):.1f} and "
                                         f"{100 * _lb_err(s['tip_twist'], ref['tip_twist'], ts, wd):.1f} %"
                                         for label, _, s in lib)
                   + "; the peer's own spread (mesh / step): "
                   + f"{100 * lbs['spread_mesh'][('mid_y', k)]:.1f} / {100 * lbs['spread_step'][('mid_y', k)]:.1f} "
                   + f"and {100 * lbs['spread_mesh'][('tip_twist', k)]:.1f} / "
                   + f"{100 * lbs['spread_step'][('tip_twist', k)]:.1f} %.")
    return out


def figure(pr, lbs, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(2, 3, figsize=(15, 8))
    libs = pr["libs"]
    for k, (q, scale, unit) in enumerate((("flap", 1e3, "mm"), ("lag", 1e3, "mm"), ("twist", np.degrees(1.0), "deg"))):
        a = ax[0, k]
        for j, P in enumerate(pb.LOADS):
            c = f"C{j}"
            a.plot(PR_ANGLES, [scale * pr["rich"][(P, t)][q] for t in PR_ANGLES], "-", color=c, lw=2,
                   label=f"Exudyn x*, {P} N")
            a.plot(PR_ANGLES, [scale * libs[0]["cases"][(P, t)][q] for t in PR_ANGLES], "o", color=c, mfc="none",
                   label=f"library, {libs[0]['elements']} el., {P} N")
        a.set(xlabel="load angle θ [deg]", ylabel=f"tip {q} [{unit}]", title=f"Princeton beam: tip {q}")
    ts, ref = lbs["ts"], lbs["ref"]
    for k, (q, scale, unit) in enumerate((("tip_z", 1e3, "mm"), ("mid_y", 1e3, "mm"), ("tip_twist", 1.0, "rad"))):
        a = ax[1, k]
        a.plot(ts, scale * ref[q], "k-", lw=2.5, label=f"Exudyn x* ({lbs['ref_label']})")
        for label, _, s in lbs["lib"]:
            a.plot(ts, scale * s[q], "--", lw=1, label=label.split(" (")[0])
        a.set(xlabel="t [s]", ylabel=f"{q} [{unit}]", title=f"lateral buckling: {q}")
    for a in ax.flat:
        a.legend(fontsize=6)
        a.grid(alpha=0.3)
    fig.tight_layout()
    os.makedirs(os.path.dirname(path), exist_ok=True)
    fig.savefig(path, dpi=100)


def _pairs(text):
    out = []
    for item in text.split(","):
        if item.strip():
            ne, h = item.split(":")
            out.append((int(ne), float(h)))
    return out


def parse(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--quick", action="store_true", help="coarse grids (a smoke test; the page is then not the record)")
    p.add_argument("--no-reduced", dest="reduced", action="store_false",
                   help="skip the library's reduced lateral-buckling default (about a minute)")
    p.add_argument("--no-refined", dest="refined", action="store_false",
                   help="skip the library's refined runs (16 Princeton elements; 8 lateral-buckling elements "
                        "at rtol 1e-4 and 1e-5)")
    p.add_argument("--pr-elements", type=int, default=8, help="the library's Princeton mesh (the example's default 8)")
    p.add_argument("--lb-elements", type=int, default=4, help="the library's lateral-buckling mesh (default 4)")
    p.add_argument("--pr-meshes", type=lambda s: tuple(int(x) for x in s.split(",")), default=PR_MESHES,
                   help="the peer's Princeton meshes, ascending; the last two extrapolated (default 4,...,256)")
    p.add_argument("--lb-meshes", type=lambda s: tuple(int(x) for x in s.split(",")), default=(8, 16, 32, 64),
                   help="the peer's lateral-buckling meshes at --lb-h, ascending (default 8,16,32,64)")
    p.add_argument("--lb-h", type=float, default=1.25e-4, help="the peer's step of the mesh study [s]")
    p.add_argument("--lb-steps", type=lambda s: tuple(float(x) for x in s.split(",")),
                   default=(5e-4, 2.5e-4, 1.25e-4, 6.25e-5), help="the peer's steps of the step study (dividing 1 ms)")
    p.add_argument("--lb-step-mesh", type=int, default=16, help="the beam mesh of the step study")
    p.add_argument("--lb-check-mesh", type=int, default=16, help="the beam mesh of the link/crank and Newton checks")
    p.add_argument("--lb-extra", type=_pairs, default=_pairs("24:2.5e-4,32:5e-4,32:2.5e-4"),
                   help="further peer runs for the cheapest within 1 %%, 'elements:h,...'")
    p.add_argument("--out", default=os.path.join(HERE, "results", "peer_exudyn_beams.md"))
    args = p.parse_args(argv)
    if args.quick:
        args.pr_meshes, args.lb_meshes, args.lb_h = (8, 16, 32), (4, 8, 16), 2.5e-4
        args.lb_steps, args.lb_step_mesh, args.lb_check_mesh, args.lb_extra = (5e-4, 2.5e-4), 8, 8, []
    return args


def main(argv=None):
    args = parse(argv)
    if missing("exudyn", "pip install exudyn"):
        return 1
    pin_to_one_core()
    t_start = time.perf_counter()
    lines = ["# The Princeton beam and the lateral buckling against an independent code (Exudyn, 3-D beams)", "",
             f"Produced by `benchmarks/peer_exudyn_beams.py` in one invocation{' (--quick)' if args.quick else ''}. "
             f"Machine: {machine()}. The machine was shared: other jobs ran on the other core throughout, so the "
             "wall times are loaded ones (compare them with each other, not with other pages).", "",
             "Exudyn's 3-D geometrically exact beam (`ObjectBeamGeometricallyExact`, 2-node, shear-deformable, "
             "Simo-Reissner strains constant in each element) on Euler-parameter nodes, as in `peer_exudyn_3d.md`; the "
             "model and its sensors are in the script's docstring. Wall times: Exudyn's `SolveStatic` and "
             "`SolveDynamic` (no compilation); this library's compile and run timed apart (`block_until_ready`).", ""]
    pr = princeton_section(lines, args)
    lbs = lateral_buckling_section(lines, args)
    fig_name = os.path.splitext(os.path.basename(args.out))[0] + ".png"
    figure(pr, lbs, os.path.join(os.path.dirname(args.out), "figures", fig_name))
    lines += ["", f"![Princeton beam and lateral buckling against the peer](figures/{fig_name})", ""]
    lines += notes(pr, lbs)
    lines += ["", f"Whole script: {time.perf_counter() - t_start:.0f} s."]
    report("\n".join(lines) + "\n", args.out, keep_notes="## Notes (by hand)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
