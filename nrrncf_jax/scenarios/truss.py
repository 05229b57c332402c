"""The beamlike truss of the paper's Sec. 4.5 (its Table 10 is lost in the paper's text; a substitute
geometry of the same kind).

A cantilevered space truss along x: ``bays`` bays of length ``bay`` with an equilateral
triangular cross-section of side ``side`` (vertices on a circle of radius side/√3, one on +y).
Longerons (along x) and battens (the sides of the triangle at every station) are aluminium tubes
Ø20 × 2 mm, C1 beams rigidly joined at the joints (``frame.frame_body``: each member end linked
to the joint's full gradient in rotation and shear, and a joint cell of the tube's diameter); two
crossed diagonals per side face and bay are solid rods Ø2 mm, pin-ended bars. The three joints of
the root station are clamped. Mesh: 6 beam elements per longeron bay and 4 per batten (the paper's
1092 beams and 216 bars at 36 bays).

Closed forms (``equivalent_beam``): the truss as a Timoshenko beam, with

- bending stiffness ``EI = E A_l Σ y_k² + 3 E I_l = E A_l side²/2 + 3 E I_l`` (three longerons
  of area A_l and second moment I_l at the vertices),
- shear stiffness ``GA = (3/2) GA_face``, ``GA_face = 2 E A_d s² a / l_d³ + 24 E I_l / a²``
  (per face, an X-bracing of two diagonals of area A_d and length l_d over a bay a and a face
  width s takes a transverse shear δ with the force 2 E A_d s² δ / l_d³; the face's two
  longerons add their frame action, 12 E I_l/a³ each; the three faces at 120° add up to 3/2 of
  one face in any transverse direction),
- torsional stiffness ``GJ = 3 GA_face r_f² + 3 G J_l`` (the faces' shear flows at the inradius
  r_f, and the longerons' own twist, which the rigid joints impose),
- mass per length m and polar mass moment per length I_p of all members,

and the lowest bending frequency by Southwell-Dunkerley, ``1/f² = 1/f_b² + 1/f_s²`` (the
Euler-Bernoulli cantilever's f_b = 1.8751²/(2π L²) √(EI/m) and the shear beam's quarter wave
f_s = √(GA/m)/(4L)); the first torsion frequency as the quarter-wave shaft,
``f_t = √(GJ/I_p)/(4L)``.
"""

import dataclasses
import functools

import numpy as np

from .. import _validate
from ..bodies.frame import Frame, frame_body
from ..elements import Bar, C1Beam
from ..elements.material import Material
from ..elements.section import TubeSection
from ..integrate import AdaptiveStepSize, GeneralizedAlpha
from ..models import Harmonic, Loads, RotatingFrameModel
from ..motion import Stationary
from ..reduction.basis_choice import Basis
from ..reduction.basis_to_tolerance import ToTolerance
from ..reduction.run_error import ErrorEstimator
from .forced_run import DEFAULT_BASIS, FORMULATIONS, ForcedRun, run_forced
from .run_record import check_reduction, run_integrator


@dataclasses.dataclass(frozen=True)
class TrussSpec:
    """Geometry, material and mesh of the truss (defaults: the substitute for the lost Table 10)."""

    bays: int = 36
    bay: float = 1.0  # [m]
    side: float = 0.40  # [m], the triangle's side
    E: float = 70e9  # [Pa]
    nu: float = 0.33
    rho: float = 2700.0  # [kg/m³]
    tube_outer: float = 0.010  # [m] radius
    tube_inner: float = 0.008  # [m] radius
    rod_radius: float = 0.001  # [m]
    longeron_elements: int = 6  # per bay
    batten_elements: int = 4

    def __post_init__(self):
        for name in ("bay", "side", "E", "rho", "tube_outer", "rod_radius"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be positive, got {getattr(self, name)!r}")
        for name in ("bays", "longeron_elements", "batten_elements"):
            if int(getattr(self, name)) < 1:
                raise ValueError(f"{name} must be a positive integer, got {getattr(self, name)!r}")
        if not 0.0 <= self.tube_inner < self.tube_outer:
            raise ValueError(f"tube_inner must lie in [0, tube_outer), got {self.tube_inner!r}")

    @property
    def length(self) -> float:
        return self.bays * self.bay

    @property
    def material(self) -> Material:
        return Material(self.E, self.rho, self.nu)

    def vertices(self) -> np.ndarray:
        """The section's three vertices (y, z), one on +y, counter-clockwise."""
        R = self.side / np.sqrt(3.0)
        a = 2 * np.pi * np.arange(3) / 3  # the angle from +y toward +z
        return R * np.stack([np.cos(a), np.sin(a)], axis=1)


@dataclasses.dataclass(frozen=True)
class Truss:
    """The meshed truss: the frame (body and index maps), its spec, and where things are."""

    spec: TrussSpec
    frame: Frame

    @property
    def body(self):
        return self.frame.body

    def joint(self, station: int, vertex: int) -> int:
        return 3 * station + vertex

    @property
    def clamped(self) -> np.ndarray:
        """The root station's joints, fully clamped (position and gradient)."""
        return self.frame.clamp([self.joint(0, k) for k in range(3)])

    @property
    def tip_positions(self) -> np.ndarray:
        """The position vectors of the free end's three joints (the load is shared by them)."""
        return self.frame.joint_vectors[[self.joint(self.spec.bays, k) for k in range(3)], 0]

    def station_positions(self) -> np.ndarray:
        """(stations, 3) position-vector indices of each station's joints."""
        return self.frame.joint_vectors[:, 0].reshape(-1, 3)


def _layout(spec: TrussSpec):
    """Joints, longerons, battens and diagonals (joint indices 3·station + vertex)."""
    yz = spec.vertices()
    n = spec.bays + 1
    joints = np.array([[i * spec.bay, y, z] for i in range(n) for y, z in yz])
    j = lambda i, k: 3 * i + k  # noqa: E731
    longerons = [(j(i, k), j(i + 1, k)) for i in range(spec.bays) for k in range(3)]
    battens = [(j(i, k), j(i, (k + 1) % 3)) for i in range(n) for k in range(3)]
    diagonals = [pair for i in range(spec.bays) for k in range(3)
                 for pair in ((j(i, k), j(i + 1, (k + 1) % 3)), (j(i, (k + 1) % 3), j(i + 1, k)))]
    return joints, longerons, battens, diagonals


@functools.cache
def build_truss(spec: TrussSpec = TrussSpec()) -> Truss:
    """The truss body of ``spec`` (cached: the element integrals of the full truss take seconds)."""
    joints, longerons, battens, diagonals = _layout(spec)
    tube = C1Beam(spec.material, TubeSection(spec.tube_outer, spec.tube_inner))
    rod = Bar(spec.E, spec.rho, np.pi * spec.rod_radius**2)
    n_el = [spec.longeron_elements] * len(longerons) + [spec.batten_elements] * len(battens)
    frame = frame_body(joints, longerons + battens, tube, n_el, bars=diagonals, bar=rod)
    return Truss(spec=spec, frame=frame)


@dataclasses.dataclass(frozen=True)
class EquivalentBeam:
    """The truss as a beam (see the module docstring); SI units, frequencies in Hz."""

    EI: float
    GA: float
    GJ: float
    m: float  # mass per length
    I_p: float  # polar mass moment per length
    f_bending_eb: float
    f_bending: float  # with the shear flexibility (Southwell-Dunkerley)
    f_torsion: float


def equivalent_beam(spec: TrussSpec = TrussSpec()) -> EquivalentBeam:
    A_l = np.pi * (spec.tube_outer**2 - spec.tube_inner**2)
    I_l = np.pi / 4.0 * (spec.tube_outer**4 - spec.tube_inner**4)  # a tube's second moment
    A_d = np.pi * spec.rod_radius**2
    a, s, L = spec.bay, spec.side, spec.length
    R, r_f = s / np.sqrt(3.0), s / (2.0 * np.sqrt(3.0))
    l_d = np.hypot(a, s)
    G = spec.E / (2.0 * (1.0 + spec.nu))
    EI = spec.E * A_l * s**2 / 2.0 + 3 * spec.E * I_l
    # A face's shear stiffness: its X-bracing, plus the frame action of its two longerons, each
    # bent over a bay between battens that keep its ends parallel (12 E I_l / a³ each).
    GA_face = 2.0 * spec.E * A_d * s**2 * a / l_d**3 + 2 * 12.0 * spec.E * I_l / a**2
    GA = 1.5 * GA_face
    # Torsion: the faces' shear flows at the inradius, and each longeron's own twist (the rigid
    # joints turn its section with the truss's): G J_l, J_l = 2 I_l for a tube.
    GJ = 3.0 * GA_face * r_f**2 + 3 * G * 2.0 * I_l
    rho = spec.rho
    stations = spec.bays + 1
    m_batten = 3 * stations * rho * A_l * s / L  # per length, spread over the truss
    m = 3 * rho * A_l + m_batten + 6 * spec.bays * rho * A_d * l_d / L
    I_p = (3 * rho * A_l * R**2 + 3 * stations * rho * A_l * (s * r_f**2 + s**3 / 12) / L
           + 6 * spec.bays * rho * A_d * l_d * (r_f**2 + s**2 / 12) / L)
    f_b = 1.875104068711961**2 / (2 * np.pi * L**2) * np.sqrt(EI / m)
    f_s = np.sqrt(GA / m) / (4 * L)
    return EquivalentBeam(EI=EI, GA=GA, GJ=GJ, m=m, I_p=I_p, f_bending_eb=f_b,
                          f_bending=1.0 / np.sqrt(1.0 / f_b**2 + 1.0 / f_s**2),
                          f_torsion=np.sqrt(GJ / I_p) / (4 * L))


def mode_types(truss: Truss, phi: np.ndarray) -> list[str]:
    """Each mode's type from the motion of the stations' joints: ``bending-y``/``bending-z``
    (the section's mean transverse displacement dominates; for the degenerate pairs of an
    equilateral section the dominant axis of the pair's arbitrary orientation), ``torsion`` (the
    rotation of the section about x), ``axial``, or ``local`` (the joints carry under 10 % of the
    mode's amplitude: a member's own vibration)."""
    pos = truss.station_positions()  # (stations, 3)
    yz = truss.spec.vertices()
    R2 = float(np.sum(yz**2))
    types = []
    P = np.asarray(phi).reshape(truss.body.n_vectors, 3, -1)
    isp = np.asarray(truss.body.is_position)
    for i in range(P.shape[-1]):
        u = P[pos, :, i]  # (stations, 3 joints, 3)
        mean = u.mean(axis=1)
        twist = np.sum(yz[None, :, 0] * u[:, :, 2] - yz[None, :, 1] * u[:, :, 1], axis=1) / np.sqrt(R2)
        shares = {"axial": np.sum(mean[:, 0] ** 2), "bending-y": np.sum(mean[:, 1] ** 2),
                  "bending-z": np.sum(mean[:, 2] ** 2), "torsion": np.sum(twist**2) / 3.0}
        joints_share = np.sum(u**2) / len(yz) / (np.sum(P[isp, :, i] ** 2) / isp.sum())
        types.append("local" if joints_share < 0.1 else max(shares, key=shares.get))
    return types


# --- dynamics: the tip excitation at the first bending frequency -------------------------------


def truss_model(truss: Truss, F0: float, frequency: float, solver: str = "auto") -> RotatingFrameModel:
    """The full RNCF model of the cantilevered truss in a stationary frame, with the transverse force
    ``F(t) = F0 sin(2π f t)`` along y at the free end's centroid, shared equally by its three
    joints (the force's resultant acts at the centroid; the section is symmetric about it)."""
    _validate.positive("F0 (force amplitude)", F0)
    _validate.positive("frequency", frequency)
    forces = np.tile([0.0, F0 / 3.0, 0.0], (3, 1))
    loads = Loads(point_vectors=truss.tip_positions, point_forces=forces, point_history=Harmonic(frequency))
    return RotatingFrameModel(truss.body, Stationary(), loads=loads, clamped=truss.clamped, solver=solver)


def first_bending(truss: Truss, count: int = 6):
    """The lowest bending pair among the first ``count`` modes (``mode_types``): (frequency [Hz],
    the tip's y-amplitude² of the pair's mass-normalised modes, summed: the pair's orientation is
    arbitrary, the sum is not)."""
    from ..reduction import vibration_modes

    model = RotatingFrameModel(truss.body, Stationary(), clamped=truss.clamped)
    modes = vibration_modes(truss.body, model.free_mask(), count)
    phi = np.asarray(modes.phi)
    bending = [i for i, t in enumerate(mode_types(truss, phi)) if t.startswith("bending")]
    if len(bending) < 2:
        raise ValueError(f"no bending pair among the first {count} modes; ask for more")
    pair = bending[:2]
    tip_y = phi.reshape(truss.body.n_vectors, 3, -1)[truss.tip_positions, 1][:, pair].mean(axis=0)
    return float(modes.omega[pair[0]]) / (2 * np.pi), float(np.sum(tip_y**2))


def resonant_force(truss: Truss, deflection: float, t_end: float) -> tuple[float, float]:
    """``(F0, f)``: the first bending frequency f and the amplitude F0 of a force at f that brings
    the undamped linear tip response to ``deflection`` at ``t_end``: at resonance a mode's
    amplitude grows as φ_tip² F0 t / (2ω), so F0 = 2ω · deflection / (φ_tip² t_end)."""
    f, phi2 = first_bending(truss)
    return 2 * (2 * np.pi * f) * deflection / (phi2 * t_end), f


@dataclasses.dataclass
class TrussRun(ForcedRun):
    """One forced-response run (``ForcedRun``); its observed point is the free end's midpoint
    (the centroid of the tip joints), ``tip``."""

    @property
    def tip(self) -> np.ndarray:
        return self.point

    def summary(self) -> dict:
        d = super().summary()
        d.update(tip_y_max_m=float(np.abs(self.tip[:, 1]).max()), tip_z_max_m=float(np.abs(self.tip[:, 2]).max()))
        return d


def run_truss(formulation: str = "nr-rncf", spec: TrussSpec = TrussSpec(), F0: float | None = None,
              frequency: float | None = None, deflection: float = 0.05, t_end: float = 10.0, dt_out: float = 0.02,
              basis: Basis = DEFAULT_BASIS, *, solver: GeneralizedAlpha | None = None,
              controller: AdaptiveStepSize | None = None, estimator: ErrorEstimator | None = ErrorEstimator(),
              tol: float | ToTolerance | None = None, reference: "bool | TrussRun" = False, progress: bool = False,
              max_steps: int = 500_000) -> TrussRun:
    """The truss excited at its free end by ``F0 sin(2π f t)`` along y (default: f the first
    bending frequency and F0 from ``resonant_force`` for a tip deflection of ``deflection`` times
    the length at ``t_end``), run with the full RNCF model (``'rncf'``, sparse solver) or NR-RNCF
    (``'nr-rncf'``: ``basis``, a ``reduction.Basis``, default ``DEFAULT_BASIS``, 4 VMs and 6 MDs
    chosen by MMI among 12 candidates over the output times; with ``tol``, the basis chosen to a
    target χ_rel in per cent instead, ``run_forced``), with ``solver`` (default
    ``GeneralizedAlpha(0.9)``) and ``controller`` (default ``AdaptiveStepSize(1e-4, 1e-6)``). With
    ``reference`` χ_rel and the speed-up are filled in: ``True`` against the full model converged,
    the error split into its parts (``run_forced``); or against a full ``TrussRun`` on the same
    output times, as it is. ``estimator``: the NR-RNCF run's error estimate (a
    ``reduction.ErrorEstimator``: static or dynamic, with or without the run's time-integration
    part; None: none; ``run_forced``)."""

    if formulation not in FORMULATIONS:
        raise ValueError(f"formulation must be one of {FORMULATIONS}, got {formulation!r}")
    ts = _validate.output_times(t_end, dt_out)
    solver, controller = run_integrator(solver, controller)
    check_reduction(basis, estimator)
    truss = build_truss(spec)
    if F0 is None or frequency is None:
        F0_auto, f_auto = resonant_force(truss, deflection * spec.length, t_end)
        F0 = F0_auto if F0 is None else F0
        frequency = f_auto if frequency is None else frequency
    return run_forced(truss_model(truss, F0, frequency), formulation, ts, truss.tip_positions, basis=basis,
                      solver=solver, controller=controller, estimator=estimator, tol=tol, reference=reference,
                      progress=progress, max_steps=max_steps, cls=TrussRun)


__all__ = ["DEFAULT_BASIS", "FORMULATIONS", "EquivalentBeam", "Truss", "TrussRun", "TrussSpec", "build_truss",
           "equivalent_beam", "first_bending", "mode_types", "resonant_force", "run_truss", "truss_model"]
