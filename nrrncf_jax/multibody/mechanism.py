"""A mechanism: bodies of any kind (``kinds``: NR-RNCF and RNCF bodies in floating frames, rigid
bodies, ANCF bodies in the inertial frame, point masses) joined by joints and drivers under gravity,
the index-3 DAE of ``models.constrained`` (docs/theory.md, §7 Jointed bodies;
docs/multibody-theory.md, §Index-3 constraints):

    Σ_b J_bᵀ(M_b ẍ_b − Q_b) + ∂U/∂z − Σ_e f_e ∂g_e/∂z + C_zᵀ λ = 0,    C(z, t) = 0,

with z the bodies' coordinates stacked, f_e and g_e the force elements' forces and measures
(``forces``: spring-dampers, actuators), x_b = f_b(z_b) their nodal vectors in the inertial frame
(where the joints act) and C the joints' equations, then each body's own (a floating frame's
|e|² = 1). Each body supplies its map, residual, iteration block and energies; the system
assembles them and the joints. It is the library's one constrained-system implementation:
``FloatingFrameSystem`` is the mechanism whose bodies are all floating frames (the paper's NR-RNCF
pendulum; its equations and the reasons for its choices, Euler parameters, inertia invariants,
the p columns of the iteration matrix, the velocity projection, are ``floating``'s docstring),
``system.MultibodySystem`` the one whose bodies are all ANCF bodies in the inertial frame.

The iteration matrix is block-diagonal, one block a body (dense, or factored by the body's own
structured solver: an ANCF beam chain's block-tridiagonal one); the constrained matrix is
factored body by body with the joints' m × m Schur complement (``factor_augmented``). The joints'
Hessian and the inertia terms' derivatives with respect to the frames' coordinates are left to
Newton's iterations (``preferred_newton = "modified"``).

Consecutive bodies of one structure (a chain of equal beams, a rotor's blades after its hub) are
evaluated in one ``vmap`` a run (``runs``, ``stacks``): on a CPU the time of these small models
is per XLA operation, and XLA's compile time grows with the operations it is handed.
"""

from typing import ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._types import Array, Float, Scalar
from ..bodies.body import Body
from ..bodies.rigid import RigidBody
from ..linalg import AugmentedFactor, DenseLU, factor_block, schur_factor
from ..models.constrained import AbstractConstrainedModel
from ..motion import unit_axis
from .floating import FloatingBody, axis_angle, rotation
from .forces import AbstractForceElement, ForceSpec, resolve_forces
from .inertial import InertialBody
from .joints import AbstractJoint
from .kinds import AbstractBodyKind
from .markers import JointSpec, resolve_joints
from .rigid import rigid_floating_body
from .section_frame import Directions, triad


def as_body_kind(body) -> AbstractBodyKind:
    """A mechanism's body: a body kind as it is; an element ``Body`` (placed in space) as an ANCF
    body in the inertial frame; a ``RigidBody`` in its floating frame."""
    if isinstance(body, AbstractBodyKind):
        return body
    if isinstance(body, Body):
        return InertialBody(body)
    if isinstance(body, RigidBody):
        return rigid_floating_body(body)
    raise ValueError(f"a mechanism's bodies are Body, RigidBody, PointMass or FloatingBody; got {type(body).__name__}")


def _same_structure(a, b) -> bool:
    """Whether two bodies have one kind, structure and array shapes (so that they stack)."""
    (la, ta), (lb, tb) = jax.tree_util.tree_flatten(a), jax.tree_util.tree_flatten(b)
    return ta == tb and len(la) == len(lb) and all(
        isinstance(x, jax.Array) and isinstance(y, jax.Array) and x.shape == y.shape and x.dtype == y.dtype
        for x, y in zip(la, lb))


def _runs(bodies) -> tuple[tuple[int, int], ...]:
    """The maximal runs ``(first, count)`` of consecutive bodies of one structure."""
    runs = [[0, 1]]
    for k in range(1, len(bodies)):
        if _same_structure(bodies[runs[-1][0]], bodies[k]):
            runs[-1][1] += 1
        else:
            runs.append([k, 1])
    return tuple((first, n) for first, n in runs)


def _same_array(x, y) -> bool:
    """Whether two leaves are known to hold the same numbers: one object, or equal concrete arrays
    (a traced leaf, e.g. a stiffness under ``grad``, is never compared)."""
    if x is y:
        return True
    if isinstance(x, jax.core.Tracer) or isinstance(y, jax.core.Tracer):
        return False
    return np.array_equal(np.asarray(x), np.asarray(y))


def _stacks(bodies, runs) -> tuple:
    """Each run's bodies' arrays stacked into one body (leading axis: the body); None for a run of
    one body. A leaf equal in every body of the run (equal beams share their basis and their
    reduced tensors; only their frames differ) is kept once, unstacked, and not mapped
    (``_stack_axes``): the run's contractions then read it once for all its bodies (a matrix
    times several vectors instead of one product a body), where reading three copies of them
    was a large share of a step."""
    stacks = []
    for first, n in runs:
        if n == 1:
            stacks.append(None)
            continue
        flat, treedef = zip(*[jax.tree_util.tree_flatten(b) for b in bodies[first:first + n]])
        stacks.append(jax.tree_util.tree_unflatten(
            treedef[0], [leaves[0] if all(_same_array(leaves[0], y) for y in leaves[1:]) else jnp.stack(leaves)
                         for leaves in zip(*flat)]))
    return tuple(stacks)


def _stack_axes(stack, body):
    """``vmap``'s axes over a run's stack (``_stacks``): 0 for a stacked leaf, None for a shared
    one, told apart by shape (a stacked leaf has the body's shape behind the run's axis)."""
    return jax.tree_util.tree_map(lambda s, b: None if jnp.shape(s) == jnp.shape(b) else 0, stack, body)


def _pick(x, rows: tuple[int, ...]):
    """``x[rows]`` for static, increasing ``rows``: each run of consecutive rows one slice, the
    slices concatenated. A gather (``x[np.asarray(rows)]``) is an operation of its own to XLA,
    where slices fuse with what reads them."""
    if not rows:
        return x[:0]
    runs, start = [], 0
    for k in range(1, len(rows) + 1):
        if k == len(rows) or rows[k] != rows[k - 1] + 1:
            runs.append(x[rows[start]:rows[k - 1] + 1])
            start = k
    return runs[0] if len(runs) == 1 else jnp.concatenate(runs)


def _place(f, rows: tuple[int, ...], n: int):
    """The (n, ...) array with ``f``'s rows at the static, increasing ``rows`` and zeros elsewhere
    (``zeros.at[rows].add(f)``): the rows and the zero blocks between them concatenated. XLA turns
    a scatter into a loop, a kernel of its own, per body and per evaluation of the joints'
    reactions."""
    pieces, prev = [], 0
    for k, v in enumerate(rows):
        if v > prev:
            pieces.append(jnp.zeros((v - prev,) + f.shape[1:], f.dtype))
        pieces.append(f[k:k + 1])
        prev = v + 1
    if prev < n:
        pieces.append(jnp.zeros((n - prev,) + f.shape[1:], f.dtype))
    return pieces[0] if len(pieces) == 1 else jnp.concatenate(pieces)


def _through(dC, Js) -> Float[Array, "m n"]:
    """The joints' C_z from their derivatives on the rows they read (``dC``, (m, rows, 3) a body)
    and those rows of each body's J ((rows, 3, n_b)), ∂C/∂x J, body by body side by side. As
    element-wise products and sums: these are a few hundred products, and XLA fuses them with
    their neighbours, where each ``dot_general`` would be a kernel of its own, compiled on its
    own."""
    return jnp.concatenate([jnp.sum(d[:, :, :, None] * J[None], axis=(1, 2)) for d, J in zip(dC, Js)], axis=1)


class Mechanism(AbstractConstrainedModel):
    """``bodies`` (any of ``as_body_kind``'s), ``joints`` (joints on nodal vectors, or on markers:
    ``hinge``, ``ball``, ``clamp``, ``slider``), ``gravity`` (an acceleration, 3-vector) and
    ``forces`` (force elements, ``forces.SpringDamper``, ``forces.Actuator``, or on markers:
    ``spring``, ``torsion_spring``, ``motor``, ``actuator``). See the module docstring. Runs with
    ``integrate.GeneralizedAlphaIndex3``.

    Raises ``ValueError`` before anything is traced for a joint on a missing body or nodal vector,
    an initial state that violates the joints, and redundant joint equations (a mechanism that
    locks, or a driver incompatible with its joints)."""

    bodies: tuple[AbstractBodyKind, ...]
    joints: tuple[AbstractJoint, ...]
    gravity: Float[Array, " 3"]
    forces: tuple[AbstractForceElement, ...]
    runs: tuple[tuple[int, int], ...] = eqx.field(static=True)  # (first, count): consecutive equal bodies
    stacks: tuple  # each run's bodies stacked (vmapped), None for a run of one
    error_sensors: tuple = ()  # (name, resolved sensor): the step error on these outputs (``observed_error``)

    preferred_newton = "modified"
    require_held: ClassVar[bool] = False  # every body must be held by a joint (``MultibodySystem``)
    project_velocities = True  # GeneralizedAlphaIndex3 projects v onto C_z v = −C_t after each step (floating)

    @property
    def newton_in_error_space(self) -> bool:  # type: ignore[override]
        """Newton measures every nodal vector (``newton_space``) when the step error is on sensors."""
        return not self.error_sensors

    def __init__(self, bodies, joints=(), gravity=(0.0, 0.0, 0.0), forces=()):
        bodies = tuple(bodies)
        if not bodies:
            raise ValueError("a mechanism needs at least one body")
        self.bodies = tuple(as_body_kind(b) for b in bodies)
        joints = tuple(joints)
        if any(isinstance(j, JointSpec) for j in joints):  # markers: on the bodies' reference nodal vectors
            joints = resolve_joints(joints, tuple(b.geometry() for b in self.bodies))
        self.joints = joints
        if not all(isinstance(j, AbstractJoint) for j in self.joints):
            raise ValueError("joints must be multibody joints (Spherical, Revolute, Fixed, Prismatic, drivers) or "
                             "joints on markers (hinge, ball, clamp, slider)")
        self.gravity = jnp.asarray(gravity, dtype=float).reshape(3)
        forces = tuple(forces)
        # markers need the bodies' concrete reference geometry; resolved force elements do not
        geometry = tuple(b.geometry() for b in self.bodies) if any(isinstance(f, ForceSpec) for f in forces) else ()
        self.forces = tuple(f.resolved(self) for f in resolve_forces(forces, geometry))  # actuators' inputs
        for k, element in enumerate(self.forces):
            for b, v in element.measure.references():
                if not (0 <= b < len(self.bodies) and 0 <= v < self.bodies[b].n_vectors):
                    raise ValueError(f"force element {k} ({type(element).__name__}) refers to nodal vector {v} of "
                                     f"body {b}, which does not exist")
        self.runs = _runs(self.bodies)
        self.stacks = _stacks(self.bodies, self.runs)
        self.error_sensors = ()
        self.check_joints(require_held=self.require_held)

    # --- coordinates ------------------------------------------------------------------------------
    def body_sizes(self) -> tuple[int, ...]:
        return tuple(b.n_z for b in self.bodies)

    def vector_counts(self) -> tuple[int, ...]:
        return tuple(b.n_vectors for b in self.bodies)

    @property
    def n_body_equations(self) -> int:
        """The bodies' own constraints (one |e|² = 1 a floating frame)."""
        return sum(b.n_own_equations for b in self.bodies)

    @property
    def formulation(self) -> str:
        """The deformable bodies' kind (``"ancf"``, ``"rncf"``, ``"nr-rncf"``) when they share
        one (floating frames with any reduced body count as ``"nr-rncf"``), ``"rigid"`` without
        deformable bodies, else ``"mixed"``."""
        kinds = {b.kind for b in self.bodies} - {"rigid", "point"}
        if kinds == {"rncf", "nr-rncf"}:
            return "nr-rncf"
        return kinds.pop() if len(kinds) == 1 else ("rigid" if not kinds else "mixed")

    @property
    def small_kernels(self) -> bool:
        """Every body's kind says its part of a step is small (``kinds.AbstractBodyKind``; reduced,
        rigid and point bodies): ``models.base.AbstractModel.small_kernels``."""
        return all(b.small_kernels for b in self.bodies)

    @property
    def masses(self) -> tuple[Float[Array, "nv nv"], ...]:
        """Each body's mass matrix on its nodal vectors (the same for each component)."""
        return tuple(b.mass for b in self.bodies)

    @property
    def stacked(self) -> AbstractBodyKind | None:
        """All the bodies stacked, when they are one run (a chain of equal beams), else None."""
        return self.stacks[0] if len(self.runs) == 1 else None

    def _each_run(self, fn, by_run: bool, *vectors):
        """``(n, out, stacked)`` for each run of n equal bodies: ``fn(body, *parts)`` for a body
        on its own, vmapped over a run's stacked bodies (its outputs with the body as their
        leading axis, ``stacked``). With ``by_run``, ``fn(first)`` gives the function for the
        run that starts at body ``first`` (data that differs from run to run)."""
        for run, stack in zip(self.runs, self.stacks):
            f = fn(run[0]) if by_run else fn
            if stack is None:
                yield 1, f(self.bodies[run[0]], *(self._part(x, run[0]) for x in vectors)), False
            else:
                yield run[1], self._vmap(run, stack, f, *vectors), True

    def _map(self, fn, *vectors, by_run: bool = False) -> list:
        """``[fn(body_b, *(each vector's part b))]``: one vmapped call a run of equal bodies (a
        chain of equal beams: a third of the operations for three bodies, and XLA's time here is
        per operation), a plain call for a body on its own. A vector is split by the bodies'
        coordinates; a tuple holds its parts already (one a body). ``by_run``: see ``_each_run``."""
        out = []
        for n, y, stacked in self._each_run(fn, by_run, *vectors):
            out += [jax.tree_util.tree_map(lambda a, i=i: a[i], y) for i in range(n)] if stacked else [y]
        return out

    def _part(self, x, b):
        """Body b's part of a vector (or of a tuple of parts)."""
        if isinstance(x, tuple):
            return x[b]
        o, n = self.offsets[b], self.body_sizes()[b]
        return x[o:o + n]

    def _vmap(self, run, stack, fn, *vectors):
        """``fn`` over a run's stacked bodies (its shared leaves unmapped, ``_stacks``), its
        outputs with the body as their leading axis.
        Equal bodies have equal coordinate counts, so a vector's parts are a reshape of its run's
        slice (of the whole vector for a chain of equal bodies), not slices and a stack, whose
        copies are a noticeable share of a small model's operations."""
        first, n = run
        o, size = self.offsets[first], self.body_sizes()[first]

        def parts(x):
            if isinstance(x, tuple):
                return jnp.stack(x[first:first + n])
            return (x if x.shape[0] == n * size else x[o:o + n * size]).reshape(n, -1)

        axes = _stack_axes(stack, self.bodies[first])
        return jax.vmap(fn, in_axes=(axes,) + (0,) * len(vectors))(stack, *(parts(x) for x in vectors))

    def _concat_map(self, fn, *vectors) -> Float[Array, " n"]:
        """``jnp.concatenate(self._map(fn, *vectors))`` (each part a vector, or flattened)."""
        pieces = [y.reshape(-1) for _, y, _ in self._each_run(fn, False, *vectors)]
        return pieces[0] if len(pieces) == 1 else jnp.concatenate(pieces)

    def nodal_vectors(self, z: Float[Array, " n"]) -> tuple[Float[Array, "nv 3"], ...]:
        """Every body's nodal vectors in the inertial frame."""
        return tuple(self._map(lambda b, zb: b.nodal_vectors(zb), z))

    def nodal_velocities(self, z: Float[Array, " n"], v: Float[Array, " n"]) -> tuple[Float[Array, "nv 3"], ...]:
        """ẋ_b = J_b ż_b."""
        return tuple(self._map(lambda b, zb, vb: b.tangent(zb, vb), z, v))

    def reference(self) -> Float[Array, " n"]:
        return jnp.concatenate([b.initial() for b in self.bodies])

    def rigid_velocity(self, velocity=(0.0, 0.0, 0.0), omega=(0.0, 0.0, 0.0), z=None, bodies=None
                       ) -> Float[Array, " n"]:
        """ż of the rigid motion ẋ(p) = velocity + omega × p of the bodies ``bodies`` (indices;
        all by default; the others at rest) at z (the reference by default): an initial velocity
        in physical terms, for ``simulate(..., y0=(z, v))``. Velocities that the joints do not
        allow are refused by ``check_velocity``."""
        z = self.reference() if z is None else z
        chosen = set(range(len(self.bodies))) if bodies is None else {int(b) for b in bodies}
        return jnp.concatenate([b.rigid_velocity(zb, velocity, omega) if i in chosen else jnp.zeros_like(zb)
                                for i, (b, zb) in enumerate(zip(self.bodies, self.split(z)))])

    def check_velocity(self, z, v, t: Scalar = 0.0, rtol: float = 1e-8) -> None:
        """``ValueError`` unless C_z v + C_t = 0 to ``rtol`` of |C_z| |v|: an initial velocity
        that the joints and drivers allow."""
        B, v = np.asarray(self.constraint_jacobian(z, t)), np.asarray(v)
        r = np.abs(B @ v + np.asarray(self.constraint_rate(z, t)))
        bound = rtol * max(1.0, float(np.abs(B).max() * np.abs(v).max()))
        if r.max(initial=0.0) > bound:
            raise ValueError(f"the initial velocities violate the joints' velocity equations (largest {r.max():.3g} "
                             f"at constraints {np.flatnonzero(r > bound)[:10].tolist()})")

    def turned(self, axis, angle) -> "Mechanism":
        """The system turned as a whole by ``angle`` [rad] about ``axis`` through the origin: each
        body (its frame, or its nodal vectors) and the joints' fixed data in space
        (``AbstractJoint.turned``); gravity stays. Traceable in ``angle``: a batch of release
        angles is a ``vmap`` over it (``scenarios.pendulum.release_sweep``)."""
        e = axis_angle(unit_axis(axis), angle)
        A = rotation(e)
        out = eqx.tree_at(lambda s: (s.bodies, s.joints, s.forces), self,
                          (tuple(b.turned(e, A) for b in self.bodies), tuple(j.turned(A) for j in self.joints),
                           tuple(f.turned(A) for f in self.forces)))
        stacks = tuple(None if st is None else st.turned(e, A) for st in self.stacks)
        return eqx.tree_at(lambda s: s.stacks, out, stacks, is_leaf=lambda x: x is None)

    def stiffened(self, s, bodies=None) -> "Mechanism":
        """The system with the stiffness of ``bodies`` (indices; all by default) times ``s``
        (``AbstractBodyKind.stiffened``): Young's modulus as a parameter, traceable, for
        ``jax.grad``/``jvp`` through a jointed run."""
        chosen = set(range(len(self.bodies))) if bodies is None else {int(b) for b in bodies}
        out = eqx.tree_at(lambda m: m.bodies, self,
                          tuple(b.stiffened(s) if i in chosen else b for i, b in enumerate(self.bodies)))
        return eqx.tree_at(lambda m: m.stacks, out, _stacks(out.bodies, out.runs), is_leaf=lambda x: x is None)

    def observed_error(self, sensors: dict) -> "Mechanism":
        """This mechanism with its step error measured on the outputs ``sensors`` ({name:
        sensor}, configuration sensors: ``Position``, ``ChordDeflection``, ``SectionAngle``)
        instead of on every nodal vector: the error of a step is J_y e, y the sensors' values,
        weighted by ``atol + rtol |y|`` (lengths in metres, angles in radians). The nodal vectors
        hold the stiff directions a reduced body's modal derivatives add (an axial vibration in the
        kHz, its strain as large as the tolerance on unit slope vectors) and the mechanism's rigid
        motion, whose size scales the tolerance; an error norm on what the user observes lets the
        step follow that, with the fast directions left to the integrator's damping (ρ∞ < 1).
        An empty ``sensors`` restores the nodal vectors."""
        from .sensors import ChordDeflection, Position, SectionAngle  # sensors read the system: imported late

        chosen = []
        for name, sensor in dict(sensors).items():
            if not isinstance(sensor, (Position, ChordDeflection, SectionAngle)):
                raise ValueError(f"the step error is measured on configuration sensors (Position, ChordDeflection, "
                                 f"SectionAngle); sensor {name!r} is a {type(sensor).__name__}")
            chosen.append((str(name), sensor.resolve(self)))
        return eqx.tree_at(lambda m: m.error_sensors, self, tuple(chosen))

    def error_space(self, z, e):
        """The step error on the sensors of ``observed_error`` (J_y e), or else in the inertial
        nodal vectors as ``newton_space`` measures it, so that a tolerance means what it means for
        the full system."""
        if self.error_sensors:
            from .sensors import Observer  # sensors read the system: imported late

            observer = Observer(self, dict(self.error_sensors))  # the sensors share the nodal vectors

            def outputs(zz):
                ys = observer(0.0, zz, None)
                return jnp.concatenate([jnp.ravel(ys[name]) for name, _ in self.error_sensors])

            y, dy = jax.jvp(outputs, (z,), (e,))
            return y, dy, jnp.ones(y.shape[0], bool)
        return self.newton_space(z, e)

    def newton_space(self, z, e):
        """Every inertial nodal vector (J e): Newton's corrections are measured there, whatever
        the step error is measured on (``observed_error``), since every coordinate must converge.
        Each body's vectors are taken component by component (3 × nv, not nv × 3): the loop only
        forms norms of these, which do not depend on the order, and with the nodal vectors
        innermost XLA computes them in rows as long as the body's vectors instead of rows of three."""
        x = self._concat_map(lambda b, zb: b.nodal_vectors(zb).T, z)
        dx = self._concat_map(lambda b, zb, eb: b.tangent(zb, eb).T, z, e)
        return x, dx, jnp.ones(x.shape[0], bool)

    # --- the equations ----------------------------------------------------------------------------
    def _own_equations(self, z) -> list:
        return [b.own_equations(zb) for b, zb in zip(self.bodies, self.split(z))]

    def constraints(self, z: Float[Array, " n"], t: Scalar = 0.0) -> Float[Array, " m"]:
        """The joints' equations on the rows they read (``_joints_on_rows``: the section frames
        in one batch), then the bodies' own."""
        joints = (self._joints_on_rows(self._rows_of(self.nodal_vectors(z)), t) if self.joints
                  else jnp.zeros((0,), z.dtype))
        return jnp.concatenate([joints] + self._own_equations(z))

    def constraint_rate(self, z, t: Scalar) -> Float[Array, " m"]:
        """C_t = ∂C/∂t (zero without drivers), of the joints on the rows they read: the bodies'
        maps do not depend on t, so only the joints' equations are differentiated."""
        if not self.rheonomic:
            return jnp.zeros(self.n_constraints, z.dtype)
        rows = self._rows_of(self.nodal_vectors(z))
        C_t = jax.jvp(lambda s: self._joints_on_rows(rows, s), (jnp.asarray(t, z.dtype),), (jnp.ones((), z.dtype),))[1]
        return jnp.concatenate([C_t, jnp.zeros(self.n_body_equations, z.dtype)])

    def _rows_along(self, z, v) -> tuple:
        """``(x, ẋ, ẍ₀, J)`` on the rows the joints read (``_joint_rows``), each a tuple with one
        array a body: the nodal vectors, their velocities J v, their second derivative J̇ v along
        the path z + s v (the nodal accelerations at z̈ = 0) and those rows of J, the last three
        from one forward-mode derivative of the rows of each body's Jacobian (cheaper than a
        derivative of its ``tangent``, which maps every nodal vector)."""
        read = self._joint_rows()

        def along(first):
            def f(b, zb, vb):
                J, dJ = jax.jvp(lambda y: b.jacobian(y, read[first]), (zb,), (vb,))
                return jnp.sum(J * vb, axis=-1), jnp.sum(dJ * vb, axis=-1), J
            return f

        xd, xdd, Js = zip(*self._map(along, z, v, by_run=True))
        return self._rows_of(self.nodal_vectors(z)), xd, xdd, Js

    def _joints_along(self, rows, t, dC=None) -> Float[Array, " mj"]:
        """d²/ds² of the joints' equations along x(s) = x + s ẋ + ½ s² ẍ₀ at time t + s, at s = 0
        (``rows``: ``_rows_along``'s first three), C_xx(ẋ, ẋ) + 2 C_xt ẋ + C_tt + C_x ẍ₀: the
        second derivative along (ẋ, 1), and C_x ẍ₀ from the rows' Jacobian ``dC`` when the
        caller has it (``_joint_jacobian``), else from one more derivative."""
        x, xd, xdd = rows[:3]
        t = jnp.asarray(t, jnp.result_type(*x))
        one = jnp.ones_like(t)

        def rate(y, s):
            return jax.jvp(self._joints_on_rows, (y, s), (xd, one))[1]

        second = jax.jvp(rate, (x, t), (xd, one))[1]
        if dC is None:
            return second + jax.jvp(lambda y: self._joints_on_rows(y, t), (x,), (xdd,))[1]
        return second + sum(jnp.sum(d * a, axis=(1, 2)) for d, a in zip(dC, xdd))

    def _own_along(self, z, v) -> list:
        """The bodies' own equations' second derivatives along v (2 ė·ė of |e|² = 1)."""
        return [jax.jvp(lambda y, b=b, vb=vb: jax.jvp(b.own_equations, (y,), (vb,))[1], (zb,), (vb,))[1]
                for b, zb, vb in zip(self.bodies, self.split(z), self.split(v)) if b.n_own_equations]

    def constraint_acceleration(self, z, v, t: Scalar = 0.0) -> Float[Array, " m"]:
        """The part of C̈ = C_z a + (C_z v)_z v + 2 C_zt v + C_tt that does not hold a, by the chain
        rule through the nodal vectors the joints read (``_rows_along``: x, ẋ = J v, ẍ₀ = J̇ v):
        the joints' equations' second derivative along the path x + s ẋ + ½ s² ẍ₀ at time t + s,

            d²/ds² C(x(s), t + s) = C_xx(ẋ, ẋ) + 2 C_xt ẋ + C_tt + C_x ẍ₀

        (``_joints_along``), then the bodies' own equations' second derivative along v. The same
        quantity as the second derivative of ``constraints`` along (v, 1)
        (``AbstractConstrainedModel``), whose nested derivatives run through every body's map."""
        joints = [self._joints_along(self._rows_along(z, v), t)] if self.joints else []
        return jnp.concatenate([jnp.zeros((0,), z.dtype)] + joints + self._own_along(z, v))

    def constraint_jacobian_and_acceleration(self, z, v, t: Scalar = 0.0) -> tuple:
        """``(C_z, constraint_acceleration)`` from one evaluation of the rows the joints read and
        of their Jacobians (``_rows_along``), for the consistent accelerations."""
        if not self.joints:
            return self.constraint_jacobian(z, t), self.constraint_acceleration(z, v, t)
        rows = self._rows_along(z, v)
        dC = jax.jacfwd(lambda x_rows: self._joints_on_rows(x_rows, t))(rows[0])
        return (jnp.concatenate([_through(dC, rows[3])] + self._own_rows(z), axis=0),
                jnp.concatenate([self._joints_along(rows, t, dC)] + self._own_along(z, v)))

    def _joint_rows(self) -> tuple[tuple[int, ...], ...]:
        """Each body's nodal vectors that any joint reads; for a run of equal bodies one list for
        the run (the union), so that they are evaluated in one vmap."""
        rows = [tuple(sorted({v for j in self.joints for b, v in j.references() if b == i}))
                for i in range(len(self.bodies))]
        for first, n in self.runs:
            union = tuple(sorted({v for r in rows[first:first + n] for v in r}))
            rows[first:first + n] = [union] * n
        return tuple(rows)

    def _rows_of(self, xs) -> tuple:
        """Each body's nodal vectors that the joints read (``_joint_rows``), (rows, 3) a body: the
        rows by static slices (``_pick``), not a gather."""
        return tuple(_pick(x, r) for x, r in zip(xs, self._joint_rows()))

    def describe(self) -> list[str]:
        """One line a body: its kind and coordinates, and for a reduced body how its basis was
        chosen (``multibody.reduce``)."""
        lines = [f"body {i}: {b.describe()}" for i, b in enumerate(self.bodies)]
        if self.error_sensors:
            lines.append("step error on the sensors " + ", ".join(n for n, _ in self.error_sensors))
        return lines

    def _frame_keys(self) -> tuple[tuple[int, tuple[int, int]], ...]:
        """The nodes whose section frames the joints read (``section_frame.Directions``), as
        ``(body, section vectors)``, each once."""
        keys = []
        for j in self.joints:
            for d in jax.tree_util.tree_leaves(j, is_leaf=lambda x: isinstance(x, Directions)):
                if isinstance(d, Directions) and d.body is not None and (d.body, d.vectors) not in keys:
                    keys.append((d.body, d.vectors))
        return tuple(keys)

    def _joints_on_rows(self, x_rows, t: Scalar = 0.0) -> Float[Array, " mj"]:
        """The joints' equations on those rows alone: the joints read ``xs[body][vector]``, so a
        dict a body of the rows they read stands for the whole nodal arrays. Differentiated with
        respect to the rows, nothing is scattered into the whole arrays: fewer operations in the
        constraint Jacobian, which a step computes twice.
        Every section frame the joints read is computed here, all nodes in one batch
        (``Directions.triad`` reads it from the dict): a frame's scalars (its section vectors'
        lengths and angle) node by node were a few XLA operations each, per frame and per
        derivative, a large share of a reduced pendulum's step's operations."""
        xs = tuple({v: xr[k] for k, v in enumerate(r)} for r, xr in zip(self._joint_rows(), x_rows))
        keys = self._frame_keys()
        if keys:
            T = triad(jnp.stack([xs[b][v[0]] for b, v in keys]), jnp.stack([xs[b][v[1]] for b, v in keys]))
            for k, (b, v) in enumerate(keys):
                xs[b][Directions.frame_key(v)] = T[k]
        return self.joint_equations(xs, t)

    def _joint_jacobian(self, z, t: Scalar = 0.0, rate: bool = False, rows=None) -> tuple:
        """``(dC, C_joints, C_t)``: the joints' equations differentiated with respect to the few
        nodal vectors they read (``dC``, one (m, rows, 3) array a body), times those rows of each
        body's J (``C_joints``, m × n), and, with ``rate`` and drivers, their rate C_t from the
        same forward-mode derivative (one tangent more; else None). ``rows``: the rows' nodal
        vectors (``_rows_of``) when the caller has them."""
        rows = self._rows_of(self.nodal_vectors(z)) if rows is None else rows
        if rate and self.rheonomic:
            dC, C_t = jax.jacfwd(self._joints_on_rows, argnums=(0, 1))(rows, jnp.asarray(t, z.dtype))
        else:
            dC, C_t = jax.jacfwd(lambda x_rows: self._joints_on_rows(x_rows, t))(rows), None  # (m, rows, 3)
        # the rows a run's bodies are read at are the run's (_joint_rows)
        read = self._joint_rows()
        Js = self._map(lambda first: lambda b, zb: b.jacobian(zb, read[first]), z, by_run=True)
        return dC, _through(dC, Js), C_t

    def _own_rows(self, z) -> list:
        """The bodies' own constraints' rows of C_z (2 e_bᵀ of |e_b|² = 1), each as wide as z."""
        own = []
        for b, zb, o in zip(self.bodies, self.split(z), self.offsets):
            if b.n_own_equations:
                Jb = b.own_jacobian(zb)
                own.append(jnp.zeros((Jb.shape[0], self.n_dof), z.dtype).at[:, o:o + b.n_z].set(Jb))
        return own

    def constraint_jacobian(self, z, t: Scalar = 0.0):
        """C_z = ∂C/∂x J: the joints differentiated with respect to the few nodal vectors they
        read, times those rows of each body's J (``_joint_jacobian``); then the bodies' own rows
        (2 e_bᵀ of |e_b|² = 1)."""
        C_joints = self._joint_jacobian(z, t)[1] if self.joints else jnp.zeros((0, self.n_dof), z.dtype)
        return jnp.concatenate([C_joints] + self._own_rows(z), axis=0)

    def constraint_jacobian_and_rate(self, z, t: Scalar) -> tuple:
        """``(C_z, C_t)`` from one forward-mode derivative of the joints with respect to their
        rows and the time (``_joint_jacobian``): the velocity projection reads both."""
        if not (self.joints and self.rheonomic):
            return self.constraint_jacobian(z, t), self.constraint_rate(z, t)
        _, C_joints, C_t = self._joint_jacobian(z, t, rate=True)
        return (jnp.concatenate([C_joints] + self._own_rows(z), axis=0),
                jnp.concatenate([C_t, jnp.zeros(self.n_body_equations, z.dtype)]))

    def residual(self, t: Scalar, z, v, a) -> Float[Array, " n"]:
        """Σ_b J_bᵀ(M_b ẍ_b − Q_b) + ∂U/∂z, without the joints' forces (the stepper adds C_zᵀ λ).
        Through the nodal vectors, not the inertia invariants: written with the invariants it
        takes a dozen 3 × 3 × k × k contractions, more operations, and XLA's time here is per
        operation."""
        return self._bodies_residual(t, z, v, a)

    def _bodies_residual(self, t, z, v, a, reactions=None) -> Float[Array, " n"]:
        """``residual``, with the nodal forces ``reactions`` (one array a body) added inside each
        body's J ᵀ (``AbstractBodyKind.loaded_residual``) when given."""
        if reactions is None:
            r = self._concat_map(lambda b, zb, vb, ab: b.residual(zb, vb, ab, self.gravity), z, v, a)
        else:
            r = self._concat_map(lambda b, zb, vb, ab, fb: b.loaded_residual(zb, vb, ab, self.gravity, fb),
                                 z, v, a, reactions)
        return r if not self.forces else r - self.applied_force(t, z, v)

    def dae_residual(self, t: Scalar, z, v, a, lam) -> tuple[Float[Array, " n"], Float[Array, " m"]]:
        """``(r + C_zᵀ λ, C)`` from one evaluation of the nodal vectors: the joints' equations and
        their forces on the nodal vectors (``_joint_reactions``), each body's share added to its
        own nodal forces before its J ᵀ, and the bodies' own equations with their forces. Equal to
        ``residual + constraint_force`` and ``constraints`` to round-off, in fewer operations than
        the pullback of C through every body's map."""
        C_joints, reactions = self._joint_reactions(self.nodal_vectors(z), lam, t)
        r = self._bodies_residual(t, z, v, a, reactions)
        if not self.n_body_equations:
            return r, C_joints
        C_own, own_pullback = jax.vjp(lambda y: jnp.concatenate(self._own_equations(y)), z)
        return r + own_pullback(lam[self.n_joint_equations:])[0], jnp.concatenate([C_joints, C_own])

    # --- force elements ---------------------------------------------------------------------------
    def measures(self, z) -> Float[Array, " e"]:
        """The force elements' measures g_e(z) (distances, angles, travels)."""
        xs = self.nodal_vectors(z)
        return jnp.stack([f.measure(xs) for f in self.forces])

    def element_state(self, t, z, v) -> tuple[Float[Array, " e"], Float[Array, " e"], Float[Array, " e"]]:
        """``(g, ġ, f)``: the force elements' measures, their rates ∂g/∂z ż and forces."""
        g, g_dot = jax.jvp(self.measures, (z,), (v,))
        return g, g_dot, self._element_forces(t, z, v, g, g_dot)

    def _element_forces(self, t, z, v, g, g_dot) -> Float[Array, " e"]:
        return jnp.stack([e.force(t, gi, gd, e.signals(self, t, z, v))
                          for e, gi, gd in zip(self.forces, g, g_dot)])

    def applied_force(self, t, z, v) -> Float[Array, " n"]:
        """Σ_e f_e ∂g_e/∂z: the force elements' generalized forces (virtual work f δg)."""
        g, linear = jax.linearize(self.measures, z)
        f = self._element_forces(t, z, v, g, linear(v))
        return jax.linear_transpose(linear, z)(f)[0]

    def _force_blocks(self, t, z, v, c_K, c_C) -> list:
        """The force elements' stiffness and damping on each body's diagonal block,
        G_bᵀ diag(c_K k + c_C c) G_b with G = ∂g/∂z, k = −∂f/∂g, c = −∂f/∂ġ (``forces``)."""
        g, G = self.measures(z), jax.jacfwd(self.measures)(z)
        g_dot = G @ v
        dfdg = jnp.stack([jnp.stack(jax.grad(e.force, argnums=(1, 2))(t, gi, gd, e.signals(self, t, z, v)))
                          for e, gi, gd in zip(self.forces, g, g_dot)])
        D = -(c_K * dfdg[:, 0] + c_C * dfdg[:, 1])
        return [G[:, o:o + n].T @ (D[:, None] * G[:, o:o + n]) for o, n in zip(self.offsets, self.body_sizes())]

    def mass_matrix(self, z) -> Float[Array, "n n"]:
        """M_z = blockdiag(J_bᵀ M_b J_b)."""
        return jax.scipy.linalg.block_diag(*self._map(lambda b, zb: b.mass_matrix(zb), z))

    def iteration_matrix(self, t, z, v, c_M, c_C, c_K):
        """``c_M M_z + c_K ∂F/∂z``: the mass matrix and the elastic stiffness, block by block.
        The derivatives of the inertia terms through J (centrifugal, gyroscopic, the load's
        change of direction) are left out here: they are of order c_K ω² M and c_C ω M against
        M, and a modified Newton on this matrix converges linearly, at that rate, to the same
        solution. ``factor_augmented`` with the state's acceleration adds their p columns."""
        blocks = self._blocks(z, c_M, c_K)
        if self.forces:
            blocks = [S + F for S, F in zip(blocks, self._force_blocks(t, z, v, c_K, c_C))]
        return jax.scipy.linalg.block_diag(*blocks)

    def _blocks(self, z, c_M, c_K, v=None, a=None, lam=None, c_C=0.0, reactions=None) -> list:
        """The ``iteration_matrix``'s diagonal blocks, one a body; with the state's velocity
        ``v``, acceleration ``a`` and multipliers ``lam``, the terms each body keeps of them
        (``AbstractBodyKind.block``). ``reactions``: the joints' nodal forces C_xᵀλ when the
        caller has them (else from ``lam``, ``_nodal_reactions``)."""
        if a is None:
            return self._map(lambda b, zb: b.block(zb, c_M, c_K, self.gravity), z)
        reactions = self._nodal_reactions(z, lam) if reactions is None else reactions
        return self._map(lambda b, zb, vb, ab, reaction: b.block(zb, c_M, c_K, self.gravity, (vb, ab, reaction), c_C),
                         z, v, a, tuple(reactions))

    def tangent_blocks(self, t, z, v, a, lam) -> list:
        """∂r/∂z body by body at a state (z, ż, z̈, λ) of the DAE: each body's elastic stiffness with
        the inertia terms' p columns (``_blocks`` with c_M = 0, c_K = 1) and the force elements'
        stiffness; the joints' Hessian left out, as in ``factor_augmented``."""
        blocks = self._blocks(z, 0.0, 1.0, v, a, lam)
        if self.forces:
            blocks = [S + F for S, F in zip(blocks, self._force_blocks(t, z, v, 1.0, 0.0))]
        return blocks

    def _joint_reactions(self, xs, lam, t: Scalar = 0.0) -> tuple:
        """``(C_joints, forces)``: the joints' equations at the nodal vectors ``xs`` and their
        forces on each body's nodal vectors, C_xᵀλ (zero without joints), by one pullback on the
        rows the joints read (``_joints_on_rows``), added into each body's nodal array."""
        if not self.joints:
            return jnp.zeros((0,), lam.dtype), tuple(jnp.zeros_like(x) for x in xs)
        C, pullback = jax.vjp(lambda y: self._joints_on_rows(y, t), self._rows_of(xs))
        f_rows = pullback(lam[:self.n_joint_equations])[0]
        return C, tuple(_place(f, r, x.shape[0]) for x, r, f in zip(xs, self._joint_rows(), f_rows))

    def _nodal_reactions(self, z, lam, t: Scalar = 0.0) -> tuple:
        """The joints' forces on each body's nodal vectors, C_xᵀλ (zero without joints)."""
        return self._joint_reactions(self.nodal_vectors(z), lam, t)[1]

    def factor_iteration_matrix(self, t, z, v, c_M, c_C, c_K):
        return DenseLU.factor(self.iteration_matrix(t, z, v, c_M, c_C, c_K))

    def factor_augmented(self, t, z, v, lam, c_C, c_K, a=None) -> AugmentedFactor:
        """``[[S, C_zᵀ], [C_z, 0]]`` factored body by body: each body's block of S (``block``,
        with ``a``, the step's acceleration, the state's terms), on its own, and the joints by
        the m × m Schur complement C_z S⁻¹ C_zᵀ (a body with a structured solver, an ANCF beam
        chain, factors its block itself: ``AbstractBodyKind.factor``).
        The joints' Hessian c_K H_λ is left out: of the order of the reactions times c_K. Small
        LU factorisations of the bodies' blocks instead of one of the whole matrix: a small
        fraction of its arithmetic, and on a CPU one LU of the whole matrix can cost more than the
        rest of the step. A small block's inverse is formed from its LU (``linalg.factor_block``),
        so that each Newton iteration's solve is a product, one for a chain of equal bodies."""
        xs, reactions = self.nodal_vectors(z), None
        if self.joints:
            dC, C_joints, _ = self._joint_jacobian(z, t, rows=self._rows_of(xs))
            if a is not None:  # the reactions C_xᵀλ from the Jacobian on the rows, not from a pullback
                lam_j = lam[:self.n_joint_equations]
                reactions = tuple(_place(jnp.sum(lam_j[:, None, None] * d, axis=0), r, x.shape[0])
                                  for x, r, d in zip(xs, self._joint_rows(), dC))
        else:
            C_joints = jnp.zeros((0, self.n_dof), z.dtype)
        B = jnp.concatenate([C_joints] + self._own_rows(z), axis=0)
        blocks = self._blocks(z, 1.0, c_K, v, a, lam, c_C, reactions)
        if self.forces:
            blocks = [S + F for S, F in zip(blocks, self._force_blocks(t, z, v, c_K, c_C))]
        # a body that knows its block's structure (an ANCF beam chain) factors it itself; the dense
        # blocks it leaves unused are dropped by XLA. Force elements add to the dense blocks only.
        factors = tuple(b.factor(zb, 1.0, c_K, self.gravity) if b.structured and not self.forces else factor_block(S_b)
                        for b, zb, S_b in zip(self.bodies, self.split(z), blocks))
        return schur_factor(factors, self.offsets, self.body_sizes(), B)

    def kinetic_energy(self, z, v) -> Float[Array, ""]:
        """½ Σ_b ẋ_bᵀ M_b ẋ_b, ẋ_b = J_b ż_b."""
        return sum(self._map(lambda b, zb, vb: b.kinetic_energy(zb, vb), z, v))

    def potential_energy(self, z) -> Float[Array, ""]:
        """Strain energy (the reduced cubic force's potential, or the elements' own), the
        gravity potential −Σ ϱ_α x_α·g and the springs' potentials."""
        U = sum(b.potential_energy(zb, self.gravity) for b, zb in zip(self.bodies, self.split(z)))
        if self.forces:
            U = U + sum(e.potential(g) for e, g in zip(self.forces, self.measures(z)))
        return U


class FloatingFrameSystem(Mechanism):
    """A mechanism of floating-frame bodies only (``FloatingBody``: NR-RNCF or full-order RNCF;
    ``floating``'s docstring gives the equations): the paper's jointed NR-RNCF systems."""

    def __init__(self, bodies, joints, gravity=(0.0, 0.0, 0.0), forces=()):
        bodies = tuple(bodies)
        if not bodies or not all(isinstance(b, FloatingBody) for b in bodies):
            raise ValueError("bodies must be a non-empty sequence of FloatingBody")
        super().__init__(bodies, joints, gravity, forces)


__all__ = ["FloatingFrameSystem", "Mechanism", "as_body_kind"]
