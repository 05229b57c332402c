"""The flexible four-bar of the field's validation set (Bauchau et al., Multibody System Dynamics
37 (2016) 29-48, problem (b); data in ``VALIDATION_SET.md``): a spatial mechanism over-constrained
by a tilted hinge, which only the bars' flexibility lets move.

Points A (0, 0, 0), B (0, 0.12, 0), C (0.24, 0.12, 0), D (0.24, 0, 0) m: the crank AB and the
coupler BC are steel bars of 16 × 16 mm, the follower DC one of 8 × 8 mm (E = 207 GPa, ν = 0.3,
ρ = 7800 kg/m³, Saint-Venant torsion: ``elements.section.RectangleSection``), no gravity. Hinges
at A, B and D about Z; the hinge at C about the global (sin 5°, 0, cos 5°). The crank is driven
at Ω = 0.6 rad/s about Z from t = 0, from the undeformed reference with the rigid
parallelogram's velocities (crank and follower at Ω about Z, the coupler translating at
(−0.072, 0, 0) m/s), which violate the tilted hinge at velocity level: the integrator absorbs
that in a small, decaying ringing (``VALIDATION_SET.md``).

Every joint holds the bars by their section frames (``multibody.section_frame``): a hinge's
reaction moments and the drive torque act on the cross-sections, and the answer converges under
mesh refinement (a hinge written on the beam's slope would not: ``multibody.section_frame``).

The bars are ``formulation="ancf"`` (``elements`` C1 elements a bar, in the inertial frame) or
``"nr-rncf"`` (each bar in a floating frame at its first end, ``multibody.reduce``): the bars are
loaded at their ends and move quasi-statically, far below their vibrations, so the attachment
modes of the other end's force and moment carry the deformation (``interface_rotations``) and
no vibration mode is needed (``vms = 0``). The tilted hinge pushes the mechanism out of its
plane: the force normal to it (each bar's section axis z), the twist and the out-of-plane
bending moment deform the bars beyond the linear range, and the modal derivatives of those
three loads' modes carry the geometric nonlinearity (``interface_mds = ("fz", "mx", "my")``;
without derivatives the reduced out-of-plane motion is far off), while the
in-plane loads' modes (axial force, in-plane shear and bending) stay linear. The attachment
modes of the far end's section stretch and shear (``interface_sections``) free the section the
joint turns, which the crank's mid-span axial force ``crank_N`` reads (``multibody.reduce``).
``interface_mds=True`` and ``vms`` ≥ 1 give the derivatives of every pair and vibration modes
too, at a higher cost a step (the reduced cubic force grows as the fourth power of the
columns). The documentation's validation results compare these choices with an independent
code.

Sensors (``nrrncf run fourbar --out F.csv``): ``C_x, C_y, C_z`` the coupler's end at C in space
[m]; ``crank_N``, ``crank_T``, ``crank_M`` the crank's mid-span axial force [N], torque and
bending-moment magnitude [N·m] (``post.stress.SectionResultant``); ``drive_torque`` the torque
driving the crank [N·m].
"""

import numpy as np

from ..bodies import Material, RectangleSection, beam_body, straight_reference
from ..motion import SteadySpin
from ..multibody import Marker, Mechanism, hinge, placed
from ..multibody.reduce import reduce
from ..multibody.sensors import DriverEffort, Position
from ..post.stress import SectionResultant
from ..scenarios.mechanism_file import MechanismSetup

CRANK, COUPLER, FOLLOWER = 0, 1, 2
A, B, C, D = (0.0, 0.0, 0.0), (0.0, 0.12, 0.0), (0.24, 0.12, 0.0), (0.24, 0.0, 0.0)
Z = (0.0, 0.0, 1.0)
E_STEEL, NU, RHO = 207e9, 0.3, 7800.0
Y_UP = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # the beam's x onto y, its y onto −x


def _bar(start, end, side, elements):
    """A C1 beam of square section ``side`` from ``start`` to ``end`` (along x or y)."""
    start, end = np.asarray(start), np.asarray(end)
    length = float(np.linalg.norm(end - start))
    body = beam_body(Material(E_STEEL, RHO, NU), RectangleSection(side), straight_reference(length, elements))
    along_y = abs((end - start)[1]) > 0
    return placed(body, rotation=Y_UP if along_y else None, translation=start)


def mechanism(formulation: str = "ancf", elements: int = 4, tilt_deg: float = 5.0, omega: float = 0.6,
              t_end: float = 2.0, rtol: float | None = None, rho_inf: float = 0.5, vms: int = 0,
              interface_rotations: bool = True, interface_mds=("fz", "mx", "my"),
              interface_sections: bool = True) -> MechanismSetup:
    """The four-bar (module docstring); ``elements`` C1 elements a bar (even: a node at the
    crank's mid-span). ρ∞ = 0.5 suits a quasi-static problem whose bars bend at 0.65-2.6 kHz:
    those vibrations are damped rather than resolved. ``rtol``: by default 1e-4 for the ANCF
    bars and 1e-3 for the reduced ones, whose deformation lies in the static shapes of their
    basis: their error at 1e-3 is the basis's, and the looser tolerance saves steps.
    ``vms``, ``interface_rotations``, ``interface_mds``, ``interface_sections``: the reduced
    bars' basis (``multibody.reduce``; ``interface_mds`` True, False or load names)."""
    if formulation not in ("ancf", "nr-rncf"):
        raise ValueError(f"formulation must be 'ancf' or 'nr-rncf', got {formulation!r}")
    if rtol is None:
        rtol = 1e-4 if formulation == "ancf" else 1e-3
    elements = int(elements)
    if elements < 2 or elements % 2:
        raise ValueError(f"elements must be an even integer >= 2 (a node at the crank's mid-span), got {elements}")
    bars = [_bar(A, B, 0.016, elements), _bar(B, C, 0.016, elements), _bar(D, C, 0.008, elements)]
    if formulation == "nr-rncf":
        ends = [(A, B), (B, C), (D, C)]
        bars = [reduce(bar, list(e), vms=int(vms), mds="all", interface_modes=True,
                       interface_rotations=bool(interface_rotations), interface_mds=interface_mds,
                       interface_sections=bool(interface_sections))
                for bar, e in zip(bars, ends)]
    tilt = np.radians(float(tilt_deg))
    axis_C = (float(np.sin(tilt)), 0.0, float(np.cos(tilt)))
    joints = [hinge(None, Marker(CRANK, A), Z, drive=SteadySpin(omega)),
              hinge(Marker(CRANK, B), Marker(COUPLER, B), Z),
              hinge(Marker(COUPLER, C), Marker(FOLLOWER, C), axis_C),
              hinge(None, Marker(FOLLOWER, D), Z)]
    system = Mechanism(bars, joints)
    w = (0.0, 0.0, float(omega))
    v0 = (system.rigid_velocity(omega=w, bodies=[CRANK])
          + system.rigid_velocity(velocity=np.cross(w, B), bodies=[COUPLER])
          + system.rigid_velocity(velocity=-np.cross(w, D), omega=w, bodies=[FOLLOWER]))
    mid = (0.0, 0.06, 0.0)
    sensors = {"C_x": Position(Marker(COUPLER, C), 0), "C_y": Position(Marker(COUPLER, C), 1),
               "C_z": Position(Marker(COUPLER, C), 2),
               "crank_N": SectionResultant(Marker(CRANK, mid), "N"),
               "crank_T": SectionResultant(Marker(CRANK, mid), "T"),
               "crank_M": SectionResultant(Marker(CRANK, mid), "M"),
               "drive_torque": DriverEffort(1)}
    return MechanismSetup(system, sensors, y0=(system.reference(), v0), t_end=t_end, rtol=rtol, rho_inf=rho_inf,
                          compare=("C_x", "C_y", "C_z"),
                          info={"formulation": formulation, "elements": elements, "tilt_deg": tilt_deg})


__all__ = ["mechanism"]
