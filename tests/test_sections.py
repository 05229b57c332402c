"""Beam sections beyond the tube: a rectangle with Saint-Venant's torsion, and a section given by
its stiffnesses (EA, EI_y, EI_z, GJ, ρA) as MBDyn and Exudyn take it.

Closed forms: the torsion constant of a rectangle (Timoshenko & Goodier §109; a square 0.1406 a⁴,
a thin strip b h³/3 (1 − 0.630 h/b)); a cantilever whose tip section is turned by θ about its
axis or a section axis needs the torque GJθ/L or EIθ/L, exactly for this element at any mesh (a
constant twist or curvature; the geometric nonlinearity is O(θ²) = 1e-6 relative, round-off
~1e-10). Without the section's torsion correction the continuum over a square twists with the
polar moment, 18.6 % stiffer, and a strip's end sections distort in their plane, a compliance
that grew with the mesh (``section.RectangleSection``).
"""

import numpy as np
import pytest

from nrrncf_jax.bodies import Material, RectangleSection, beam_body, sectional, straight_reference
from nrrncf_jax.elements.section import rectangle_torsion_constant
from nrrncf_jax.integrate import constrained_equilibrium
from nrrncf_jax.motion import SteadySpin
from nrrncf_jax.multibody import Marker, Mechanism, angle_driver, clamp
from nrrncf_jax.multibody.sensors import observe
from nrrncf_jax.post.stress import SectionResultant

THETA = 1e-3
RTOL = 1e-6
PRINCETON = dict(EA=2.84191e6, EI_y=36.2794, EI_z=2.42873, GJ=3.10338, rhoA=0.548)  # VALIDATION_SET.md (a)


def test_rectangle_torsion_constant_closed_forms():
    a = 0.016
    assert abs(rectangle_torsion_constant(a, a) / a**4 - 0.140577) < 1e-6  # Roark's 0.1406
    b, h = 1.0, 0.01  # a thin strip: b h³/3 (1 − 0.630 h/b), to terms of order exp(−πb/h)
    assert abs(rectangle_torsion_constant(b, h) / (b * h**3 / 3 * (1 - 0.630249 * h / b)) - 1) < 1e-6
    assert rectangle_torsion_constant(b, h) == rectangle_torsion_constant(h, b)


def _turned_tip_torques(material, section, n, L=1.0):
    """The torques that turn a clamped beam's tip section by θ about x, y and z, times L/θ; and the
    section resultants T, M2, M3 at mid-span (``post.stress.SectionResultant``) in each case."""
    beam = beam_body(material, section, straight_reference(L, n))
    torques, resultants = [], []
    for k, axis in enumerate(np.eye(3)):
        mech = Mechanism([beam], [clamp(None, Marker(0, (0.0, 0.0, 0.0))),
                                  angle_driver(None, Marker(0, (L, 0.0, 0.0)), axis, SteadySpin(THETA))])
        eq = constrained_equilibrium(mech, t=1.0)
        torques.append(float(mech.joints[1].effort(eq.lam[mech.joint_slices()[1]])))
        mid = observe(mech, {"r": SectionResultant(Marker(0, (L / 2, 0.0, 0.0)))})(1.0, eq.z, 0.0 * eq.z)["r"]
        resultants.append(float(np.asarray(mid)[3 + k]))
    return np.array(torques) * L / THETA, np.array(resultants) * L / THETA


@pytest.mark.parametrize("n", [2, 16])
def test_a_rectangular_beam_twists_and_bends_with_its_closed_form_stiffnesses(n):
    """A steel strip 16 × 4 mm: GJ with Saint-Venant's J, EI_y = E w h³/12, EI_z = E h w³/12."""
    E, nu, w, h = 207e9, 0.3, 0.016, 0.004
    G = E / (2 * (1 + nu))
    stiffness, resultants = _turned_tip_torques(Material(E, 7800.0, nu), RectangleSection(w, h), n)
    expected = [G * rectangle_torsion_constant(w, h), E * w * h**3 / 12, E * h * w**3 / 12]
    np.testing.assert_allclose(stiffness, expected, rtol=RTOL)
    # the section resultants T, M2, M3 read the same moments (up to their sign convention)
    np.testing.assert_allclose(np.abs(resultants), expected, rtol=RTOL)


def test_a_section_given_by_its_stiffnesses_is_reproduced():
    """The Princeton beam's sectional data (a strip 12.7 × 3.2 mm): the beam twists and bends with
    GJ, EI_y and EI_z at every mesh, weighs ρA a metre, and stretches with EA."""
    material, section = sectional(**PRINCETON)
    for n in (2, 16):
        stiffness, _ = _turned_tip_torques(material, section, n)
        np.testing.assert_allclose(stiffness, [PRINCETON["GJ"], PRINCETON["EI_y"], PRINCETON["EI_z"]], rtol=RTOL)
    beam = beam_body(material, section, straight_reference(0.508, 4))
    assert abs(float(beam.mass) / (PRINCETON["rhoA"] * 0.508) - 1) < 1e-12
    assert abs(float(material.E * section.area) / PRINCETON["EA"] - 1) < 1e-12


def test_bad_sections_are_refused():
    with pytest.raises(ValueError, match="width"):
        RectangleSection(-1.0)
    with pytest.raises(ValueError, match="shear_factors"):
        RectangleSection(1.0, 1.0, shear_factors=(1.0,))
    with pytest.raises(ValueError, match="GJ"):
        sectional(**{**PRINCETON, "GJ": 0.0})
