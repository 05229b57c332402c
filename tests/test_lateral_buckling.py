"""Lateral-torsional buckling of a cantilever (the validation set's problem (c), its beam alone): the
static solver's tangent loses its stability where Prandtl's closed form says.

A cantilever of L = 1 m with the benchmark's section (EI 60830 N·m² in the load's plane, 608.3
across it, GJ 877.2 N·m², EA 73e6 N; ``elements.section.sectional``) under a dead tip load P at its
centroid, in the stiff plane. Prandtl (1899): the beam buckles sideways at P_cr = 4.013 √(EI_soft
GJ)/L² (= 2.93 kN), neglecting the bending before buckling; with it the load rises by about 1/√((1 −
EI_soft/EI_stiff)(1 − GJ/EI_stiff)) = 1.012 (Kirby & Nethercot's correction). The planar equilibrium
at load P is found by ``constrained_equilibrium``; its stability is the lowest eigenvalue of the
stiffness on the joints' tangent space (``integrate.stability``), which crosses zero at the critical
load. The crossing, interpolated between 0.95 and 1.05 P_Prandtl, must lie within 2 % of Prandtl's
value (the correction's size, and the 8-element mesh's error on a buckling mode with one half-wave,
well below it).
"""

import numpy as np

from nrrncf_jax.bodies import beam_body, sectional, straight_reference
from nrrncf_jax.integrate import constrained_equilibrium, stability
from nrrncf_jax.multibody import Marker, Mechanism, actuator, clamp

SECTION = dict(EA=73e6, EI_y=60830.0, EI_z=608.3, GJ=877.2, rhoA=2.68)  # the load along z: bending about y


def _grow(t, s, s_dot, P):
    return P * t


def _lowest_stiffness(mech, P):
    """The lowest eigenvalue of the stiffness on the joints' tangent space (``integrate.stability``)
    at the equilibrium under the tip load P."""
    loaded = Mechanism(mech.bodies, mech.joints,
                       forces=[actuator(None, Marker(0, (1.0, 0.0, 0.0)), _grow, params=P, axis=(0.0, 0.0, -1.0))])
    return float(stability(loaded, constrained_equilibrium(loaded, t=1.0, load_steps=4), t=1.0)[0])


def test_the_cantilever_buckles_sideways_at_prandtls_load():
    material, section = sectional(**SECTION)
    beam = beam_body(material, section, straight_reference(1.0, 8))
    mech = Mechanism([beam], [clamp(None, Marker(0, (0.0, 0.0, 0.0)))])
    P_prandtl = 4.013 * np.sqrt(SECTION["EI_z"] * SECTION["GJ"])
    below, above = (_lowest_stiffness(mech, f * P_prandtl) for f in (0.95, 1.05))
    assert below > 0 > above, (below, above)
    P_cr = P_prandtl * (0.95 + 0.1 * below / (below - above))
    assert abs(P_cr / P_prandtl - 1) < 0.02, P_cr / P_prandtl
