"""The dynamic lateral buckling of a thin beam, from the field's validation set (Bauchau et al.,
Multibody System Dynamics 37 (2016) 29-48, problem (c); data in ``VALIDATION_SET.md``): a crank
and a link push a cantilever's tip up until it buckles sideways, then pull it back.

Geometry, as MBDyn's deck builds it (``tests/benchmarks/lateralbuckling``, ``lateralbuckling_gen.m``
and ``lateralbuckling``; the problem statement leaves the link's and the crank's directions and the
drive's axis to a figure): the beam from R (0, 0, 0) to its tip T (1, 0, 0) m, clamped at R on its
section frame; C = T + (0, d, 0) with d = 0.1 mm, the imperfection; the link from C straight down to
B = C + (0, 0, −0.25) m; the crank from the ground hinge G = B + (−0.05, 0, 0) m to B. A spherical
joint joins the link's top to the beam at C, a point fixed in the tip's section frame d off the
beam's axis along its section y (MBDyn's spherical hinge with an offset:
``multibody.ball(..., eccentric=True)``); a revolute joint about y joins link and crank at B; at
G the crank is hinged to the ground about y and driven by the angle φ(t) = (π/2)(1 − cos(π t/T))
for t ≤ T = 0.4 s and π after it about −y (MBDyn's total pin joint, its rotation about (0, −1, 0)
given by ``cosine, 0., pi/T, pi/2, half, 0.``; ``motion.HalfCosine``): B rises over the first quarter
turn, to 0.05 m above its start at 0.2 s, and comes down again to its start's height, 0.1 m
towards R, at 0.4 s, where the crank is held until 0.8 s. No gravity, no damping.

Sections (MBDyn's sectional stiffnesses, ``elements.section.sectional``; x along each bar): the
beam EA 73e6 N, GA_y 5.025e6 N, GA_z 23.40e6 N, GJ 877.2 N·m², EI_y 60830 N·m² (bending in the
vertical x-z plane, the stiff one), EI_z 608.3 N·m² (sideways), 2.68 kg/m (a 10 × 100 mm
aluminium strip, its wide side vertical); the link EA 33.02e6, GA 10.81e6, GJ 914.5, EI 1189,
1.212 kg/m; the crank EA 132.1e6, GA 43.22e6, GJ 14630, EI 19020, 4.85 kg/m.

What happens: the link is far stiffer than the beam, so the crank imposes the tip's vertical
deflection, up to about 4.6 cm near 0.2 s, a tip load of up to 3 EI_y/L³ × 4.6 cm ≈ 8 kN in the
plane, well above the load at which the beam buckles sideways (Prandtl: P_cr = 4.013 √(EI_z GJ)/L² ≈ 2.93 kN, a
deflection of about 16 mm, reached near t = 0.09 s; ``prandtl_load``, and
``tests/test_lateral_buckling.py`` for the static problem). The 0.1 mm offset of C makes the push
twist the tip from the start, so the beam leaves its plane to one side, by about 4.5 cm at
mid-span and 0.26 rad of twist at the tip (near 0.13-0.2 s, the load then about twice P_cr: the
sideways motion takes time to grow); the perfect beam (``imperfection=0``) takes the load in its
plane until round-off, amplified by the instability, tips it. Coming down, the load falls below
P_cr and the beam straightens. Held from 0.4 s, the link leans by about 22° and pulls the tip down
by about 2 cm with about 3.6 kN, above P_cr; but a pull through a link pinned below the beam
draws a sideways-displaced tip back (a load below the shear centre stabilises), and the beam,
undamped, vibrates sideways about its plane by about ±2.4 cm and ±0.1 rad.

``formulation="ancf"``: every bar of C1 elements in the inertial frame (``elements`` the beam's,
``link_elements``, ``crank_elements``); ``"nr-rncf"``: each bar in a floating frame at its first
interface (the beam at R, the link at C, the crank at G), ``vms`` cantilever modes, the
attachment modes of the force and moment at its other joint and the modal derivatives of them
all, and every section's own stretch and shear modes (``multibody.reduce`` with
``interface_rotations``, ``interface_mds`` and ``interface_sections="all"``). The reduction
itself is exact (every coordinate kept, ``reduce(..., basis="full")``, it reproduces the full
model); what a basis must carry here is the twist. The buckled beam twists its sections along its
length, and a basis of fixed shapes turns a section vector by a polynomial in the amplitudes,
which also stretches it (to fourth order in the twist with the modal derivatives): the section,
far stiffer in stretch than the strip in torsion, resists, and the reduced beam is too stiff in
large twist. The sections' own modes let them relax; with them the reduced beam reaches the
full model's twist, and its sideways motion falls short still. With 4 elements a basis that
carries all of that is nearly the full one, and its cubic tensors cost more than the elements:
for this problem the full model is both more accurate and faster.

The tip itself hardly moves sideways (millimetres): the link, hinged to the crank about y, holds it;
the beam buckles between its clamp and the link, so the mid-span sensors show it best.

Sensors: ``tip_y`` (sideways), ``tip_z`` (vertical) the displacement of the beam's tip T [m];
``tip_twist`` its section's rotation about x [rad] (``multibody.sensors.SectionAngle``);
``mid_y``, ``mid_twist`` the same at mid-span (where MBDyn reports them); ``link_N`` the link's
mid-span axial force [N] (``post.stress.SectionResultant``, tension positive); ``drive_torque``
the torque driving the crank about −y [N·m].
"""

import numpy as np

from ..bodies import beam_body, sectional, straight_reference
from ..motion import HalfCosine
from ..multibody import Marker, Mechanism, ball, clamp, hinge, placed
from ..multibody.reduce import reduce
from ..multibody.sensors import DriverEffort, Position, SectionAngle
from ..post.stress import SectionResultant
from ..scenarios.mechanism_file import MechanismSetup

BEAM, LINK, CRANK = 0, 1, 2
L_BEAM, L_LINK, L_CRANK = 1.0, 0.25, 0.05
T_DRIVE = 0.4
"""The drive's half-cosine lasts T [s]; the run ends at 2 T."""
IMPERFECTION = 0.1e-3
"""C's offset from the beam's tip along y [m]."""
BEAM_SECTION = dict(EA=73e6, GA_y=5.025e6, GA_z=23.40e6, GJ=877.2, EI_y=60830.0, EI_z=608.3, rhoA=2.68)
LINK_SECTION = dict(EA=33.02e6, GA_y=10.81e6, GA_z=10.81e6, GJ=914.5, EI_y=1189.0, EI_z=1189.0, rhoA=1.212)
CRANK_SECTION = dict(EA=132.1e6, GA_y=43.22e6, GA_z=43.22e6, GJ=14630.0, EI_y=19020.0, EI_z=19020.0, rhoA=4.85)
Y = (0.0, 1.0, 0.0)
DOWN = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])  # x onto −z, y onto y (MBDyn's link frame)


def prandtl_load() -> float:
    """Prandtl's critical tip load of the cantilever [N], 4.013 √(EI_z GJ)/L² (a dead load at the
    centroid, the bending before buckling neglected)."""
    return float(4.013 * np.sqrt(BEAM_SECTION["EI_z"] * BEAM_SECTION["GJ"]) / L_BEAM**2)


def points(imperfection: float = IMPERFECTION) -> dict:
    """The benchmark's points R, T, C, B, G [m] (module docstring)."""
    R, T = np.zeros(3), np.array([L_BEAM, 0.0, 0.0])
    C = T + np.array([0.0, imperfection, 0.0])
    B = C + np.array([0.0, 0.0, -L_LINK])
    G = B + np.array([-L_CRANK, 0.0, 0.0])
    return {k: tuple(float(x) for x in p) for k, p in dict(R=R, T=T, C=C, B=B, G=G).items()}


def _bar(section: dict, start, length: float, elements: int, rotation=None):
    material, sec = sectional(**section)
    return placed(beam_body(material, sec, straight_reference(length, elements)), rotation=rotation,
                  translation=start)


def mechanism(formulation: str = "ancf", elements: int = 4, link_elements: int = 2, crank_elements: int = 1,
              imperfection: float = IMPERFECTION, t_end: float = 2 * T_DRIVE, rtol: float = 1e-4,
              rho_inf: float = 0.5, vms: int = 3, interface_rotations: bool = True,
              interface_mds: bool = True, interface_sections="all") -> MechanismSetup:
    """The lateral-buckling benchmark (module docstring): ``elements`` C1 elements in the beam
    (even: a node at mid-span), ``link_elements`` in the link (even: a node at its middle, where
    ``link_N`` reads), ``crank_elements`` in the crank; ``imperfection`` C's offset from the tip
    along y [m]. rtol = 1e-4 and ρ∞ = 0.5 (as the four-bar's full model): the bars' axial and the
    link's and crank's bending vibrations (kHz) are damped rather than resolved. ``vms``,
    ``interface_rotations``, ``interface_mds``, ``interface_sections``: the reduced bars' basis
    (``multibody.reduce``)."""
    if formulation not in ("ancf", "nr-rncf"):
        raise ValueError(f"formulation must be 'ancf' or 'nr-rncf', got {formulation!r}")
    elements, link_elements, crank_elements = int(elements), int(link_elements), int(crank_elements)
    if elements < 2 or elements % 2 or link_elements < 2 or link_elements % 2:
        raise ValueError(f"elements and link_elements must be even integers >= 2 (nodes at the beam's mid-span and "
                         f"the link's middle), got {elements}, {link_elements}")
    if crank_elements < 1:
        raise ValueError(f"crank_elements must be >= 1, got {crank_elements}")
    if not np.isfinite(imperfection) or abs(float(imperfection)) >= 0.01:
        raise ValueError(f"imperfection must be a small offset (|d| < 1 cm), got {imperfection!r}")
    p = points(float(imperfection))
    bars = [_bar(BEAM_SECTION, p["R"], L_BEAM, elements), _bar(LINK_SECTION, p["C"], L_LINK, link_elements, DOWN),
            _bar(CRANK_SECTION, p["G"], L_CRANK, crank_elements)]
    if formulation == "nr-rncf":
        ends = [(p["R"], p["T"]), (p["C"], p["B"]), (p["G"], p["B"])]
        bars = [reduce(bar, list(e), vms=int(vms), mds="all", interface_modes=True,
                       interface_rotations=bool(interface_rotations), interface_mds=bool(interface_mds),
                       interface_sections=interface_sections)
                for bar, e in zip(bars, ends)]
    joints = [clamp(None, Marker(BEAM, p["R"])),
              ball(Marker(BEAM, p["T"]), Marker(LINK, p["C"]), eccentric=True),
              hinge(Marker(LINK, p["B"]), Marker(CRANK, p["B"]), Y),
              hinge(None, Marker(CRANK, p["G"]), (0.0, -1.0, 0.0), drive=HalfCosine(np.pi, T_DRIVE))]
    system = Mechanism(bars, joints)
    tip, mid = Marker(BEAM, p["T"]), Marker(BEAM, (0.5 * L_BEAM, 0.0, 0.0))
    X = (1.0, 0.0, 0.0)
    sensors = {"tip_y": Position(tip, 1), "tip_z": Position(tip, 2), "tip_twist": SectionAngle(tip, X),
               "mid_y": Position(mid, 1), "mid_twist": SectionAngle(mid, X),
               "link_N": SectionResultant(Marker(LINK, tuple(np.add(p["C"], p["B"]) / 2)), "N"),
               "drive_torque": DriverEffort(len(system.joints) - 1)}
    return MechanismSetup(system, sensors, t_end=t_end, rtol=rtol, rho_inf=rho_inf,
                          compare=("tip_y", "tip_z", "tip_twist", "mid_y", "mid_twist"),
                          info={"formulation": formulation, "elements": elements, "link_elements": link_elements,
                                "crank_elements": crank_elements, "imperfection": float(imperfection),
                                "prandtl_load": prandtl_load()})


__all__ = ["mechanism", "points", "prandtl_load"]
