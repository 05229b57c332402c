"""The flexible three-beam pendulum of the paper's Sec. 4.4 (Table 9): full order and NR-RNCF.

Three beams, each 1.0 m long, solid circular section of radius 5 mm, ρ = 1100 kg/m³,
E = 5 MPa, ν = 0.3 (a soft rubber-like rod: as a cantilever its first two bending frequencies,
0.09 and 0.59 Hz, are of the order of the swing), C1 beam elements. Beam 1 is hinged to the ground at its left end (the
origin), the beams are joined end to end by revolute joints about Z, and the chain is released
from rest in a straight horizontal line along +x, gravity −9.81 m/s² along Y.

Three models: ``build_pendulum``, inertial-frame (ANCF) bodies joined by ``multibody`` joints
and integrated by the index-3 generalized-α (``integrate.GeneralizedAlphaIndex3``), the
full-order reference; ``build_rncf_pendulum``, the same beams at full order in floating frames
(the paper's full RNCF, the ANCF model in other coordinates); and ``build_reduced_pendulum``,
NR-RNCF: each beam in a floating frame
(``multibody.floating``) with its deformation reduced to cantilever modes and their modal
derivatives (optionally with the right-end joint's static modes), or to the
extended Craig-Bampton basis (``reduction.craig_bampton``: the joint's position as boundary
coordinates, fixed-interface modes and their MDs); ``mmi_per_body`` picks each beam's MDs by
maximum modal interaction; ``pendulum_to_tolerance`` grows the beams' basis along
``candidate_order`` until the error estimate of a training run meets a target χ_rel
(``multibody.basis_to_tolerance``); ``release_sweep`` runs any of them released at a batch of
angles in one compiled, vmapped loop. ``run_pendulum``/``run_chain`` record a run (``PendulumRun``), and
``PendulumRun.compare`` its χ_rel and speed-up against a full-order one.
"""

import dataclasses
from typing import ClassVar

import jax
import jax.numpy as jnp
import numpy as np

from .. import _validate
from .._validate import positive_int
from ..bodies.body import beam_body
from ..bodies.mesh import straight_reference
from ..elements.material import Material
from ..elements.section import TubeSection
from ..integrate import (
    AdaptiveStepSize,
    GeneralizedAlphaIndex3,
    Newton,
    batch_lanes,
    simulate,
    simulate_batch,
    step_control_name,
    tightened,
)
from ..integrate.simulate import kernel_options, simulate_timed
from ..models.constrained import AbstractConstrainedModel
from ..multibody import (
    GROUND,
    FloatingFrameSystem,
    Marker,
    MultibodySystem,
    full_floating_body,
    hinge,
    placed,
)
from ..reduction.run_error import TIGHTEN, ErrorEstimator, estimate_times
from .run_record import RunRecord, chosen_step_settings, estimate_mechanism_run, run_integrator, step_tolerances_to

# The C1 beam's nodal vectors at a node: r, r_x, r_y, r_xy, r_z, r_xz
_R, _RX, _RY, _RZ, _PER_NODE = 0, 1, 2, 4, 6


@dataclasses.dataclass(frozen=True)
class PendulumSpec:
    """The pendulum: ``beams`` beams of ``length`` [m] and solid circular section of ``radius``,
    material ``E`` [Pa], ``rho`` [kg/m³], ``nu``; ``elements`` C1 elements per beam."""

    beams: int = 3
    length: float = 1.0
    radius: float = 0.005
    E: float = 5e6
    rho: float = 1100.0
    nu: float = 0.3
    elements: int = 10
    gravity: float = 9.81

    def __post_init__(self):
        positive_int("beams", self.beams)
        positive_int("elements", self.elements)
        for name in ("length", "radius", "E", "rho", "gravity"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be positive, got {getattr(self, name)!r}")


def _beam(spec: PendulumSpec):
    material = Material(spec.E, spec.rho, spec.nu)
    return beam_body(material, TubeSection(spec.radius), straight_reference(spec.length, spec.elements))


def _joints(spec: PendulumSpec) -> list:
    """Hinges about Z: beam 0's left end to the ground at the origin, and beam k's right end to beam
    k + 1's left end, at x = (k + 1) L (markers; the systems resolve them to nodal vectors)."""
    z = (0.0, 0.0, 1.0)
    joints = [hinge(GROUND, Marker(0, (0.0, 0.0, 0.0)), axis=z)]
    ends = [((k + 1) * spec.length, 0.0, 0.0) for k in range(spec.beams - 1)]
    return joints + [hinge(Marker(k, x), Marker(k + 1, x), axis=z) for k, x in enumerate(ends)]


REFERENCE_CONDITIONS = (_R, _RY, _RZ)
"""The nodal vectors of each beam's left node that define its floating frame (the paper: "the
left end's position vector and local frame"): its position and cross-section vectors, zero
deformation in the frame."""


def build_pendulum(spec: PendulumSpec = PendulumSpec()) -> MultibodySystem:
    """The jointed system: beam k along x from k·L to (k+1)·L, a ground hinge about Z at the
    origin, and hinges about Z between consecutive beams (each at the section vector r_z of the
    next beam's first node, kept normal to the slope and section vector of the previous beam's last
    node)."""
    beam = _beam(spec)
    bodies = [placed(beam, translation=(k * spec.length, 0.0, 0.0)) for k in range(spec.beams)]
    return MultibodySystem(bodies, _joints(spec), gravity=(0.0, -spec.gravity, 0.0))


LEFT_END_FRAME = ((_R, 0), (_R, 1), (_R, 2), (_RX, 1), (_RX, 2), (_RY, 2))
"""The full-order RNCF's reference conditions, (nodal vector, component) of each beam's left node
held in its frame: the position (3), and the left end's local frame, x along the centre line's
tangent r_x (its y and z components zero) and y in the plane of r_x and the section vector r_y (its
z component zero). Six conditions for the frame's six motions, so the model is the ANCF one in
other coordinates (the two converge together: ``tests/test_floating.py``).

Why the tangent and not the section vectors (``LEFT_SECTION_FRAME``): a C1 beam's section
vectors shear against its centre line, and their shear and stretch vibrate at the mesh's highest
frequencies. A frame that follows them carries that vibration into every coordinate of the body
(each one measured from the frame), and the step-size control then rejects many of its steps;
with the tangent frame the step counts follow the ANCF model's, as the same equations should. The
NR-RNCF basis holds the section vectors entirely (``REFERENCE_CONDITIONS``, a cantilever's clamp):
its modes have no shear vibration at the clamp to carry."""

LEFT_SECTION_FRAME = ((_R, 0), (_R, 1), (_R, 2), (_RY, 0), (_RY, 2), (_RZ, 0))
"""The alternative: the Gram-Schmidt frame of the left node's section vectors, x normal to r_y
and r_z (their x components zero), y along r_y (its z component zero). The same model in other
coordinates; see ``LEFT_END_FRAME`` for why it is not the default."""


def build_rncf_pendulum(spec: PendulumSpec = PendulumSpec(), frame=LEFT_END_FRAME) -> FloatingFrameSystem:
    """The full-order RNCF pendulum (the paper's reference): each beam in the floating frame of
    its left end (``frame``: six (nodal vector, component) pairs of its left node held in the
    frame, ``LEFT_END_FRAME`` or ``LEFT_SECTION_FRAME``) with all its other nodal coordinates as
    deformation coordinates and its elements' own elastic force (``multibody.full_floating_body``),
    the same joints as ``build_pendulum``. 3 × (7 + 192) coordinates on the paper's 10-element
    beams."""
    beam = _beam(spec)
    held = [3 * v + i for v, i in frame]
    if len(set(held)) != 6 or not all(0 <= h < 3 * _PER_NODE for h in held):
        raise ValueError(f"frame must be six distinct (nodal vector, component) pairs of the left node, got {frame}")
    free = np.ones(beam.n_dof, bool)
    free[held] = False
    bodies = [full_floating_body(beam, free, R0=(k * spec.length, 0.0, 0.0)) for k in range(spec.beams)]
    return FloatingFrameSystem(bodies, _joints(spec), gravity=(0.0, -spec.gravity, 0.0))


CONDITIONS = ("clamped", "pinned", "mean-axis")
"""The reference conditions a pendulum beam's basis may take (``PendulumBasis.conditions``)."""


@dataclasses.dataclass(frozen=True)
class PendulumBasis:
    """What each beam of the NR-RNCF pendulum keeps (``build_reduced_pendulum``, which says what
    each option does; ``run_pendulum(formulation="nr-rncf", basis=...)``): ``n_vms`` vibration
    modes and the modal derivatives of ``pairs`` (``"all"``: the k(k+1)/2 pairs i ≤ j, the
    paper's 5 VMs + 15 MDs; or (i, j) pairs; or none, ``()``); ``joint_modes``: the joints' static
    modes too; ``craig_bampton``: the extended Craig-Bampton basis instead; ``body_pairs``: one
    sequence of MD pairs a beam instead of ``pairs`` (``mmi_per_body``'s selection); the reference
    ``conditions`` (``CONDITIONS``); ``in_plane``: the beam's in-plane modes only. The default is
    the paper's basis. Frozen (the pairs kept as tuples): ``dataclasses.replace(basis, n_vms=3)``
    is a variant. Checked as it is made; ``build_reduced_pendulum`` checks ``body_pairs`` against
    the pendulum's beams."""

    n_vms: int = 5
    pairs: str | tuple = "all"
    joint_modes: bool = False
    craig_bampton: bool = False
    body_pairs: tuple | None = None
    conditions: str = "clamped"
    in_plane: bool = True

    def __post_init__(self):
        positive_int("n_vms", self.n_vms)
        for name in ("joint_modes", "craig_bampton", "in_plane"):
            _validate.boolean(name, getattr(self, name))
        if isinstance(self.pairs, str):
            if self.pairs != "all":
                raise ValueError(f"pairs must be 'all' or a sequence of (i, j) pairs, got {self.pairs!r}")
        else:
            object.__setattr__(self, "pairs", tuple(tuple(p) for p in self.pairs))
        if self.body_pairs is not None:
            object.__setattr__(self, "body_pairs", tuple(tuple(tuple(int(i) for i in pair) for pair in b)
                                                         for b in self.body_pairs))
        if self.conditions not in CONDITIONS:
            raise ValueError(f"conditions must be 'clamped', 'pinned' or 'mean-axis', got {self.conditions!r}")
        if self.craig_bampton and self.conditions == "mean-axis":
            raise ValueError("craig_bampton holds the beams' boundary coordinates: it goes with conditions='clamped' "
                             "or 'pinned', not 'mean-axis'")
        if self.craig_bampton and self.joint_modes:
            raise ValueError("craig_bampton already holds the joint's static modes: pass one of craig_bampton, "
                             "joint_modes")

    @property
    def md_pairs(self) -> list:
        """The MD pairs of ``pairs`` as a list of (i, j) (``"all"`` spelled out)."""
        n = self.n_vms
        return [(i, j) for i in range(n) for j in range(i, n)] if self.pairs == "all" else list(self.pairs)


def build_reduced_pendulum(spec: PendulumSpec = PendulumSpec(),
                           basis: PendulumBasis = PendulumBasis()) -> tuple[FloatingFrameSystem, dict]:
    """NR-RNCF of the pendulum, each beam reduced as ``basis`` (a ``PendulumBasis``; default the
    paper's) says; below, its options. Each beam reduced by ``multibody.reduce`` at its two
    joints, in the reference ``conditions`` (``reduce``'s): ``"clamped"``, the default (the frame at the left
    end, a cantilever: the paper's choice, and Craig-Bampton's), ``"mean-axis"`` (free-free modes,
    the frame at the beam's centre of mass and its deformation without momentum relative to it,
    Buckens' conditions) or ``"pinned"``. Each beam of the chain hangs from hinges that carry no
    moment, and at equal modes and accuracy the mean axes take about half the cantilever's steps
    (``benchmarks/reference_conditions.py``); they are not the default because the static error
    estimate, the pendulum's default, cannot hold a frame that no joint holds
    (``multibody.error_estimate``: a mean-axis chain is estimated by the dynamic method). To ``n_vms``
    vibration modes and their modal derivatives (``pairs``: ``"all"``, the k(k+1)/2 pairs i ≤ j,
    the paper's 5 VMs + 15 MDs; or a sequence of (i, j); or ``()``), with ``joint_modes`` the static
    modes of the joints too (``reduce``'s ``interface_modes``: under clamped conditions the right
    end's, the span of the extended Craig-Bampton's static constraint modes; under mean axes both
    ends' inertia-relief modes), deflated by SVD (ϑ = 1e-6). ``craig_bampton``: the
    extended Craig-Bampton basis instead (``reduce(basis="craig-bampton")``, clamped): the right end's
    position (its in-plane components) kept as boundary coordinates with their static constraint
    modes, and ``n_vms`` fixed-interface modes (both ends held) and their MDs; every beam gets
    the same kind of basis (the last beam's right end is free, and its boundary coordinates are
    two more coordinates), so the three are evaluated in one ``vmap``. ``body_pairs``: one sequence of
    MD pairs a beam (``mmi_per_body``'s selection). Returns the system and the offline record:
    ``frequencies_hz`` (of the vibration modes; None with ``craig_bampton``), ``pairs``, ``k``
    (coordinates a body after deflation; with ``body_pairs`` a list), ``phi`` (the VMs),
    ``conditions``, ``offline_s``.

    ``in_plane`` (default): the beam's in-plane modes and MDs (``reduce``'s ``plane_normal``: its
    coordinates that are odd under the mirror z → −z held at zero, ``elements.beam.mirror_even``,
    which gives exactly the in-plane ones; ``reduction.excited_modes`` finds the same modes by
    their loads, to the eigensolver's round-off). ``in_plane=False``: the lowest ``n_vms``
    overall. A round tube's bending modes come in equal-frequency pairs, and eigh returns any mix
    of the two planes; the lowest five are two pairs and half of the third, a y–z mix without its
    partner. The motion couples into it out of the plane, the basis holds only two or three
    in-plane modes, and the reduced pendulum leaves its plane, where the full one stays in it to
    round-off."""
    import time

    from ..multibody.reduce import reduce

    if not isinstance(basis, PendulumBasis):
        raise ValueError(f"basis must be a PendulumBasis, got {type(basis).__name__}")
    n_vms, pairs, body_pairs, conditions = basis.n_vms, basis.md_pairs, basis.body_pairs, basis.conditions
    joint_modes, craig_bampton = basis.joint_modes, basis.craig_bampton
    if body_pairs is not None:
        body_pairs = [list(b) for b in body_pairs]
        if len(body_pairs) != spec.beams or craig_bampton or joint_modes:
            raise ValueError(f"body_pairs takes one list of MD pairs for each of the {spec.beams} beams, with the "
                             "vibration modes alone (neither craig_bampton nor joint_modes)")
    t0 = time.perf_counter()
    beam = _beam(spec)

    def reduced(mds):  # the beam at the origin, its joints at its ends (the first interface the left end)
        return reduce(beam, [(0.0, 0.0, 0.0), (spec.length, 0.0, 0.0)], vms=n_vms, mds=mds,
                      basis="craig-bampton" if craig_bampton else "free", interface_modes=joint_modes,
                      plane_normal=(0.0, 0.0, 1.0) if basis.in_plane else None, conditions=conditions)

    # equal beams share one reduction, moved along the chain (one offline computation, one vmap);
    # each by its own frame's origin (the left end, or the centre of mass for mean axes)
    templates = [reduced(pairs)] * spec.beams if body_pairs is None else [reduced(bp) for bp in body_pairs]
    bodies = [b.moved(np.asarray(b.R0) + (k * spec.length, 0.0, 0.0)) for k, b in enumerate(templates)]
    system = FloatingFrameSystem(bodies, _joints(spec), gravity=(0.0, -spec.gravity, 0.0))
    phi = None if craig_bampton else np.asarray(bodies[0].modes)
    info = {"frequencies_hz": None if craig_bampton else _frequencies_hz(bodies[0].body, phi).tolist(),
            "pairs": pairs if body_pairs is None else body_pairs,
            "k": bodies[0].k if body_pairs is None else [b.k for b in bodies], "phi": phi,
            "conditions": conditions, "offline_s": time.perf_counter() - t0}
    return system, info


def _frequencies_hz(body, phi) -> np.ndarray:
    """The natural frequencies [Hz] of ``body``'s vibration modes ``phi`` (eigenvectors of (K, M)
    at its reference): the Rayleigh quotients √(φᵀKφ / φᵀMφ) / 2π, exact for eigenvectors."""
    phi = np.asarray(phi)
    K = np.asarray(body.stiffness_matrix(body.q_hat))
    M = np.kron(np.asarray(body.mass_matrix()), np.eye(3))
    return np.sqrt(np.einsum("ik,ij,jk->k", phi, K, phi) / np.einsum("ik,ij,jk->k", phi, M, phi)) / (2 * np.pi)


MMI_RTOL = 1e-3
"""The modal-interaction run's default rtol (``mmi_per_body``, ``candidate_order``; atol a tenth
of it): loose, W ranks the pairs and need not be accurate."""


def mmi_per_body(spec: PendulumSpec = PendulumSpec(), n_vms: int = 5, n_mds: int = 8, t_end: float = 2.0,
                 n_samples: int = 401, *, solver: GeneralizedAlphaIndex3 | None = None,
                 controller: AdaptiveStepSize | None = None, newton: Newton | None = None) -> list:
    """Maximum modal interaction per beam (Eq. 39, the paper's Fig. 16): the reduced pendulum
    with its ``n_vms`` VMs alone run over 0-``t_end`` (its own nonlinear motion, frames and
    joints included) with ``n_samples`` outputs, and each beam's ``n_mds`` pairs (i ≤ j) of
    largest W_b,ij (``multibody.modal_interaction``): one ``reduction.Selection`` a beam, for
    ``build_reduced_pendulum(spec, PendulumBasis(n_vms, body_pairs=[s.pairs for s in
    selections]))``. ``solver``: an ``integrate.GeneralizedAlphaIndex3`` (default ρ∞ = 0.9);
    ``controller``: an ``integrate.AdaptiveStepSize`` (default the plain controller at a loose
    ``MMI_RTOL``, atol a tenth of it: W ranks the pairs, it need not be accurate); ``newton``:
    an ``integrate.Newton`` (default ``simulate``'s)."""
    from ..multibody.modal_interaction import modal_interaction

    positive_int("n_mds", n_mds)
    solver, controller = run_integrator(solver, controller, MMI_RTOL, MMI_RTOL / 10,
                                        solver_type=GeneralizedAlphaIndex3)
    system, _ = build_reduced_pendulum(spec, PendulumBasis(n_vms, pairs=()))
    ts = np.linspace(0.0, t_end, n_samples)
    sol = simulate(system, solver, controller, ts, observe=lambda t, z, v: z, newton=newton)
    return modal_interaction(system, ts, np.asarray(sol.ys), n_mds)


JOINT_MODES = "joint modes"
"""The candidate of ``candidate_order`` that stands for each beam's right-end joint's static modes
(``PendulumBasis(joint_modes=True)``)."""


def candidate_order(spec: PendulumSpec = PendulumSpec(), n_vms: int = 5, t_end: float = 2.0,
                    joint_modes: bool = True, n_samples: int = 401, *, solver: GeneralizedAlphaIndex3 | None = None,
                    controller: AdaptiveStepSize | None = None, newton: Newton | None = None) -> list:
    """The pendulum's candidates for a basis chosen to a tolerance (``pendulum_to_tolerance``),
    in greedy order: the ``n_vms`` in-plane cantilever modes (ints) and the MDs of their pairs
    (``(i, j)``) ranked by maximum modal interaction (``reduction.greedy_order`` on W summed over
    the beams, from the VMs-only pendulum's run over 0-``t_end`` with ``n_samples`` outputs,
    ``mmi_per_body``, which takes ``solver``, ``controller`` and ``newton``; ties broken by
    index), with ``JOINT_MODES`` second, right after the first VM: a joint's static modes carry
    its load as Craig-Bampton's constraint modes do (two columns a beam, in-plane), which the free
    cantilever's modes and MDs approach only slowly."""
    from ..reduction.basis_to_tolerance import greedy_order

    selections = mmi_per_body(spec, n_vms, n_mds=1, t_end=t_end, n_samples=n_samples, solver=solver,
                              controller=controller, newton=newton)
    order = greedy_order(sum(np.asarray(s.W) for s in selections), range(n_vms))
    return order[:1] + [JOINT_MODES] + order[1:] if joint_modes else order


def build_from_candidates(spec: PendulumSpec, prefix) -> FloatingFrameSystem:
    """The NR-RNCF pendulum whose beams hold the candidates ``prefix`` of ``candidate_order``:
    the lowest vibration modes up to the highest one named (``reduce`` takes the lowest k), the
    MDs named, and the joint's static modes if named."""
    prefix = list(prefix)
    vms = [c for c in prefix if isinstance(c, int)]
    if not vms:
        raise ValueError("a pendulum basis needs at least one vibration mode among its candidates")
    pairs = [tuple(c) for c in prefix if isinstance(c, tuple)]
    system, _ = build_reduced_pendulum(spec, PendulumBasis(max(vms) + 1, pairs, joint_modes=JOINT_MODES in prefix))
    return system


def pendulum_to_tolerance(spec: PendulumSpec = PendulumSpec(), tol: float = 0.5, n_vms: int = 5,
                          t_train: float = 0.5, dt_out: float = 0.01, t_end: float = 2.0, safety: float = 2.0,
                          joint_modes: bool = True, method: str = "dynamic", *,
                          solver: GeneralizedAlphaIndex3 | None = None, controller: AdaptiveStepSize | None = None,
                          newton: Newton | None = None):
    """The NR-RNCF pendulum with the smallest basis (a prefix of ``candidate_order``, W from a run
    over 0-``t_end`` at ``candidate_order``'s defaults) whose training run, released from rest
    over 0-``t_train`` with outputs every ``dt_out``, has an error estimate of at most
    ``tol / safety`` per cent χ_rel (``multibody.basis_to_tolerance.mechanism_to_tolerance``: the
    linearised error equation by default, which holds on this soft chain only until its beams
    buckle in compression, so the training window is shorter than the run; ``safety`` covers the
    error's growth after it). ``solver``, ``controller``, ``newton``: the integrator of the run
    the basis is for, as ``run_chain`` takes them (the same defaults); the training runs go at the
    controller's tolerances tightened (``mechanism_to_tolerance``). Returns the
    ``MechanismSearch``."""
    from ..multibody.basis_to_tolerance import TRAINING_TIGHTEN, mechanism_to_tolerance
    from ..reduction.basis_to_tolerance import ToTolerance

    positive_int("n_vms", n_vms)
    ts = _validate.output_times(t_train, dt_out)
    solver, controller = run_integrator(solver, controller, 1e-4, 1e-5, solver_type=GeneralizedAlphaIndex3)
    newton = _chain_newton(newton)
    order = candidate_order(spec, n_vms, t_end, joint_modes=joint_modes)
    target = ToTolerance(tol=tol, safety=safety, start=1, tighten=TRAINING_TIGHTEN)
    return mechanism_to_tolerance(lambda prefix: build_from_candidates(spec, prefix), order, ts, target,
                                  solver=solver, controller=controller, newton=newton, method=method)


def tip_vectors(spec: PendulumSpec) -> list[tuple[int, int]]:
    """``(body, position vector)`` of each beam's right end."""
    return [(k, _PER_NODE * spec.elements + _R) for k in range(spec.beams)]


SHAPE_TIMES = (0.0, 0.5, 1.0, 1.5, 2.0)
"""The instants of the paper's Fig. 17."""


@dataclasses.dataclass(kw_only=True)
class PendulumRun(RunRecord):
    """A run (``RunRecord``): every node's global position (``nodes`` (nt, beams, nodes, 3)) and
    each beam's left-end slope r_x (``left_slopes`` (nt, beams, 3)) at the output times, the total
    and kinetic energy, the largest joint violation |C(q)| at each output time (``violation``), and
    the run's statistics. ``compare`` gives χ_rel of every node's displacement from its initial
    position over all output times."""

    nodes: np.ndarray
    left_slopes: np.ndarray
    energy: np.ndarray
    kinetic: np.ndarray
    violation: np.ndarray
    offline: dict | None = None  # NR-RNCF: build_reduced_pendulum's record
    search: object = None  # NR-RNCF to a tolerance: the basis search (multibody.basis_to_tolerance.MechanismSearch)
    error_on: str = "nodes"  # what the step error was measured on (``run_chain``)

    REFERENCE: ClassVar[str] = "a run of the same pendulum and output times"

    def displacement_series(self) -> np.ndarray:
        """Every node's displacement from its initial position (nt, beams, nodes, 3)."""
        return self.nodes - self.nodes[0]

    @property
    def constraint_max(self) -> float:
        """The largest joint violation over the output times."""
        return float(self.violation.max())

    @property
    def tips(self) -> np.ndarray:
        """Each beam's right-end position (nt, beams, 3), global."""
        return self.nodes[:, :, -1]

    @property
    def tip_displacements(self) -> np.ndarray:
        """Each right end's displacement from its initial position (nt, beams, 3)."""
        return self.tips - self.tips[0]

    @property
    def transverse_deflections(self) -> np.ndarray:
        """Each beam's right end, transverse to the beam in the frame of its left end (nt, beams):
        (r_tip − r_left) · (e_z × r_x/|r_x|), r_x the left end's slope (the paper's Fig. 18b). A rigid
        beam gives zero; positive is a deflection to the beam's left (counter-clockwise about Z)."""
        t = self.left_slopes / np.linalg.norm(self.left_slopes, axis=-1, keepdims=True)
        normal = np.stack([-t[..., 1], t[..., 0], np.zeros_like(t[..., 0])], axis=-1)
        return np.einsum("tbi,tbi->tb", self.tips - self.nodes[:, :, 0], normal)

    def table(self) -> np.ndarray:
        """Columns ``t, x1, y1, x2, y2, x3, y3, ...``: time and each beam's right-end global x and y."""
        return np.column_stack([self.ts, self.tips[:, :, :2].reshape(len(self.ts), -1)])

    def table_header(self) -> str:
        return ",".join(["t"] + [f"{c}{k + 1}" for k in range(self.tips.shape[1]) for c in "xy"])

    def summary(self) -> dict:
        return {"formulation": self.formulation, "dofs": self.dofs, **self.statistics(),
                **({} if self.error_on == "nodes" else {"error_on": self.error_on}),
                "constraint_max": self.constraint_max,
                "energy_drift": float(np.abs(self.energy - self.energy[0]).max()),
                "kinetic_max": float(self.kinetic.max()),
                "tips_final_m": self.tips[-1, :, :2].round(6).tolist(),
                **({} if self.offline is None else {"offline_s": round(self.offline["offline_s"], 3)}),
                **({"conditions": self.offline["conditions"]} if self.offline and "conditions" in self.offline
                   else {}),
                **self.comparison(), **self.estimate_summary(), **self.step_tolerance_fields(),
                **({} if self.search is None else self.search.summary())}


FORMULATIONS = ("ancf", "rncf", "nr-rncf")


def run_pendulum(spec: PendulumSpec = PendulumSpec(), t_end: float = 2.0, dt_out: float = 0.001, *,
                 formulation: str = "ancf", basis: PendulumBasis | None = None,
                 solver: GeneralizedAlphaIndex3 | None = None, controller: AdaptiveStepSize | None = None,
                 newton: Newton | None = None, estimator: ErrorEstimator | None = None, error_on: str = "nodes",
                 progress: bool = False, max_steps: int = 500_000) -> PendulumRun:
    """The pendulum released from rest: full order (``"ancf"``: ANCF bodies, ``build_pendulum``;
    ``"rncf"``: floating frames, ``build_rncf_pendulum``) or NR-RNCF (``"nr-rncf"``:
    ``build_reduced_pendulum(spec, basis)``, ``basis`` a ``PendulumBasis``, default the paper's;
    only with ``"nr-rncf"``), index-3 generalized-α. ``solver``, ``controller``, ``newton``,
    ``estimator`` (NR-RNCF: the run's error estimate from the run alone; None, the default: none),
    ``error_on``: ``run_chain``'s."""
    if formulation not in FORMULATIONS:
        raise ValueError(f"formulation must be one of {FORMULATIONS}, got {formulation!r}")
    if basis is not None and formulation != "nr-rncf":
        raise ValueError("basis goes with formulation='nr-rncf' (a full model keeps every coordinate)")
    basis = PendulumBasis() if basis is None else basis
    if not isinstance(basis, PendulumBasis):
        raise ValueError(f"basis must be a PendulumBasis, got {type(basis).__name__}")
    _check_estimator(estimator)
    if estimator is not None and estimator.method == "static" and basis.conditions == "mean-axis":
        raise ValueError("the static error estimate holds each beam's frame, which under mean axes no joint holds "
                         "(multibody.error_estimate): with conditions='mean-axis' use "
                         "estimator=ErrorEstimator(method='dynamic') or estimator=None")
    if estimator is not None and formulation != "nr-rncf":
        raise ValueError("estimator goes with formulation='nr-rncf' (a full model has no reduction error to "
                         "estimate)")
    info = None
    if formulation == "ancf":
        system = build_pendulum(spec)
    elif formulation == "rncf":
        system = build_rncf_pendulum(spec)
    else:
        system, info = build_reduced_pendulum(spec, basis)
    run = run_chain(system, t_end, dt_out, solver=solver, controller=controller, newton=newton, estimator=estimator,
                    error_on=error_on, progress=progress, max_steps=max_steps)
    run.offline = info
    return run


def _check_estimator(estimator) -> None:
    """A chain's ``estimator``: a ``reduction.ErrorEstimator`` or None (``run_chain``)."""
    if estimator is not None and not isinstance(estimator, ErrorEstimator):
        raise ValueError(f"estimator must be a reduction.ErrorEstimator or None, got {type(estimator).__name__}")


ERROR_ON = ("nodes", "tips")
"""What a chain's step error is measured on (``run_chain``'s ``error_on``)."""


def tip_sensors(system) -> dict:
    """``{"tip1": Position, ...}``: each beam's right end (its last node) in space, the chain's
    outputs as sensors (``multibody.sensors.Position`` on a marker at that node)."""
    from ..multibody.sensors import Position

    _, _, nodes = _chain(system)
    out = {}
    for k, body in enumerate(system.bodies):
        point = body.geometry().vectors[nodes[-1]]
        out[f"tip{k + 1}"] = Position(Marker(k, tuple(float(x) for x in point)))
    return out


def _chain(system: AbstractConstrainedModel) -> tuple[str, object, np.ndarray]:
    """``(formulation, vectors, nodes)`` of a chain of C1 beams: the system's ``formulation``
    (``"ancf"``, ``"rncf"`` or ``"nr-rncf"``), ``vectors(x)`` its bodies' inertial nodal vectors,
    and ``nodes`` the index of each node's position vector in a body."""
    if not isinstance(system, AbstractConstrainedModel):
        raise ValueError(f"system must be a jointed system (MultibodySystem, FloatingFrameSystem), got "
                         f"{type(system).__name__}")
    n_vectors = system.vector_counts()[0]
    return system.formulation, system.nodal_vectors, _PER_NODE * np.arange(n_vectors // _PER_NODE) + _R


NEWTON_TOL = 1e-2
"""``run_chain``'s default Newton tolerance (``Newton(NEWTON_TOL)``), a fraction of the step's error
tolerance: 1 % here, against ``simulate``'s 0.1 %. The reduced pendulum's modified Newton
converges linearly (its iteration matrix leaves out the inertia terms' derivatives), so a tighter
stop costs iterations without changing χ_rel. The full model's Newton stops after its second
correction either way."""


def _chain_newton(newton: Newton | None) -> Newton:
    """A chain run's ``newton``: ``Newton(NEWTON_TOL)`` where None (built at the call), else checked."""
    newton = Newton(NEWTON_TOL) if newton is None else newton
    if not isinstance(newton, Newton):
        raise ValueError(f"newton must be an integrate.Newton, got {type(newton).__name__}")
    return newton


def run_chain(system: MultibodySystem | FloatingFrameSystem, t_end: float = 2.0, dt_out: float = 0.001, *,
              solver: GeneralizedAlphaIndex3 | None = None, controller: AdaptiveStepSize | None = None,
              newton: Newton | None = None, estimator: ErrorEstimator | None = None, error_on: str = "nodes",
              progress: bool = False, max_steps: int = 500_000) -> PendulumRun:
    """Any chain of C1 beams joined into a ``MultibodySystem`` (``"ancf"``) or a
    ``FloatingFrameSystem`` (``"rncf"`` with full-order bodies, else ``"nr-rncf"``), from its
    reference state at rest, index-3 generalized-α: the ``PendulumRun`` record (every node's
    position, the left ends' slopes, energies, the joints' violation, the statistics).
    ``run_pendulum`` is this for the paper's pendulum; a notebook builds its own system and runs
    it here.

    ``solver``: an ``integrate.GeneralizedAlphaIndex3`` (default ρ∞ = 0.9); ``controller``: an
    ``integrate.AdaptiveStepSize`` (default the plain controller at rtol 1e-4, atol 1e-5;
    ``integrate.adaptive_step_size(rtol, atol, "pi")`` is Gustafsson's PI controller, whose runs
    are more accurate at the same tolerance and reject fewer steps, so that it can be run at a
    looser one); ``newton``: an ``integrate.Newton`` (default ``Newton(NEWTON_TOL)``, which says
    why 1 %).

    ``estimator`` (a ``reduction.ErrorEstimator``, for a reduced system; None, the default: no
    estimate): the run's a-posteriori error estimate from the run alone, by its ``method`` at its
    ``samples`` output times (``multibody.error_estimate``, against the system's full-order
    counterpart), in ``PendulumRun.estimate``; the run then also records its coordinates and
    velocities at the output times, and ends a step on each of the estimate's times
    (``reduction.run_error.estimate_times``: the estimate evaluates the equations there; every
    output for ``"dynamic"``, a few more steps where the chain's own steps are shorter than the
    output interval). With ``integration``, the run is repeated at the controller's tolerances
    divided by ``reduction.run_error.TIGHTEN`` (``integrate.tightened``), ending its steps on the
    same times, so that it reuses the run's compiled program; the basis part is then estimated on
    the repetition's states, and the run's distance to it is its own time-integration error
    (``multibody.error_estimate.integration_error_percent``: χ_rel over the reduced bodies' position
    vectors, the basis part's norm, so that the two add up to the total's estimate), and each
    beam's right end's (``sensor_integration_percent``, ``tip1``, ...; summary:
    ``integration_error_estimate_percent[_tip<k>]``). The repetition's compile and run times are
    in the estimate's.

    ``error_on``: what the step error is measured on: ``"nodes"``, every nodal vector (of the
    full-order counterpart, for a reduced body), or ``"tips"``, the beams' right ends, the run's
    outputs (``multibody.Mechanism.observed_error``; Newton still converges every coordinate). On
    tips a reduced chain leaves its modal derivatives' stiff axial vibration to the integrator's
    damping (ρ∞ < 1) instead of resolving it."""

    ts = _validate.output_times(t_end, dt_out)
    solver, controller = run_integrator(solver, controller, 1e-4, 1e-5, solver_type=GeneralizedAlphaIndex3)
    newton = _chain_newton(newton)
    _check_estimator(estimator)
    estimate = estimator is not None
    formulation, vectors, nodes = _chain(system)
    if error_on not in ERROR_ON:
        raise ValueError(f"error_on must be one of {ERROR_ON}, got {error_on!r}")
    if error_on == "tips":
        system = system.observed_error(tip_sensors(system))

    def observe(t, x, v):
        xs, kinetic = vectors(x), system.kinetic_energy(x, v)
        out = (jnp.stack([xb[nodes] for xb in xs]), jnp.stack([xb[_RX] for xb in xs]),
               kinetic + system.potential_energy(x), kinetic, jnp.max(jnp.abs(system.constraints(x))))
        return out + ((x, v) if estimate else ())

    step_ts = None
    if estimate:
        from ..multibody.error_estimate import full_counterpart

        full = full_counterpart(system)  # checks that the system has reduced bodies, before the run
        # The estimate evaluates the equations at its states: the run ends steps there (``run_error``),
        # and so does a repetition for the ``integration`` part, with the run's compiled program.
        step_ts = estimate_times(ts, estimator.samples, estimator.method)

    def run_at(controller):
        sol, compile_s, run_s = simulate_timed(system, solver, controller, jnp.asarray(ts), observe=observe,
                                               progress=progress, max_steps=max_steps, newton=newton,
                                               step_ts=step_ts)
        return sol, [np.asarray(y) for y in jax.device_get(sol.ys)], compile_s, run_s

    sol, ys, compile_s, run_s = run_at(controller)
    pos, slopes, energy, kinetic, cmax, *state = ys
    run = PendulumRun(formulation=formulation, dofs=system.n_dof, ts=ts, nodes=pos, left_slopes=slopes,
                      energy=energy, kinetic=kinetic, violation=cmax, steps=int(sol.num_steps),
                      rejected=int(sol.num_rejected), newton_iters=int(sol.num_newton), compile_s=compile_s,
                      run_s=run_s, step_control=step_control_name(controller), error_on=error_on)
    if estimate:
        run.estimate = _estimate(system, full, estimator, ts, pos, state,
                                 lambda: run_at(tightened(controller, TIGHTEN)))
    return run


def chain_to_tolerance(system: FloatingFrameSystem, tol: float, estimator: ErrorEstimator | None = None,
                       **options) -> PendulumRun:
    """``run_chain(system, **options)`` with its step settings chosen to a target χ_rel of ``tol``
    per cent (``run_record.step_tolerances_to``), for a basis chosen to ``tol`` / 2
    (``pendulum_to_tolerance``): the run's own time-integration error, estimated by ``estimator``
    (default the static ``ErrorEstimator()``) with its ``integration`` part, at most ``tol`` / 2,
    the controller's tolerances tightened (or its steps limited to the output interval) until it
    is. Returns the last run, whose ``estimate`` has both parts and ``step_tolerances`` the
    settings it ran with."""
    _validate.positive("tol (target chi_rel in per cent)", tol)
    _check_estimator(estimator)
    estimator = dataclasses.replace(ErrorEstimator() if estimator is None else estimator, integration=True)
    solver, controller = run_integrator(options.pop("solver", None), options.pop("controller", None), 1e-4, 1e-5,
                                        solver_type=GeneralizedAlphaIndex3)
    last = run_chain(system, solver=solver, controller=controller, estimator=estimator, **options)

    def rerun(c):
        nonlocal last
        last = run_chain(system, solver=solver, controller=c, estimator=estimator, **options)

    _, controller = step_tolerances_to(float(tol), controller, lambda c: last.estimate, rerun,
                                       float(np.diff(last.ts).min()))
    last.step_tolerances = chosen_step_settings(controller)
    return last


def _estimate(system, full, estimator, ts, pos, state, repeat):
    """``run_chain``'s error estimate of its run (its docstring): the run's nodes ``pos`` and
    (z, ż) ``state`` at the output times ``ts``; ``repeat()`` the run at tightened tolerances
    (``run_at``'s tuple), for the ``integration`` part
    (``run_record.estimate_mechanism_run``). Each beam tip's parts too
    (``tip_sensors``), so that the summary's ``chi_rel_estimate_percent_tip<k>`` is each tip's
    total."""
    def tips(nodes):  # each beam's right end, as a sensor's history
        return {f"tip{k + 1}": nodes[:, k, -1] for k in range(nodes.shape[1])}

    repetition = None
    if estimator.integration:
        _, (rep_pos, *_, rep_zs, rep_vs), compile_s, run_s = repeat()
        repetition = (tips(rep_pos), (rep_zs, rep_vs), compile_s, run_s)
    return estimate_mechanism_run(full, system, estimator, ts, state, sensors=tip_sensors(system),
                                  outputs=tips(pos), repetition=repetition)


def _released(system, angle):
    """The system released at ``angle`` [rad] about Z from its reference (its ground hinge's
    axis through the origin: the pendulum's release angle; positive lifts the chain above +x)."""
    return system.turned((0.0, 0.0, 1.0), angle)


@dataclasses.dataclass
class ReleaseSweep:
    """A batch of pendulums released from rest at ``angles`` [rad] (``release_sweep``): each
    beam's right-end position ``tips`` (n, nt, beams, 3) at the output times ``ts``, each
    member's steps, rejected steps and Newton iterations, whether it finished (``ok``), and the
    compiled batch's compile and run time."""

    angles: np.ndarray
    ts: np.ndarray
    tips: np.ndarray
    steps: np.ndarray
    rejected: np.ndarray
    newton_iters: np.ndarray
    ok: np.ndarray
    compile_s: float
    run_s: float
    lanes: int


def release_sweep(system: MultibodySystem | FloatingFrameSystem, angles, t_end: float = 2.0, dt_out: float = 0.01, *,
                  solver: GeneralizedAlphaIndex3 | None = None, controller: AdaptiveStepSize | None = None,
                  newton: Newton | None = None, lanes: int | None = None, max_steps: int = 500_000,
                  small_kernels: bool = False) -> ReleaseSweep:
    """The chain ``system`` (any of ``FORMULATIONS``; its reference state straight along +x)
    released from rest at each of ``angles`` [rad] about the ground hinge's Z axis
    (``system.turned``), all in one compiled, batched run (``integrate.simulate_batch``: every
    member keeps its own adaptive steps; ``lanes`` of them advance together, the rest queue;
    default ``integrate.batch_lanes``: all at once on an accelerator, a few on a CPU; the highest
    releases queue first, the costliest as a rule). Index-3 generalized-α as in ``run_chain``
    (``solver``, ``controller``, ``newton``: its, with its defaults); returns a ``ReleaseSweep``
    with the tips. A member that fails (Newton, step size) is flagged in
    ``ok``, not raised.
    ``small_kernels``: compile with ``integrate.SMALL_KERNEL_OPTIONS`` on a CPU (``simulate_batch``'s
    option of that name): it compiles in about two thirds of the time; the batch's run was about 7 %
    slower on one machine and 7 % faster on another (``benchmarks/results/xla_options.md``,
    ``pendulum_batch.md``), and a persistent compilation cache saves the compile but not the run,
    so it is off by default."""
    import time

    ts = _validate.output_times(t_end, dt_out)
    solver, controller = run_integrator(solver, controller, 1e-4, 1e-5, solver_type=GeneralizedAlphaIndex3)
    newton = _chain_newton(newton)
    angles = np.asarray(angles, dtype=float).reshape(-1)
    if angles.size == 0 or not np.all(np.isfinite(angles)):
        raise ValueError(f"angles must be a non-empty sequence of finite release angles [rad], got {angles!r}")
    _, vectors, nodes = _chain(system)
    tip = nodes[-1]
    lanes = batch_lanes(angles.size, None if lanes is None else positive_int("lanes", lanes))
    _validate.boolean("small_kernels", small_kernels)

    def observe(t, x, v):
        return jnp.stack([xb[tip] for xb in vectors(x)])

    def batch(angles):
        return simulate_batch(jax.tree_util.Partial(_released, system), angles, solver, controller, ts, width=lanes,
                              newton=newton, max_steps=max_steps, observe=observe, throw=False)

    # The queue runs the highest releases first, with their results put back in the order of
    # ``angles``: a higher release has more energy to swing with and costs more steps, and with
    # fewer lanes than members a costly member that starts last runs on alone at the end.
    # A heuristic: any order gives the same results.
    order = np.argsort(-np.sin(angles), kind="stable")
    back = np.argsort(order)
    args = jnp.asarray(angles[order])
    t0 = time.perf_counter()
    compiled = jax.jit(batch, compiler_options=kernel_options(small_kernels) or None).lower(args).compile()
    t1 = time.perf_counter()
    sol = jax.block_until_ready(compiled(args))
    t2 = time.perf_counter()

    def in_given_order(x):
        return np.asarray(x)[back]

    return ReleaseSweep(angles=angles, ts=ts, tips=in_given_order(sol.ys), steps=in_given_order(sol.num_steps),
                        rejected=in_given_order(sol.num_rejected), newton_iters=in_given_order(sol.num_newton),
                        ok=in_given_order(sol.succeeded), compile_s=t1 - t0, run_s=t2 - t1, lanes=int(lanes))


__all__ = ["CONDITIONS", "FORMULATIONS", "LEFT_END_FRAME", "LEFT_SECTION_FRAME", "MMI_RTOL", "NEWTON_TOL",
           "REFERENCE_CONDITIONS", "SHAPE_TIMES", "PendulumBasis", "PendulumRun", "PendulumSpec", "ReleaseSweep",
           "build_pendulum", "build_reduced_pendulum", "build_rncf_pendulum", "chain_to_tolerance", "mmi_per_body",
           "release_sweep", "run_chain", "run_pendulum", "tip_vectors"]
