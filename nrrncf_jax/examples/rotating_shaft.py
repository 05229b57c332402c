"""The rotating shaft of the field's validation set (Bauchau et al. 2016, problem (d); data in
``VALIDATION_SET.md``): a shaft with an unbalanced disk accelerated through its first critical
speed.

A steel tube of L = 6 m (r_o = 0.05 m, r_i = 0.045 m, E = 210 GPa, ν = 0.3, ρ = 7800 kg/m³) along x,
with a rigid disk at mid-span (m = 70.573 kg, radius 0.24 m, thickness 0.05 m) whose centre of mass
sits 0.05 m off the axis (the unbalance, along y), welded to the shaft's section. The root holds
the shaft's position and its two bending rotations and imposes the spin about x (a driven hinge);
the tip is a bearing: transverse position and bending rotations held, axial motion and spin free
(a cylindrical joint). No gravity, no damping. The spin follows half-cosine ramps, 0 → 48 rad/s
over 0-0.5 s and 48 → 72 rad/s over 1.0-1.25 s (``motion.SpinSchedule``); the first critical
speed of the shaft clamped in bending at both ends with the disk at mid-span is about 57 rad/s
(``critical_speed``, Rayleigh), so the second ramp crosses it and excites a whirl that persists.

``formulation="ancf"`` (``elements`` C1 elements) or ``"nr-rncf"``: the shaft in a floating frame
at its root along its axis, which spins with it, with the reference conditions of its supports
(``multibody.reduce`` with ``conditions="bearing"``: clamped at the root, held in the bearing at
the tip, so the basis carries the tip's bearing and the system drops the cylindrical joint), ``vms``
vibration modes (clamped-clamped in bending), the attachment modes of the disk's forces at
mid-span and the modal derivatives of them all (39 coordinates). It follows the full shaft's whirl
closely at a fraction of its cost.
``conditions="clamped"`` (with ``interface_rotations=True``) is the cantilever basis held at the
root alone: its modes do not know the bearing, so the whirl must live in the attachment modes of
the bearing's forces and moments, whose derivatives make a basis of about a hundred columns,
slower than the full model.

Sensors: ``mid_y``, ``mid_z`` the shaft's centre at mid-span [m] (its whirl amplitude is
√(y² + z²)) and ``drive_torque`` the torque driving the root [N·m].
"""

import numpy as np

from ..bodies import Material, TubeSection, beam_body, straight_reference
from ..bodies.rigid import RigidBody
from ..motion import SpinSchedule
from ..multibody import Marker, Mechanism, clamp, cylindrical, hinge
from ..multibody.reduce import reduce
from ..multibody.sensors import DriverEffort, Position
from ..scenarios.mechanism_file import MechanismSetup

SHAFT, DISK = 0, 1
L, R_OUT, R_IN = 6.0, 0.05, 0.045
E, NU, RHO = 210e9, 0.3, 7800.0
DISK_MASS, DISK_RADIUS, DISK_THICKNESS, UNBALANCE = 70.573, 0.24, 0.05, 0.05
X = (1.0, 0.0, 0.0)
RAMPS = ((0.0, 0.5, 0.0, 48.0), (1.0, 1.25, 48.0, 72.0))


def critical_speed() -> float:
    """The first bending critical speed (rad/s), Rayleigh's quotient with the static deflection
    shape of a beam clamped at both ends under a mid-span load: k = 192 EI/L³ and the disk's mass
    plus 13/35 of the shaft's (the shape's mass participation)."""
    I = np.pi / 4 * (R_OUT**4 - R_IN**4)
    m_shaft = RHO * np.pi * (R_OUT**2 - R_IN**2) * L
    return float(np.sqrt(192 * E * I / L**3 / (DISK_MASS + 13 / 35 * m_shaft)))


def mechanism(formulation: str = "ancf", elements: int = 8, t_end: float = 2.5, rtol: float = 1e-4,
              rho_inf: float = 0.6, vms: int = 2, interface_rotations: bool = False, interface_mds: bool = True,
              conditions: str = "bearing", interface_modes: bool = True) -> MechanismSetup:
    """The rotating shaft (module docstring); ``elements`` C1 elements (even: a node at
    mid-span). ρ∞ = 0.6 as the peers ran it."""
    if formulation not in ("ancf", "nr-rncf"):
        raise ValueError(f"formulation must be 'ancf' or 'nr-rncf', got {formulation!r}")
    elements = int(elements)
    if elements < 2 or elements % 2:
        raise ValueError(f"elements must be an even integer >= 2 (a node at mid-span), got {elements}")
    root, mid, tip = (0.0, 0.0, 0.0), (L / 2, 0.0, 0.0), (L, 0.0, 0.0)
    shaft = beam_body(Material(E, RHO, NU), TubeSection(R_OUT, R_IN), straight_reference(L, elements))
    if formulation == "nr-rncf":
        interfaces = [root, mid, tip] if conditions == "clamped" else [root, tip, mid]
        shaft = reduce(shaft, interfaces, vms=int(vms), mds="all", interface_modes=bool(interface_modes),
                       interface_rotations=bool(interface_rotations) and bool(interface_modes),
                       interface_mds=bool(interface_mds) and bool(interface_modes), conditions=conditions)
    J_axial = 0.5 * DISK_MASS * DISK_RADIUS**2
    J_diametral = DISK_MASS * (3 * DISK_RADIUS**2 + DISK_THICKNESS**2) / 12
    disk = RigidBody(DISK_MASS, [J_axial, J_diametral, J_diametral], com=(L / 2, UNBALANCE, 0.0), points=[mid])
    joints = [hinge(None, Marker(SHAFT, root), X, drive=SpinSchedule(RAMPS, axis=X)),
              clamp(Marker(SHAFT, mid), Marker(DISK, mid)),
              ] + ([] if formulation == "nr-rncf" and conditions == "bearing" else
                   [cylindrical(None, Marker(SHAFT, tip), X)])  # with "bearing", the basis holds the tip
    system = Mechanism([shaft, disk], joints)
    sensors = {"mid_y": Position(Marker(SHAFT, mid), 1), "mid_z": Position(Marker(SHAFT, mid), 2),
               "drive_torque": DriverEffort(1)}
    return MechanismSetup(system, sensors, t_end=t_end, rtol=rtol, rho_inf=rho_inf, compare=("mid_y", "mid_z"),
                          info={"formulation": formulation, "elements": elements, "critical_speed": critical_speed()})


__all__ = ["critical_speed", "mechanism"]
