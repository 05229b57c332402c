"""The Princeton beam of the field's validation set (Bauchau et al. 2016, problem (a); Dowell,
Traybar & Hodges 1977; data in ``VALIDATION_SET.md``): a static large deflection with bending and
torsion coupled.

An aluminium cantilever of L = 0.508 m with the sectional stiffnesses of MBDyn's deck (EA =
2.84191e6 N, flap EI = 2.42873 N·m², lag EI = 36.2794 N·m², GJ = 3.10338 N·m²; a 12.7 × 3.175 mm
strip, ``elements.section.sectional``), clamped at x = 0 on its section frame. Its thin direction
(flap) is z, its wide one (lag) y. The beam is turned about its axis by the load angle θ under a
vertical tip load P (1, 2 or 3 lbf: 4.448, 8.896, 13.345 N), so in the beam's axes the load is
P (0, −sin θ, −cos θ): at θ = 0 pure flap, at 90° pure lag. Between them the lag component
loads the beam that the flap component has already bent and twisted.

The load is a force element (``multibody.actuator`` along the fixed direction) whose magnitude
grows with t, P·t: the static solve (``nrrncf static princeton_beam``, ``integrate.
constrained_equilibrium``) at t = 1 reaches it along load increments. Sensors: the tip's
position ``tip_y``, ``tip_z`` [m] (the flap deflection is −tip_z, the lag −tip_y) and its
``twist`` about the axis [rad] (``multibody.sensors.SectionAngle``).

Linear limit (small P): flap P cos θ L³/(3 EI_flap), lag P sin θ L³/(3 EI_lag) (and their shear
deflections, ``linear_tip``), no twist.
"""

import numpy as np

from ..bodies import beam_body, sectional, straight_reference
from ..multibody import Marker, Mechanism, actuator, clamp
from ..multibody.sensors import Position, SectionAngle
from ..scenarios.mechanism_file import MechanismSetup

LENGTH = 0.508
SECTION = dict(EA=2.84191e6, EI_y=2.42873, EI_z=36.2794, GJ=3.10338, rhoA=2700.0 * 0.0127 * 0.003175)
"""MBDyn's sectional data: flap bending about y, lag about z; aluminium's mass per metre."""
LOADS = (4.448, 8.896, 13.345)
"""1, 2 and 3 lbf in N."""


def _load_law(t, s, s_dot, P):
    """The tip load's magnitude at load factor t (the static solve's path reaches t = 1)."""
    return P * t


def mechanism(load: float = 4.448, angle_deg: float = 0.0, elements: int = 8) -> MechanismSetup:
    """The Princeton beam (module docstring) under the tip load ``load`` [N] at the load angle
    ``angle_deg``, on ``elements`` C1 elements."""
    if not load > 0:
        raise ValueError(f"load must be > 0 N, got {load!r}")
    material, section = sectional(**SECTION)
    beam = beam_body(material, section, straight_reference(LENGTH, int(elements)))
    theta = np.radians(float(angle_deg))
    direction = (0.0, -float(np.sin(theta)), -float(np.cos(theta)))
    tip = Marker(0, (LENGTH, 0.0, 0.0))
    system = Mechanism([beam], [clamp(None, Marker(0, (0.0, 0.0, 0.0)))],
                       forces=[actuator(None, tip, _load_law, params=float(load), axis=direction)])
    sensors = {"tip_y": Position(tip, 1), "tip_z": Position(tip, 2), "twist": SectionAngle(tip, (1.0, 0.0, 0.0))}
    return MechanismSetup(system, sensors, t_end=1.0, info={"load": load, "angle_deg": angle_deg,
                                                             "elements": elements})


def linear_tip(load: float, angle_deg: float, nu: float = 0.3) -> tuple[float, float]:
    """The linear limit's tip (flap, lag) displacements, along −z and −y, of a Timoshenko
    cantilever: P cos θ (L³/(3 EI_flap) + L/(k G A)) and P sin θ (L³/(3 EI_lag) + L/(k G A)), with
    ``sectional``'s k = 5/6 and G A = EA/(2(1 + ν))."""
    theta = np.radians(angle_deg)
    shear = LENGTH / (5.0 / 6.0 * SECTION["EA"] / (2.0 * (1.0 + nu)))
    c = LENGTH**3 / 3.0
    return (load * np.cos(theta) * (c / SECTION["EI_y"] + shear),
            load * np.sin(theta) * (c / SECTION["EI_z"] + shear))


__all__ = ["LOADS", "linear_tip", "mechanism"]
