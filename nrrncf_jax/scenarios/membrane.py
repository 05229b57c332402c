"""The rotating membrane of the paper's Sec. 4.3 (its Table 6 is lost; the parameters chosen here).

A flat circular aluminium plate of radius b spun about its axis Z, clamped at its centre, meshed
by the 15-ring hexagonal disk (1350 triangles, 721 vertices, 2070 edges) of ``TrianglePlate``
elements: 18,912 DOFs, the paper's count.

**Parameters (``MembraneSpec``).** b = 1 m, h = 1.36 mm, E = 70 GPa, ν = 0.33, ρ = 2700 kg/m³.
The hub is the centre node, clamped (position, both slopes and director): a rigid hub about one
ring (b/15) in size. The thickness is chosen so that the mode order is the paper's: with this
hub the first in-plane mode (the in-plane torsion, 16.75 Hz: independent of h) lies between the
18th and the 19th bending mode (whose frequencies scale with h) for 1.28 mm < h < 1.44 mm, so it
is the 19th mode; the 3rd and 8th modes are the first two axisymmetric bending modes. (A
2.3 mm plate puts the in-plane torsion 13th; a hub clamped over the first ring of vertices,
a = b/15, makes it stiffer and the 8th mode a four-nodal-diameter pair.) The in-plane torsion
frequency depends on the hub's size, hence on this mesh: the hub is part of the model.

**Cases (paper Sec. 4.3).**
- ``"in-plane"`` (case A): the spin-up of Eq. 43 to ωs (7 or 10 rad/s) over Ts = 2 s. The
  loads (Euler and centrifugal) lie in the plane, so only in-plane modes respond: the paper's
  basis is VM 19 (the in-plane torsion) and its modal derivative θ19,19.
- ``"bending-torsion"`` (case B): the same spin-up with ωs = 4 rad/s while the hub oscillates
  along Z, w_z = 0.012 sin(0.25·2πt) m (a prescribed translation of the reference frame): the
  paper's basis is VMs 3, 8 (axisymmetric bending) and 19 with their six modal derivatives.

``paper_basis`` finds those modes by their shapes (``mode_types``) rather than by number, so
that other meshes and thicknesses get the same kind of basis. Mode numbers in the code are
0-based (the paper's 19th mode is index 18).

The deflections "measured in the reference frame" (the paper's Figs. 12 and 14) are those of the
rim point on the frame's +X axis: radial (X), tangential (Y) and axial (Z).
"""

import dataclasses
import functools
import time

import numpy as np

from .. import _validate
from ..bodies.plate_mesh import PlateBody, hexagonal_disk, plate_body
from ..elements import TrianglePlate
from ..integrate import AdaptiveStepSize, GeneralizedAlpha
from ..models import RotatingFrameModel
from ..motion import ComposedMotion, HarmonicTranslation, SpinUp
from ..reduction.basis_choice import Basis
from ..reduction.basis_to_tolerance import ToTolerance
from ..reduction.run_error import ErrorEstimator
from .forced_run import FORMULATIONS, ForcedRun, run_forced
from .run_record import check_reduction, run_integrator

CASES = ("in-plane", "bending-torsion")


@dataclasses.dataclass(frozen=True)
class MembraneSpec:
    """The rotating membrane: ``radius`` b [m], ``thickness`` h [m], aluminium, ``rings`` of the
    hexagonal disk mesh (15: the paper's 1350 triangles)."""

    radius: float = 1.0
    thickness: float = 1.36e-3
    E: float = 70e9
    rho: float = 2700.0
    nu: float = 0.33
    rings: int = 15

    def __post_init__(self):
        for name in ("radius", "thickness", "E", "rho"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be finite and positive, got {v!r}")
        if not -1.0 < self.nu < 0.5:
            raise ValueError(f"nu must lie in (-1, 0.5), got {self.nu!r}")
        if isinstance(self.rings, bool) or int(self.rings) != self.rings or self.rings < 2:
            raise ValueError(f"rings must be an integer >= 2, got {self.rings!r}")

    @property
    def element(self) -> TrianglePlate:
        return TrianglePlate(self.E, self.rho, self.nu, self.thickness)


@dataclasses.dataclass(frozen=True)
class Membrane:
    """The meshed membrane (``plate``: the body with its mesh and numbering) and where things are."""

    spec: MembraneSpec
    plate: PlateBody

    @property
    def body(self):
        return self.plate.body

    @property
    def clamped(self) -> np.ndarray:
        """The hub: the centre node's position, slopes and director."""
        return self.plate.clamped([0])

    @property
    def rim_vertices(self) -> np.ndarray:
        """The outer ring's vertices, counter-clockwise from +X."""
        k = self.spec.rings
        return 1 + 3 * k * (k - 1) + np.arange(6 * k)

    @property
    def rim_point(self) -> int:
        """The position vector of the rim point on +X (where the deflections are measured)."""
        return int(self.plate.layout.vertex_vectors[self.rim_vertices[0], 0])


@functools.lru_cache(maxsize=2)
def build_membrane(spec: MembraneSpec = MembraneSpec()) -> Membrane:
    """Mesh and build the membrane (cached: integrating the 15-ring body's element integrals takes
    seconds, and several functions start from it)."""
    V, T = hexagonal_disk(spec.radius, spec.rings)
    return Membrane(spec=spec, plate=plate_body(V, T, spec.element))


def mode_types(membrane: Membrane, phi: np.ndarray) -> list[str]:
    """Each mode's type from its shape (columns of ``phi``, all DOFs): ``"in-plane"`` when most of
    it (by sum of squares) is in-plane motion (``PlateBody.in_plane``), else ``"bending"``; with
    its number of nodal diameters n, the dominant harmonic along the rim. n = 0 is told apart:
    ``"axisymmetric bending"``, ``"in-plane torsion"`` (tangential) and ``"in-plane radial"``."""
    plate = membrane.plate
    phi = np.asarray(phi).reshape(plate.body.n_dof, -1)
    in_plane = plate.in_plane()
    rim = membrane.rim_vertices
    theta = np.arctan2(plate.vertices[rim, 1], plate.vertices[rim, 0])
    rows = plate.layout.vertex_vectors[rim, 0]
    harmonics = np.exp(-1j * np.outer(np.arange(len(rim) // 2 + 1), theta))  # (n, rim)
    types = []
    for i in range(phi.shape[1]):
        u = phi[:, i].reshape(-1, 3)[rows]
        planar = np.sum(phi[in_plane, i] ** 2) > 0.5 * np.sum(phi[:, i] ** 2)
        if planar:
            ur = u[:, 0] * np.cos(theta) + u[:, 1] * np.sin(theta)
            ut = -u[:, 0] * np.sin(theta) + u[:, 1] * np.cos(theta)
            cr, ct = np.abs(harmonics @ ur), np.abs(harmonics @ ut)
            n = int(np.argmax(np.maximum(cr, ct)))
            name = ("in-plane torsion" if ct[0] > cr[0] else "in-plane radial") if n == 0 else f"in-plane n={n}"
        else:
            n = int(np.argmax(np.abs(harmonics @ u[:, 2])))
            name = "axisymmetric bending" if n == 0 else f"bending n={n}"
        types.append(name)
    return types


@functools.lru_cache(maxsize=4)
def membrane_modes(spec: MembraneSpec = MembraneSpec(), count: int = 24):
    """``(modes, types)``: the first ``count`` vibration modes of the membrane at rest, clamped at
    the hub (``reduction.VibrationModes`` on all DOFs), and their ``mode_types`` (cached)."""
    from ..motion import Stationary
    from ..reduction import vibration_modes

    m = build_membrane(spec)
    modes = vibration_modes(m.body, RotatingFrameModel(m.body, Stationary(), clamped=m.clamped).free_mask(), count)
    return modes, mode_types(m, np.asarray(modes.phi))


def paper_basis(case: str, spec: MembraneSpec = MembraneSpec(), count: int = 24) -> tuple[list, list]:
    """The paper's basis for ``case``, found by mode type among the first ``count`` modes:
    ``(vms, mds)`` as 0-based mode indices and index pairs. In-plane: the first in-plane torsion
    mode and its own MD; bending-torsion: the first two axisymmetric bending modes and the first
    in-plane torsion mode with the MDs of all their pairs (six)."""
    if case not in CASES:
        raise ValueError(f"case must be one of {CASES}, got {case!r}")
    types = membrane_modes(spec, count)[1]
    torsion = [i for i, t in enumerate(types) if t == "in-plane torsion"]
    axisym = [i for i, t in enumerate(types) if t == "axisymmetric bending"]
    need = 1 if case == "in-plane" else 3
    if not torsion or (case != "in-plane" and len(axisym) < 2):
        raise ValueError(f"the first {count} modes do not hold the paper's basis (an in-plane torsion mode"
                         f"{'' if case == 'in-plane' else ' and two axisymmetric bending modes'}); ask for more")
    vms = sorted(torsion[:1] + ([] if need == 1 else axisym[:2]))
    mds = [(i, j) for a, i in enumerate(vms) for j in vms[a:]]
    return vms, mds


def membrane_motion(case: str, omega_s: float, T_s: float = 2.0, hub_amplitude: float = 0.012,
                    hub_frequency: float = 0.25):
    """The reference frame's motion: the spin-up of Eq. 43 about Z, carried (bending-torsion) by
    the hub's oscillation ``hub_amplitude·sin(2π·hub_frequency·t)`` along Z."""
    if case not in CASES:
        raise ValueError(f"case must be one of {CASES}, got {case!r}")
    spin = SpinUp(omega_s, T_s)
    if case == "in-plane":
        return spin
    return ComposedMotion(outer=HarmonicTranslation([0.0, 0.0, hub_amplitude], hub_frequency), inner=spin)


def membrane_model(membrane: Membrane, case: str, omega_s: float, T_s: float = 2.0,
                   solver: str = "auto") -> RotatingFrameModel:
    """The full RNCF model of ``case`` (see ``membrane_motion``)."""
    return RotatingFrameModel(membrane.body, membrane_motion(case, omega_s, T_s), clamped=membrane.clamped,
                              solver=solver)


DEFAULT_OMEGA = {"in-plane": 7.0, "bending-torsion": 4.0}

DEFAULT_BASIS = Basis(n_modes=24, spin_state=False, max_dofs=None)
"""``run_membrane``'s basis: the paper's (its ``"auto"`` VMs and MDs stand for ``paper_basis``'s)
among 24 candidate modes, as given: no spinning-state enrichment and no cap on its size."""


@dataclasses.dataclass
class MembraneRun(ForcedRun):
    """One run of the rotating membrane (``ForcedRun``); its observed point is the rim point on +X,
    ``rim`` (radial X, tangential Y, axial Z in the reference frame)."""

    case: str = ""
    omega_s: float = 0.0

    @property
    def rim(self) -> np.ndarray:
        return self.point

    def summary(self) -> dict:
        d = super().summary()
        d.update(case=self.case, omega_s=self.omega_s,
                 rim_max_m=[float(v) for v in np.abs(self.rim).max(axis=0)])
        return d


def run_membrane(case: str = "in-plane", omega_s: float | None = None, formulation: str = "nr-rncf",
                 spec: MembraneSpec = MembraneSpec(), basis: Basis = DEFAULT_BASIS, T_s: float = 2.0,
                 t_end: float = 3.0, dt_out: float = 0.01, *, solver: GeneralizedAlpha | None = None,
                 controller: AdaptiveStepSize | None = None, estimator: ErrorEstimator | None = ErrorEstimator(),
                 tol: float | ToTolerance | None = None, reference: "bool | MembraneRun" = False,
                 progress: bool = False, max_steps: int = 500_000) -> MembraneRun:
    """The rotating membrane's ``case`` (``CASES``) at the steady rate ``omega_s`` (default 7 rad/s
    in-plane, 4 rad/s bending-torsion) with the full RNCF model (``'rncf'``, sparse solver above
    1000 DOFs) or NR-RNCF (``'nr-rncf'``), run with ``solver`` (default ``GeneralizedAlpha(0.9)``)
    and ``controller`` (default ``AdaptiveStepSize(1e-5, 1e-7)``, below). With ``reference`` χ_rel
    and the speed-up are filled in: ``True`` against the full model converged, the error split into
    its parts (``run_forced``); or against a full ``MembraneRun`` of the same case and output
    times, as it is. The offline time counts the modal analysis (``membrane_modes``, cached: a
    second run with the same spec and ``basis.n_modes`` reuses it and counts only the lookup).

    The NR-RNCF basis (``basis``, a ``reduction.Basis``; default ``DEFAULT_BASIS``) defaults to
    the paper's: a ``vms`` or ``mds`` of ``"auto"`` stands here for the paper's choice
    (``paper_basis``, found by mode type among the basis's ``n_modes`` candidates), not for the
    MMI's; a count (chosen by MMI) or explicit indices and pairs override it, e.g.
    ``dataclasses.replace(DEFAULT_BASIS, mds=[])`` for the paper's VMs alone. The rest of the
    basis is used as it is: the default's ``spin_state=False`` (the paper's basis as given, no
    spinning-state enrichment) and ``max_dofs=None`` (no cap on its size).

    Tolerances: the step error is measured on the coordinates, whose positions are of the order
    of the radius, while the deflections are 1e-4 to 1e-3 of it; at rtol = 1e-4 the integration
    error of either model is then of the order of the reduction's (the 8-ring disk in
    bending-torsion: χ_rel of the paper's basis 2.2 % at rtol 1e-4, 0.20 % at 1e-6, where the
    full model's steps grow from 97 to 348). The default 1e-5 is the compromise.

    ``tol``: the basis chosen to a target χ_rel in per cent instead of the paper's (``run_forced``).
    ``estimator``: the NR-RNCF run's error estimate (a ``reduction.ErrorEstimator``: static or
    dynamic, with or without the run's time-integration part; None: none; ``run_forced``)."""

    if case not in CASES:
        raise ValueError(f"case must be one of {CASES}, got {case!r}")
    if formulation not in FORMULATIONS:
        raise ValueError(f"formulation must be one of {FORMULATIONS}, got {formulation!r}")
    omega_s = DEFAULT_OMEGA[case] if omega_s is None else omega_s
    ts = _validate.output_times(t_end, dt_out)
    solver, controller = run_integrator(solver, controller, rtol=1e-5, atol=1e-7)
    check_reduction(basis, estimator)
    membrane = build_membrane(spec)
    full = membrane_model(membrane, case, omega_s, T_s)
    modes, modes_s = None, 0.0
    if formulation == "nr-rncf":
        # One modal analysis serves the choice of the paper's modes by type and the reduction.
        t0 = time.perf_counter()
        modes = membrane_modes(spec, basis.n_modes)[0]
        auto = [isinstance(x, str) and x == "auto" for x in (basis.vms, basis.mds)]
        if tol is None and any(auto):
            paper_vms, paper_mds = paper_basis(case, spec, basis.n_modes)
            basis = dataclasses.replace(basis, vms=paper_vms if auto[0] else basis.vms,
                                        mds=paper_mds if auto[1] else basis.mds)
        modes_s = time.perf_counter() - t0
    run = run_forced(full, formulation, ts, membrane.rim_point, basis=basis, modes=modes, solver=solver,
                     controller=controller, estimator=estimator, tol=tol, reference=reference, progress=progress,
                     max_steps=max_steps, cls=MembraneRun, case=case, omega_s=float(omega_s))
    if run.offline_s is not None:
        run.offline_s += modes_s
    return run


__all__ = ["CASES", "DEFAULT_BASIS", "DEFAULT_OMEGA", "Membrane", "MembraneRun", "MembraneSpec", "build_membrane",
           "membrane_model", "membrane_modes", "membrane_motion", "mode_types", "paper_basis", "run_membrane"]
