"""Beam presets: the paper's rotating beams (Section 4.1-4.2) and the classic spin-up beam."""

import dataclasses

import numpy as np

from .. import _validate
from ..bodies.body import Body, beam_body
from ..bodies.mesh import BeamReference, arc_reference, straight_reference
from ..elements.material import Material
from ..elements.section import TubeSection


@dataclasses.dataclass(frozen=True)
class BeamPreset:
    """A hollow circular beam clamped at the hub (x = 0), leaving it along +x.

    ``curve`` is ``None`` for a straight beam, or the direction an arc of radius
    ``curvature_radius`` bends toward (``'+y'``, ``'-y'``, ``'+z'``, ``'-z'``); the spin axis
    is +z, so +y is the direction of rotation.
    """

    name: str
    length: float
    E: float
    rho: float
    nu: float
    r_outer: float
    r_inner: float
    curve: str | None = None
    curvature_radius: float | None = None
    description: str = ""

    def __post_init__(self):
        for name in ("length", "E", "rho", "r_outer"):
            _validate.positive(name, getattr(self, name))
        _validate.non_negative("r_inner", self.r_inner)
        if self.r_inner >= self.r_outer:
            raise ValueError(f"inner radius must be smaller than outer radius, got r_inner={self.r_inner} >= "
                             f"r_outer={self.r_outer}")
        if self.curve is not None:
            _validate.positive("curvature_radius", self.curvature_radius)

    @property
    def material(self) -> Material:
        return Material(self.E, self.rho, self.nu)

    @property
    def section(self) -> TubeSection:
        return TubeSection(self.r_outer, self.r_inner)

    def reference(self, n_elements: int) -> BeamReference:
        if self.curve is None:
            return straight_reference(self.length, n_elements)
        return arc_reference(self.length, self.curvature_radius, n_elements, toward=self.curve)

    def body(self, n_elements: int) -> Body:
        return beam_body(self.material, self.section, self.reference(n_elements))

    def with_(self, **changes) -> "BeamPreset":
        return dataclasses.replace(self, **changes)

    @property
    def first_frequency_eb(self) -> float:
        """Euler-Bernoulli first cantilever frequency (straight beam) [rad/s]."""
        A = np.pi * (self.r_outer**2 - self.r_inner**2)
        I = np.pi / 4 * (self.r_outer**4 - self.r_inner**4)  # noqa: E741
        return 1.875104068711961**2 * np.sqrt(self.E * I / (self.rho * A * self.length**4))


def _classic() -> BeamPreset:
    # Simo & Vu-Quoc / Kane-Ryan-Banerjee: EA = 2.8e7 N, EI = 1.4e4 N m², ρA = 1.2 kg/m, L = 10 m,
    # realised as a tube r_o = 40 mm, r_i = 20 mm (I/A = (r_o² + r_i²)/4 = EI/EA).
    ro, ri = 0.04, 0.02
    A = np.pi * (ro**2 - ri**2)
    return BeamPreset("classic", 10.0, 2.8e7 / A, 1.2 / A, 0.3, ro, ri,
                      description="Simo & Vu-Quoc spin-up beam: L = 10 m, EA = 2.8e7 N, EI = 1.4e4 N m², "
                                  "rhoA = 1.2 kg/m")


_PAPER = BeamPreset("paper", 8.0, 70e9, 2700.0, 0.3, 0.020, 0.005724,
                    description="paper Table 1: L = 8 m aluminium tube, r_o = 20 mm, r_i = 5.724 mm")
_R_ARC = 32.0 / np.pi

BEAMS: dict[str, BeamPreset] = {
    "paper": _PAPER,
    "classic": _classic(),
    "curved-upwind": _PAPER.with_(name="curved-upwind", curve="-y", curvature_radius=_R_ARC,
                                  description="paper Fig. 7a: arc of radius 32/π m bending against the rotation"),
    "curved-downwind": _PAPER.with_(name="curved-downwind", curve="+y", curvature_radius=_R_ARC,
                                    description="paper Fig. 7b: arc of radius 32/π m bending with the rotation"),
    "curved-out-of-plane": _PAPER.with_(name="curved-out-of-plane", curve="+z", curvature_radius=_R_ARC,
                                        description="paper Fig. 7c: arc of radius 32/π m bending out of the plane"),
}


def beam_preset(name: str) -> BeamPreset:
    try:
        return BEAMS[name]
    except KeyError:
        raise ValueError(f"unknown beam preset {name!r}; choose one of {sorted(BEAMS)}") from None
