"""Force elements: spring-dampers and actuators between points and at joints
(docs/multibody-theory.md, §Joints: the spring-damper).

A force element is a scalar measure g(x) of the bodies' nodal vectors, a distance between two
points, a hinge's angle or a slider's travel, and a force f(t, g, ġ) along it. By virtual work,
δW = f δg, its nodal forces are

    F = f ∂g/∂x,      and on a body's coordinates Q_b = J_bᵀ F_b = f ∂g/∂z_b,

so an element is one measure and one law, and the system takes ∂g/∂z by automatic
differentiation through its bodies' maps (``Mechanism``). The measures (``measures``):

- ``Distance``: |r_b − r_a| between two position vectors (or a fixed point);
- ``HingeAngle``: b's angle about a hinge's axis relative to a (or the ground), from the same
  directions as ``drivers.AngleDriver``: u_a, w_a = axis × u_a fixed in a's section frame and
  u_b fixed in b's, u_a in the reference (``section_frame``), φ = atan2(u_b·w_a, u_b·u_a). A
  rotation δθ of b's section changes φ by δθ·axis (the directions are unit vectors of orthonormal
  frames, and the hinge keeps u_b normal to the axis): f is the torque about the axis, applied to
  the cross-section. φ is taken in
  (−π, π]: a spring's angle must stay within π of its rest angle (an actuator's torque that
  depends on t only is unaffected);
- ``Travel``: (r_b − r_a)·d along an axis fixed in a's section frame (or a fixed axis), f the
  force along it.

The laws: ``SpringDamper`` (f = −k (g − g₀) − c ġ, potential ½ k (g − g₀)²) and ``Actuator``
(f = law(t, g, ġ, params), any differentiable function: a motor's torque profile, a
controller; ``params`` a pytree, so that ``jax.grad`` reaches it). An actuator may read the
whole state through ``inputs``, kinematic sensors on markers (``sensors.Position``,
``Velocity``, ``ChordDeflection``: a tip's deflection, a link's velocity), for state feedback:
f = law(t, g, ġ, params, {name: value}).

The iteration matrix takes each element's stiffness and damping on the bodies' diagonal blocks,
∂g/∂z_bᵀ (c_K k + c_C c) ∂g/∂z_b with k = −∂f/∂g, c = −∂f/∂ġ (the term f ∂²g/∂z², of the order
of the force, the coupling between bodies and a feedback law's dependence on its inputs are
left to modified Newton, as the joints' Hessian is).
"""

import abc
import dataclasses
from collections.abc import Callable

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._types import Array, Float, Scalar
from .markers import BodyGeometry, Marker, hinge_angle
from .measures import AbstractMeasure, Distance, HingeAngle, Travel
from .section_frame import Directions
from .sensors import ChordDeflection, Position, Velocity

KINEMATIC_SENSORS = (Position, Velocity, ChordDeflection)
"""The sensors an actuator may read: functions of (z, ż) through the bodies' maps alone (a
reaction or an element's force would make the force depend on itself)."""


class AbstractForceElement(eqx.Module):
    """A force f(t, g, ġ) along a measure g (module docstring)."""

    measure: AbstractMeasure

    @abc.abstractmethod
    def force(self, t: Scalar, g, g_dot, signals=None) -> Float[Array, ""]:
        """f: positive f does positive work when g grows. ``signals``: the element's inputs at
        the state (``signals``), None for an element without inputs."""

    def signals(self, system, t, z, v):
        """The values of the element's inputs at the state (an ``Actuator``'s ``inputs``), or None."""
        return None

    def resolved(self, system) -> "AbstractForceElement":
        """The element with its inputs' markers resolved against ``system`` (``Mechanism``)."""
        return self

    def potential(self, g) -> Float[Array, ""]:
        """The element's potential energy (a spring's), zero for non-conservative elements."""
        return jnp.zeros_like(g)

    def turned(self, A) -> "AbstractForceElement":
        return eqx.tree_at(lambda e: e.measure, self, self.measure.turned(A))


class SpringDamper(AbstractForceElement):
    """f = −k (g − g₀) − c ġ: a linear spring of stiffness ``k`` and rest value ``rest`` (a free
    length, a rest angle) in parallel with a damper ``c``."""

    k: Float[Array, ""]
    c: Float[Array, ""]
    rest: Float[Array, ""]

    def __init__(self, measure: AbstractMeasure, k, c=0.0, rest=0.0):
        self.measure = measure
        self.k, self.c, self.rest = (jnp.asarray(x, dtype=float) for x in (k, c, rest))

    def force(self, t, g, g_dot, signals=None):
        return -self.k * (g - self.rest) - self.c * g_dot

    def potential(self, g):
        return 0.5 * self.k * (g - self.rest) ** 2


def _check_law(law, inputs) -> None:
    if not callable(law):
        raise ValueError("an actuator's law must be callable: law(t, g, g_dot, params) -> force or torque")
    if inputs is not None:
        if not isinstance(inputs, dict) or not inputs:
            raise ValueError("an actuator's inputs must be a non-empty dict {name: sensor}")
        for name, sensor in inputs.items():
            if not isinstance(sensor, KINEMATIC_SENSORS):
                raise ValueError(f"actuator input {name!r}: the inputs are kinematic sensors on markers "
                                 f"(Position, Velocity, ChordDeflection), got {type(sensor).__name__}")


class Actuator(AbstractForceElement):
    """f = law(t, g, ġ, params): a torque at a hinge (``HingeAngle``) or a force along a slider
    (``Travel``) or between points (``Distance``) given by any differentiable ``law``, e.g. a
    motor's torque profile or a feedback law; ``params`` (a pytree of arrays) is its argument,
    so that gradients reach it. Its Python floats become arrays: a compiled run then takes a
    new value as an argument, never as a constant that compiles the run anew (the integers and
    other leaves of ``params`` stay as given). ``inputs`` ({name: sensor}, kinematic sensors on markers):
    f = law(t, g, ġ, params, {name: the sensor's value at the state}), state feedback from
    anywhere in the mechanism (a flexible link's tip deflection and its rate)."""

    law: Callable = eqx.field(static=True)
    params: object
    inputs: dict | None = None

    def __init__(self, measure: AbstractMeasure, law, params=(), inputs=None):
        _check_law(law, inputs)
        params = jax.tree_util.tree_map(lambda x: jnp.asarray(x, dtype=float) if isinstance(x, float) else x, params)
        self.measure, self.law, self.params, self.inputs = measure, law, params, inputs

    def resolved(self, system) -> "Actuator":
        if self.inputs is None:
            return self
        return eqx.tree_at(lambda e: e.inputs, self, {k: s.resolve(system) for k, s in self.inputs.items()})

    def signals(self, system, t, z, v):
        if self.inputs is None:
            return None
        return {name: sensor(system, t, z, v) for name, sensor in self.inputs.items()}

    def force(self, t, g, g_dot, signals=None):
        if self.inputs is None:
            return jnp.asarray(self.law(t, g, g_dot, self.params), dtype=jnp.result_type(g))
        if signals is None:
            raise ValueError("this actuator reads inputs: its force needs their values (signals)")
        return jnp.asarray(self.law(t, g, g_dot, self.params, signals), dtype=jnp.result_type(g))


@dataclasses.dataclass(frozen=True)
class ForceSpec:
    """A force element on markers (``spring``, ``torsion_spring``, ``motor``, ``actuator``),
    resolved by the system into an ``AbstractForceElement`` on nodal vectors (``resolve``).
    ``a``: a marker, a fixed point in space (a 3-vector, for ``"distance"``) or None for the
    ground; ``make`` builds the element from its measure."""

    measure: str  # "distance", "angle" or "travel"
    a: object
    b: Marker
    axis: tuple[float, float, float] | None
    make: Callable[[AbstractMeasure], AbstractForceElement]

    def resolve(self, geometry: tuple[BodyGeometry, ...]) -> AbstractForceElement:
        markers = [m for m in (self.a, self.b) if isinstance(m, Marker)]
        for m in markers:
            if not 0 <= m.body < len(geometry):
                raise ValueError(f"force element on body {m.body}; the system has bodies 0..{len(geometry) - 1}")
        gb = geometry[self.b.body]
        nb = gb.node(self.b)
        a_marker = self.a if isinstance(self.a, Marker) else None
        if self.measure == "distance":
            if a_marker is None:
                return self.make(Distance(None, None, self.b.body, nb, point=self.a))
            return self.make(Distance(a_marker.body, geometry[a_marker.body].node(a_marker), self.b.body, nb))
        if self.measure == "angle":
            return self.make(hinge_angle(geometry, a_marker, self.b, self.axis))
        axis = np.asarray(self.axis)[None]
        if a_marker is None:
            return self.make(Travel(None, None, Directions.ground(axis), self.b.body, nb, point=self.b.point))
        ga = geometry[a_marker.body]
        na = ga.node(a_marker)
        return self.make(Travel(a_marker.body, na, ga.directions(a_marker.body, na, axis), self.b.body, nb))


def _end(a, what: str):
    """A force element's first end: a marker, None (the ground) or a fixed point."""
    if a is None or isinstance(a, Marker):
        return a
    p = np.asarray(a, dtype=float).reshape(-1)
    if p.shape != (3,) or not np.all(np.isfinite(p)):
        raise ValueError(f"{what}: the first end must be a Marker, None or a fixed point (a finite 3-vector), got "
                         f"{a!r}")
    return tuple(float(x) for x in p)


def _axis(axis) -> tuple[float, float, float]:
    e = np.asarray(axis, dtype=float).reshape(-1)
    if e.shape != (3,) or not np.all(np.isfinite(e)) or np.linalg.norm(e) == 0:
        raise ValueError(f"an axis must be a finite nonzero 3-vector, got {axis!r}")
    return tuple(float(x) for x in e / np.linalg.norm(e))


def _non_negative(name, value):
    if isinstance(value, (int, float, np.floating, np.integer)) and not (np.isfinite(value) and value >= 0):
        raise ValueError(f"{name} must be finite and >= 0, got {value!r}")
    return value


def spring(a, b: Marker, k, c=0.0, free_length=None) -> ForceSpec:
    """A translational spring-damper between the points of ``a`` (a marker, or a fixed point in
    space) and ``b``: stiffness ``k`` [N/m], damping ``c`` [N s/m], ``free_length`` [m] (default
    the reference distance, a spring without preload)."""
    a = _end(a, "spring")
    if a is None:
        raise ValueError("spring: the first end must be a Marker or a fixed point, not None")
    _non_negative("k", k), _non_negative("c", c)
    if free_length is None:
        pa = np.asarray(a.point if isinstance(a, Marker) else a)
        free_length = float(np.linalg.norm(np.asarray(b.point) - pa))
    return ForceSpec("distance", a, b, None, lambda m: SpringDamper(m, k, c, free_length))


def torsion_spring(a: Marker | None, b: Marker, axis, k, c=0.0, rest_angle=0.0) -> ForceSpec:
    """A rotational spring-damper at a hinge about ``axis`` between ``a`` (None: the ground) and
    ``b`` (the markers of the ``hinge``): stiffness ``k`` [N m/rad], damping ``c`` [N m s/rad],
    the torque zero at b's angle ``rest_angle`` from its reference orientation."""
    _non_negative("k", k), _non_negative("c", c)
    return ForceSpec("angle", _end(a, "torsion_spring"), b, _axis(axis),
                     lambda m: SpringDamper(m, k, c, rest_angle))


def motor(a: Marker | None, b: Marker, axis, law, params=(), inputs=None) -> ForceSpec:
    """A torque on b about a hinge's ``axis`` (reacting on a, or the ground):
    ``law(t, angle, angular_velocity, params)`` [N m], positive about the axis (``Actuator``);
    with ``inputs`` ({name: kinematic sensor}), ``law(t, angle, angular_velocity, params,
    {name: value})``: state feedback."""
    _check_law(law, inputs)  # now, not when the system resolves the spec
    return ForceSpec("angle", _end(a, "motor"), b, _axis(axis), lambda m: Actuator(m, law, params, inputs))


def actuator(a, b: Marker, law, params=(), axis=None, inputs=None) -> ForceSpec:
    """A force ``law(t, s, ṡ, params)`` [N] on b: with ``axis``, along a slider's axis (s the
    travel from a's point, or from b's reference point with ``a=None``); without, along the
    line between the two points (s their distance; ``a`` a marker or a fixed point). With
    ``inputs`` ({name: kinematic sensor}), ``law(t, s, ṡ, params, {name: value})``."""
    a = _end(a, "actuator")
    _check_law(law, inputs)
    if axis is None:
        if a is None:
            raise ValueError("actuator: without an axis the first end must be a Marker or a fixed point")
        return ForceSpec("distance", a, b, None, lambda m: Actuator(m, law, params, inputs))
    return ForceSpec("travel", a, b, _axis(axis), lambda m: Actuator(m, law, params, inputs))


def resolve_forces(forces, geometry: tuple[BodyGeometry, ...]) -> tuple[AbstractForceElement, ...]:
    """The system's force elements with every ``ForceSpec`` resolved."""
    out = tuple(f.resolve(geometry) if isinstance(f, ForceSpec) else f for f in forces)
    for f in out:
        if not isinstance(f, AbstractForceElement):
            raise ValueError("forces must be force elements (SpringDamper, Actuator) or specs on markers (spring, "
                             f"torsion_spring, motor, actuator), got {type(f).__name__}")
    return out


__all__ = ["AbstractForceElement", "AbstractMeasure", "Actuator", "Distance", "ForceSpec", "HingeAngle",
           "SpringDamper", "Travel", "actuator", "motor", "resolve_forces", "spring", "torsion_spring"]
