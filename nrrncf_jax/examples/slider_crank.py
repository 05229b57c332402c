"""The flexible slider-crank (Escalona, Hussien & Shabana 1998), planar, without gravity.

A rigid crank of length r = 0.152 m, hinged to the ground at the origin about Z and driven at a
constant ω = 150 rad/s from angle 0; a connecting rod of length L = 0.304 m (E = 1.0e10 Pa, ρ =
2770 kg/m³, ν = 0.3, a solid circular section of radius 5 mm: A = 7.854e-5 m², I = 4.909e-10 m⁴)
pinned to the crank at (r, 0, 0) and to the slider at (r + L, 0, 0); a slider of 0.033 kg on a
prismatic joint along x. At t = 0 the mechanism moves as the rigid one does: the crank pin at
(0, rω, 0) = (0, 22.8, 0) m/s, the rod turning about the slider's pin at −rω/L, the slider at
rest.

The rod is ``formulation="ancf"`` (C1 beam elements in the inertial frame), ``"nr-rncf"`` (its
floating frame at the crank pin along the chord to the slider's pin, ``vms`` in-plane simply
supported modes and their modal derivatives, ``multibody.reduce`` with ``conditions="pinned"``;
``conditions="clamped"`` for the cantilever modes of a frame clamped at the crank pin,
``basis="craig-bampton"`` for the extended Craig-Bampton basis with the slider pin's boundary
coordinates), ``"rncf"`` (the same frame, every free coordinate kept) or ``"rigid"`` (a uniform
rigid rod: the closed-form kinematics x_B = r cos θ + √(L² − r² sin² θ) hold).

Why pinned modes by default: the rod is pinned at both ends, and a frame along its chord leaves
the modes only the bending between the pins. One simply supported mode and its derivative (23
DOFs in the mechanism) follow the full rod's midpoint deflection closely, where the cantilever
frame needs several modes and many more derivatives for the same and takes many more steps: its
modes must meet the slider's pin with a sum of high modes.

The pins are balls (spherical joints): with hinges at both ends a rigid link in a planar loop is
over-constrained (its rotation out of the plane is fixed twice), and the system refuses redundant
joints. The rod's spin about its own chord is then free, with nothing to excite it.

Sensors: ``x_B`` the slider's position, ``w_mid`` the rod midpoint's signed distance from the
chord of its ends (positive to the left of the direction crank pin → slider), ``torque`` the
driving torque on the crank.
"""

import numpy as np

from ..bodies import Material, TubeSection, beam_body, straight_reference
from ..bodies.rigid import RigidBody, slender_rod
from ..motion import SteadySpin
from ..multibody import Marker, Mechanism, ball, hinge, placed, slider
from ..multibody.modal_interaction import select_modal_derivatives
from ..multibody.reduce import reduce
from ..multibody.sensors import ChordDeflection, DriverEffort, Position
from ..scenarios.mechanism_file import MechanismSetup

CRANK, ROD, SLIDER = 0, 1, 2


def mechanism(formulation: str = "ancf", elements: int = 8, vms: int = 1, mds="all", omega: float = 150.0,
              E: float = 1.0e10, crank: float = 0.152, rod: float = 0.304, rho: float = 2770.0, nu: float = 0.3,
              radius: float = 0.005, slider_mass: float = 0.033, t_end: float = 0.1, rtol: float = 2e-5,
              rho_inf: float = 0.5, n_mds: int = 4, conditions: str | None = None, basis: str = "free"
              ) -> MechanismSetup:
    """The slider-crank (module docstring); ``elements`` C1 elements along the rod (even, so that
    a node sits at its midpoint). The run's defaults: the step error measured on the sensors
    w_mid and x_B (``error_on``, ``multibody.Mechanism.observed_error``), rtol = 2e-5 (atol 2e-6 m
    on them), Gustafsson's PI controller and ρ∞ = 0.5: the rod's axial vibration (kHz, through its
    modal derivatives) is damped rather than resolved, and the steps follow the deflection the user
    observes, not the axial strain on the slope vectors.
    ``conditions`` and ``basis`` (nr-rncf): the rod's reference conditions and basis,
    ``multibody.reduce``'s (module docstring); by default
    ``"pinned"``, and ``"clamped"`` with Craig-Bampton (whose boundary coordinates are the
    slider pin's, which pinned conditions hold). ``mds="mmi"`` (nr-rncf): the rod's
    ``n_mds`` modal derivatives of largest modal interaction in a first run of the mechanism with
    its VMs alone over 0-``t_end`` (``multibody.modal_interaction``)."""
    if formulation not in ("ancf", "nr-rncf", "rncf", "rigid"):
        raise ValueError(f"formulation must be 'ancf', 'nr-rncf', 'rncf' or 'rigid', got {formulation!r}")
    elements = int(elements)
    if elements < 2 or elements % 2:
        raise ValueError(f"elements must be an even integer >= 2 (a node at the rod's midpoint), got {elements}")
    r, L = float(crank), float(rod)
    area = np.pi * radius**2
    A, B, mid = (r, 0.0, 0.0), (r + L, 0.0, 0.0), (r + 0.5 * L, 0.0, 0.0)
    crank_body = slender_rod(rho * area * r, r, (0.0, 0.0, 0.0), A)
    slider_body = RigidBody(slider_mass, np.full(3, 1e-6), com=B)
    if formulation == "rigid":
        rod_body = slender_rod(rho * area * L, L, A, B, points=[mid])
    else:
        beam = placed(beam_body(Material(E, rho, nu), TubeSection(radius), straight_reference(L, elements)),
                      translation=A)
        rod_body = beam if formulation == "ancf" else reduce(
            beam, [A, B], vms=int(vms), mds=mds, basis="full" if formulation == "rncf" else basis,
            plane_normal=(0.0, 0.0, 1.0),
            conditions=conditions or ("clamped" if basis == "craig-bampton" else "pinned"))
    joints = [hinge(None, Marker(CRANK, (0.0, 0.0, 0.0)), (0.0, 0.0, 1.0), drive=SteadySpin(omega)),
              ball(Marker(CRANK, A), Marker(ROD, A)),
              ball(Marker(ROD, B), Marker(SLIDER, B)),
              slider(None, Marker(SLIDER, B), (1.0, 0.0, 0.0))]
    system = Mechanism([crank_body, rod_body, slider_body], joints)
    w_rod = -r * omega / L

    def start(system):
        """The rigid mechanism's velocities at θ = 0: the crank turning at ω, the rod about the
        slider's pin."""
        v0 = (system.rigid_velocity(omega=(0.0, 0.0, omega), bodies=[CRANK])
              + system.rigid_velocity(velocity=np.cross([0.0, 0.0, w_rod], -np.asarray(B)), omega=(0.0, 0.0, w_rod),
                                      bodies=[ROD]))
        return system.reference(), v0

    z0, v0 = start(system)
    if mds == "mmi" and formulation == "nr-rncf":
        system, _ = select_modal_derivatives(system, np.linspace(0.0, t_end, 201), n_mds=int(n_mds), rho_inf=rho_inf,
                                             y0=(z0, v0))
        z0, v0 = start(system)
    system.check_velocity(z0, v0)
    sensors = {"x_B": Position(Marker(SLIDER, B), 0),
               "w_mid": ChordDeflection(Marker(ROD, A), Marker(ROD, B), Marker(ROD, mid)),
               "torque": DriverEffort(1)}
    return MechanismSetup(system, sensors, y0=(z0, v0), t_end=t_end, rtol=rtol, rho_inf=rho_inf,
                          compare=("x_B", "w_mid"), error_on=("w_mid", "x_B"), step_control="pi",
                          info={"formulation": formulation, "elements": elements, "omega": omega, "E": E})


def rigid_slider_position(t, omega: float = 150.0, crank: float = 0.152, rod: float = 0.304):
    """x_B(t) of the rigid mechanism: r cos θ + √(L² − r² sin² θ), θ = ωt."""
    th = omega * np.asarray(t)
    return crank * np.cos(th) + np.sqrt(rod**2 - crank**2 * np.sin(th) ** 2)


__all__ = ["mechanism", "rigid_slider_position"]
