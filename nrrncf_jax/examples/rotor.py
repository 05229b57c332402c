"""A torque-driven rotor: a rigid hub on a hinge to the ground, three of the paper's beams
(Table 1: L = 8 m aluminium tubes, r_o = 20 mm, r_i = 5.724 mm) clamped to it at 120°, spun up
by a motor whose torque is prescribed, not the speed: the rotor's speed is an outcome.

The hub: inertia 0.5 kg m² about its axis Z (``hub_inertia``), the beams' roots at radius
``hub_radius`` in the XY plane, leaving radially. The motor's torque is the smooth pulse

    τ(t) = τ₀ (1 − cos 2πt/T) / 2   for t ≤ T,   0 after,

whose impulse up to t is τ₀/2 (t − T/2π sin 2πt/T) (τ₀ T/2 in all): with no other moment about
the axis (the hinge's reactions have none), the rotor's angular momentum about Z is that
impulse, and its energy the motor's work ∫ τ ω dt, both to the integration error. Planar and
without gravity.

``formulation="ancf"``: the beams are C1 elements in the inertial frame, clamped to the hub on
their root's position and gradient vectors; ``"nr-rncf"``: each beam in a floating frame at its
root, ``vms`` in-plane cantilever modes and their modal derivatives (``multibody.reduce``),
welded to the hub.

Sensors: ``omega`` the hub's angular velocity, ``torque`` the motor's, ``power`` its power τ ω,
``H_z`` the angular momentum about Z, ``energy`` (kinetic plus strain), ``tip`` beam 0's tip
deflection from the radial line through its root (positive ahead, in the direction of rotation),
``M_root`` beam 0's in-plane bending moment at its root (``post.stress.SectionResultant``'s M3,
the section's second Piola-Kirchhoff stress integrated: what sizes the hub's clamp).
"""

import numpy as np

from ..bodies.rigid import RigidBody
from ..multibody import Marker, Mechanism, clamp, hinge, motor, placed
from ..multibody.modal_interaction import select_modal_derivatives
from ..multibody.reduce import reduce
from ..multibody.sensors import AngularMomentum, ChordDeflection, ElementForce, Energy
from ..post.stress import SectionResultant
from ..scenarios.beams import beam_preset
from ..scenarios.mechanism_file import MechanismSetup

HUB = 0
Z = (0.0, 0.0, 1.0)


def torque_pulse(t, angle, rate, params):
    """τ(t) = τ₀ (1 − cos 2πt/T)/2 on [0, T], then 0; ``params = (τ₀, T)`` (the motor's law)."""
    import jax.numpy as jnp

    tau0, T = params
    return jnp.where(t <= T, 0.5 * tau0 * (1.0 - jnp.cos(2.0 * jnp.pi * t / T)), 0.0)


def impulse(t, tau0: float, T: float):
    """∫₀ᵗ τ dt of ``torque_pulse``."""
    t = np.minimum(np.asarray(t, dtype=float), T)
    return 0.5 * tau0 * (t - T / (2 * np.pi) * np.sin(2 * np.pi * t / T))


def mechanism(formulation: str = "ancf", elements: int = 8, vms: int = 4, mds="all", torque: float = 2000.0,
              spin_time: float = 2.0, hub_radius: float = 0.5, hub_inertia: float = 0.5, hub_mass: float = 20.0,
              beam: str = "paper", t_end: float = 4.0, rtol: float = 1e-5, rho_inf: float = 0.9,
              n_mds: int = 4) -> MechanismSetup:
    """The rotor (module docstring); ``elements`` C1 elements a beam; ``torque`` τ₀ [N m] and
    ``spin_time`` T [s] the motor's pulse. ``mds="mmi"`` (nr-rncf): each reduced body's
    ``n_mds`` modal derivatives of largest modal interaction in a first run of the mechanism with
    its VMs alone over 0-``t_end`` (``multibody.modal_interaction``)."""
    if formulation not in ("ancf", "nr-rncf"):
        raise ValueError(f"formulation must be 'ancf' or 'nr-rncf', got {formulation!r}")
    if not (spin_time > 0 and hub_radius > 0 and hub_inertia > 0):
        raise ValueError("spin_time, hub_radius and hub_inertia must be > 0")
    preset = beam_preset(beam)
    angles = 2 * np.pi * np.arange(3) / 3
    roots = [hub_radius * np.array([np.cos(a), np.sin(a), 0.0]) for a in angles]
    # the hub's in-plane moments: a thin disk's (J/2), positive definite, about its centre
    hub = RigidBody(hub_mass, [0.5 * hub_inertia, 0.5 * hub_inertia, hub_inertia], points=roots)
    beams = []
    for a, r in zip(angles, roots):
        c, s = np.cos(a), np.sin(a)
        body = placed(preset.body(int(elements)), np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]), r)
        beams.append(body if formulation == "ancf" else reduce(body, [r], vms=int(vms), mds=mds, plane_normal=Z))
    O = Marker(HUB, (0.0, 0.0, 0.0))
    joints = [hinge(None, O, Z)] + [clamp(Marker(HUB, tuple(r)), Marker(k + 1, tuple(r))) for k, r in enumerate(roots)]
    forces = [motor(None, O, Z, torque_pulse, (float(torque), float(spin_time)))]
    system = Mechanism([hub] + beams, joints, forces=forces)
    if mds == "mmi" and formulation == "nr-rncf":
        system, _ = select_modal_derivatives(system, np.linspace(0.0, t_end, 201), n_mds=int(n_mds), rho_inf=rho_inf)
    tip = tuple(roots[0] + preset.length * np.array([1.0, 0.0, 0.0]))
    sensors = {"omega": ElementForce(0, "rate"), "torque": ElementForce(0), "power": ElementForce(0, "power"),
               "H_z": AngularMomentum(2), "energy": Energy(),
               "tip": ChordDeflection(O, Marker(1, tuple(roots[0])), Marker(1, tip)),
               "M_root": SectionResultant(Marker(1, tuple(roots[0])), "M3")}
    return MechanismSetup(system, sensors, t_end=t_end, rtol=rtol, rho_inf=rho_inf, compare=("omega", "tip"),
                          info={"formulation": formulation, "elements": int(elements), "torque": float(torque),
                                "spin_time": float(spin_time)})


__all__ = ["impulse", "mechanism", "torque_pulse"]
