"""The validation set's first steps (issue 59): joints that converge, real sections, the four-bar.

1. A cantilever's tip section turned by θ = 1e-3 about Z by a driver (``angle_driver``), on 2-32
   C1 elements: the driver's torque against EIθ/L, with the driver on the section frame (the
   library's) and, for comparison, the same driver written on the tip's slope r_x (the
   formulation the section frames replaced; a joint class of this script only).
2. Sections: a square 16 mm steel bar and the Princeton beam's sectional data (``sectional``),
   twisted and bent the same way: GJ, EI_y, EI_z against the closed forms.
3. The four-bar (``examples/fourbar.py``) over 0-2 s, full order (ANCF) on 2, 4 and 8 elements a
   bar and reduced (NR-RNCF) with three bases: C's out-of-plane position, the crank's mid-span
   bending moment and the drive torque at t = 2 s, against the finest ANCF mesh. One core pinned;
   compile and run timed apart (``run_setup``).

4. The rotating shaft (``examples/rotating_shaft.py``): frequencies at rest against Rayleigh's
   critical speed, the whirl's peaks before and after the crossing, full and reduced.
5. The Princeton beam (``examples/princeton_beam.py``): tip flap, lag and twist for the three
   loads and load angles 0-90°, with the linear limit beside them.
6. Lateral buckling of the lateral-buckling problem's cantilever: the load where the static
   tangent loses stability, against Prandtl's closed form.

No independent code ran here: the figures are checked against mesh refinement, closed forms and
the issue's peer figures for the four-bar (C_z ≈ 3.04 mm, M ≈ 77-79 N·m).

    python benchmarks/validation.py  ->  benchmarks/results/validation.md
"""

import os
import sys

import jax

jax.config.update("jax_enable_x64", True)

import equinox as eqx  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _machine import machine, pin_to_one_core, report  # noqa: E402

from nrrncf_jax.bodies import Material, RectangleSection, TubeSection, beam_body, sectional, straight_reference  # noqa: E402,E501
from nrrncf_jax.elements.section import rectangle_torsion_constant  # noqa: E402
from nrrncf_jax.integrate import constrained_equilibrium  # noqa: E402
from nrrncf_jax.motion import SteadySpin  # noqa: E402
from nrrncf_jax.multibody import AbstractJoint, Marker, Mechanism, angle_driver, clamp  # noqa: E402
from nrrncf_jax.scenarios.mechanism_file import load_setup, run_setup  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
THETA = 1e-3
MESHES = (2, 4, 8, 16, 32)


class SlopeDriver(AbstractJoint):
    """The replaced formulation, for comparison: the tip's angle about Z measured on its slope
    r_x against the fixed x and y, r_x·(cos φ y − sin φ x) = 0 (as the drivers were written
    before the section frames)."""

    body: int = eqx.field(static=True)
    slope: int = eqx.field(static=True)
    phi: float = eqx.field(static=True)

    n_equations = 1
    rheonomic = True

    def references(self):
        return [(self.body, self.slope)]

    def __call__(self, xs, t=0.0):
        phi = self.phi * t
        return (xs[self.body][self.slope] @ jnp.array([-jnp.sin(phi), jnp.cos(phi), 0.0]))[None]


def _tip_torque(beam, L, axis, slope=False):
    joints = [clamp(None, Marker(0, (0.0, 0.0, 0.0)))]
    if slope:
        joints.append(SlopeDriver(0, beam.n_vectors - 6 + 1, THETA))
    else:
        joints.append(angle_driver(None, Marker(0, (L, 0.0, 0.0)), axis, SteadySpin(THETA)))
    mech = Mechanism([beam], joints)
    lam = constrained_equilibrium(mech, t=1.0).lam[mech.joint_slices()[1]]
    return float(-lam[0]) * L / THETA


def joints_table() -> str:
    E, r, L = 2.1e11, 0.02, 1.0
    EI = E * np.pi * r**4 / 4
    rows = ["| elements | section frame: torque / (EIθ/L) − 1 | slope r_x: torque / (EIθ/L) |", "|---:|---:|---:|"]
    for n in MESHES:
        beam = beam_body(Material(E, 7800.0, 0.3), TubeSection(r), straight_reference(L, n))
        frame = _tip_torque(beam, L, (0.0, 0.0, 1.0)) / EI - 1
        slope = _tip_torque(beam, L, None, slope=True) / EI
        rows.append(f"| {n} | {frame:.1e} | {slope:.3f} |")
    return "\n".join(rows)


def sections_table() -> str:
    E, nu = 207e9, 0.3
    G = E / (2 * (1 + nu))
    a = 0.016
    square = (Material(E, 7800.0, nu), RectangleSection(a))
    expected_sq = (G * rectangle_torsion_constant(a, a), E * a**4 / 12, E * a**4 / 12)
    princeton = sectional(EA=2.84191e6, EI_y=36.2794, EI_z=2.42873, GJ=3.10338, rhoA=0.548)
    expected_pr = (3.10338, 36.2794, 2.42873)
    rows = ["| section | elements | GJ / closed form − 1 | EI_y / closed form − 1 | EI_z / closed form − 1 |",
            "|---|---:|---:|---:|---:|"]
    for name, (mat, sec), expected in (("square 16 mm steel", square, expected_sq),
                                       ("Princeton (sectional)", princeton, expected_pr)):
        for n in (2, 8, 32):
            beam = beam_body(mat, sec, straight_reference(1.0, n))
            got = [_tip_torque(beam, 1.0, axis) for axis in np.eye(3)]
            rows.append(f"| {name} | {n} | " + " | ".join(f"{g / e - 1:.1e}" for g, e in zip(got, expected)) + " |")
    rows.append("")
    rows.append(f"Square 16 mm: J = {rectangle_torsion_constant(a, a) / a**4:.6f} a⁴ (Saint-Venant), GJ = "
                f"{expected_sq[0]:.3f} N·m² (VALIDATION_SET.md: 733.488); the polar moment would give "
                f"{G * a**4 / 6:.3f} (+{(a**4 / 6) / rectangle_torsion_constant(a, a) * 100 - 100:.1f} %).")
    return "\n".join(rows)


FOURBAR_CASES = [  # (label, parameters of examples/fourbar.py)
    ("ANCF", {"elements": 2}), ("ANCF", {"elements": 4}), ("ANCF", {"elements": 8}),
    ("NR-RNCF, the default: force, moment and section attachment modes + the MDs of fz, mx, my (rtol 1e-3)",
     {"formulation": "nr-rncf", "elements": 4}),
    ("NR-RNCF, 1 VM + moment and force attachment modes + all their MDs (rtol 1e-4)",
     {"formulation": "nr-rncf", "elements": 4, "vms": 1, "interface_mds": True, "interface_sections": False,
      "rtol": 1e-4}),
    ("NR-RNCF, 3 VMs + 6 MDs + moment and force attachment modes (rtol 1e-4)",
     {"formulation": "nr-rncf", "elements": 4, "vms": 3, "interface_mds": False, "interface_sections": False,
      "rtol": 1e-4}),
    ("NR-RNCF, 3 VMs + 6 MDs + force attachment modes only (rtol 1e-4)",
     {"formulation": "nr-rncf", "elements": 4, "vms": 3, "interface_mds": False, "interface_sections": False,
      "interface_rotations": False, "rtol": 1e-4}),
]


def fourbar_table() -> str:
    runs = [(label, params, run_setup(load_setup("fourbar", params), n_out=41)) for label, params in FOURBAR_CASES]
    ref = runs[2][2]
    rows = ["| model | elements a bar | DOFs | steps (rejected) | compile [s] | run [s] | C_z(2 s) [mm] | "
            "crank M(2 s) [N·m] | drive torque (2 s) [N·m] | max abs ΔC_z vs ANCF 8 [mm] | max abs ΔM vs ANCF 8 "
            "[N·m] |", "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for label, params, run in runs:
        s = run.series
        dC = np.abs(s["C_z"] - ref.series["C_z"]).max() * 1e3
        dM = np.abs(s["crank_M"] - ref.series["crank_M"]).max()
        rows.append(f"| {label} | {params['elements']} | {run.dofs} | {run.steps} ({run.rejected}) | "
                    f"{run.compile_s:.1f} | {run.run_s:.2f} | {s['C_z'][-1] * 1e3:.5f} | {s['crank_M'][-1]:.3f} | "
                    f"{s['drive_torque'][-1]:.4f} | {dC:.2e} | {dM:.3f} |")
    return "\n".join(rows)


def shaft_table() -> str:
    """The rotating shaft (``examples/rotating_shaft.py``) over 0-2.5 s: the first bending
    frequencies at rest against Rayleigh's, and the whirl's peak on the 48 rad/s plateau and after
    the crossing, ANCF on 4, 8, 16 elements and NR-RNCF."""
    from nrrncf_jax.examples.rotating_shaft import critical_speed, mechanism
    from nrrncf_jax.integrate import vibration_frequencies

    rows = ["| model | elements | DOFs | ω₁, ω₂ at rest [rad/s] | steps (rejected) | compile [s] | run [s] | "
            "whirl peak 0.5-1 s [mm] | whirl peak 1.25-2.5 s [mm] |", "|---|---:|---:|---|---:|---:|---:|---:|---:|"]
    for formulation, n in (("ancf", 4), ("ancf", 8), ("ancf", 16), ("nr-rncf", 8)):
        setup = mechanism(formulation, elements=n)
        w = vibration_frequencies(setup.system, constrained_equilibrium(setup.system), count=2)
        run = run_setup(setup, n_out=501)
        whirl = np.hypot(run.series["mid_y"], run.series["mid_z"]) * 1e3
        before, after = (run.ts > 0.5) & (run.ts < 1.0), run.ts > 1.25
        rows.append(f"| {formulation} | {n} | {run.dofs} | {w[0]:.3f}, {w[1]:.3f} | {run.steps} ({run.rejected}) | "
                    f"{run.compile_s:.1f} | {run.run_s:.2f} | {whirl[before].max():.2f} | {whirl[after].max():.2f} |")
    rows.append(f"\nRayleigh's first critical speed (clamped-clamped shaft, disk at mid-span): {critical_speed():.3f} "
                "rad/s.")
    return "\n".join(rows)


def princeton_table() -> str:
    """The Princeton beam's tip flap, lag and twist at the three loads and seven load angles (8
    elements; ``examples/princeton_beam.py``), and the linear limit's flap and lag."""
    from nrrncf_jax.examples.princeton_beam import LOADS, linear_tip, mechanism
    from nrrncf_jax.multibody.sensors import observe

    rows = ["| load [N] | angle [deg] | flap [mm] | lag [mm] | twist [deg] | linear flap [mm] | linear lag [mm] | "
            "Newton corrections |", "|---:|---:|---:|---:|---:|---:|---:|---|"]
    for P in LOADS:
        for angle in range(0, 91, 15):
            setup = mechanism(load=P, angle_deg=float(angle))
            eq = constrained_equilibrium(setup.system, t=1.0, load_steps=10)
            out = observe(setup.system, setup.sensors)(1.0, eq.z, 0.0 * eq.z)
            flap, lag = linear_tip(P, float(angle))
            rows.append(f"| {P} | {angle} | {-1e3 * float(out['tip_z']):.2f} | {-1e3 * float(out['tip_y']):.2f} | "
                        f"{np.degrees(float(out['twist'])):.3f} | {1e3 * flap:.2f} | {1e3 * lag:.2f} | "
                        f"{np.asarray(eq.iterations).tolist()} |")
    return "\n".join(rows)


def buckling_table() -> str:
    """The lateral-torsional buckling load of the validation set's cantilever (problem (c)'s beam
    alone, tip load at the centroid) where ``integrate.stability`` crosses zero (interpolated
    between 0.95 and 1.05 of Prandtl's load) on 4, 8 and 16 elements, against Prandtl's
    4.013 √(EI GJ)/L²."""
    from nrrncf_jax.integrate import stability
    from nrrncf_jax.multibody import actuator

    SECTION = dict(EA=73e6, EI_y=60830.0, EI_z=608.3, GJ=877.2, rhoA=2.68)

    def lowest(mech, P):
        loaded = Mechanism(mech.bodies, mech.joints, forces=[actuator(None, Marker(0, (1.0, 0.0, 0.0)),
                                                                      lambda t, s, v, p: p * t, params=P,
                                                                      axis=(0.0, 0.0, -1.0))])
        return float(stability(loaded, constrained_equilibrium(loaded, t=1.0, load_steps=4), t=1.0)[0])

    P = 4.013 * np.sqrt(SECTION["EI_z"] * SECTION["GJ"])
    rows = ["| elements | P_cr / P_Prandtl |", "|---:|---:|"]
    material, section = sectional(**SECTION)
    for n in (4, 8, 16):
        mech = Mechanism([beam_body(material, section, straight_reference(1.0, n))],
                         [clamp(None, Marker(0, (0.0, 0.0, 0.0)))])
        below, above = (lowest(mech, f * P) for f in (0.95, 1.05))
        rows.append(f"| {n} | {0.95 + 0.1 * below / (below - above):.4f} |")
    rows.append(f"\nP_Prandtl = {P:.1f} N; with the bending before buckling, Kirby & Nethercot's correction "
                f"1/√((1 − EI_soft/EI_stiff)(1 − GJ/EI_stiff)) = "
                f"{1 / np.sqrt((1 - 608.3 / 60830) * (1 - 877.2 / 60830)):.4f}.")
    return "\n".join(rows)


def main() -> None:
    pin_to_one_core()
    text = "\n\n".join([
        "# Validation set: joints, sections, the four-bar (issue 59)",
        f"Machine: {machine()}.",
        "## A tip moment through a driver (θ = 1e-3, tube r = 20 mm, L = 1 m)\n\n" + joints_table(),
        "## Sections: torsion and bending stiffness at the tip (θ = 1e-3, L = 1 m)\n\n" + sections_table(),
        "## The four-bar, 0-2 s (ρ∞ = 0.5; the example's rtol, 1e-4 for ANCF and 1e-3 for the reduced default, "
        "unless a row says)\n\n" + fourbar_table(),
        "## The rotating shaft, 0-2.5 s (rtol 1e-4, ρ∞ = 0.6)\n\n" + shaft_table(),
        "## The Princeton beam, static (8 elements, 10 load increments)\n\n" + princeton_table(),
        "## Lateral buckling of the cantilever (dead tip load at the centroid)\n\n" + buckling_table(),
    ]) + "\n"
    report(text, os.path.join(HERE, "results", "validation.md"), keep_notes="## Notes")


if __name__ == "__main__":
    main()
