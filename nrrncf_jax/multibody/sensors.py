"""Sensors: named outputs of a mechanism's run, defined in physical terms and recorded at the
output times (``observe``, for ``simulate(..., observe=...)``).

A sensor is a function of the system and its state, ``sensor(system, t, z, v) -> array``:

- ``Position(marker, component)``, ``Velocity(marker, component)``: a marker's point (a node's
  position vector) in the inertial frame, all three components or one (0, 1, 2 for x, y, z);
- ``ChordDeflection(a, b, m, normal)``: the signed distance of marker m's point from the chord
  through a's and b's points, positive to the left of the direction from a to b about ``normal``
  (a flexible link's transverse deflection);
- ``SectionAngle(marker, axis)``: how far the section at a marker's node has turned about an axis
  (a beam's twist, a slope);
- ``JointReaction(index)``: the multipliers λ of the system's joint ``index`` (``joints`` gives
  their sign; the consistent ones of the state, ``reactions``); ``DriverEffort(index)``: the
  torque or force a driver (``drivers``) applies to its body;
- ``ElementForce(index, quantity)``: force element ``index``'s force (torque) f, its measure g
  (a spring's length, a motor's angle), its rate ġ or its power f ġ (``forces``);
- ``Energy(kind)``: kinetic, potential or total; ``AngularMomentum()`` about the origin;
- ``post.stress.SectionResultant(marker, quantity)``: a C1 beam's section force or moment at a
  marker's node (it lives with the stresses it reads; ``observe`` takes it like the others).

Markers resolve against the system's bodies in ``observe`` (``resolve``: static node indices,
before anything is traced), so a sensor is written before the system exists.
"""

import dataclasses
from typing import Any

import equinox as eqx
import jax.numpy as jnp

from .._types import Array, Float
from .markers import Marker


def _node(system, marker: Marker) -> int:
    if not 0 <= marker.body < len(system.bodies):
        raise ValueError(f"sensor marker on body {marker.body}; the system has bodies 0..{len(system.bodies) - 1}")
    return system.bodies[marker.body].geometry().node(marker)


class _MarkerSensor(eqx.Module):
    """A sensor on markers: ``resolve(system)`` fills ``nodes``, the markers' nodal vectors."""

    nodes: tuple[int, ...] | None = eqx.field(static=True, default=None, kw_only=True)

    def markers(self) -> tuple[Marker, ...]:
        return tuple(getattr(self, f) for f in ("marker", "a", "b", "m") if isinstance(getattr(self, f, None), Marker))

    def resolve(self, system) -> "_MarkerSensor":
        return dataclasses.replace(self, nodes=tuple(_node(system, m) for m in self.markers()))

    def _points(self, xs) -> list:
        if self.nodes is None:
            raise ValueError("a sensor on markers must be resolved against its system first (sensors.observe)")
        return [xs[m.body][n] for m, n in zip(self.markers(), self.nodes)]


def _component(x, component):
    return x if component is None else x[component]


class Position(_MarkerSensor):
    """A marker's position (or one component) in the inertial frame."""

    marker: Marker = eqx.field(static=True)
    component: int | None = eqx.field(static=True, default=None)

    def __call__(self, system, t, z, v) -> Float[Array, "..."]:
        return _component(self._points(system.nodal_vectors(z))[0], self.component)


class Velocity(_MarkerSensor):
    """A marker's velocity (or one component) in the inertial frame."""

    marker: Marker = eqx.field(static=True)
    component: int | None = eqx.field(static=True, default=None)

    def __call__(self, system, t, z, v) -> Float[Array, "..."]:
        return _component(self._points(system.nodal_velocities(z, v))[0], self.component)


class ChordDeflection(_MarkerSensor):
    """m's signed distance from the chord a → b, positive to the left (about ``normal``)."""

    a: Marker = eqx.field(static=True)
    b: Marker = eqx.field(static=True)
    m: Marker = eqx.field(static=True)
    normal: tuple[float, float, float] = eqx.field(static=True, default=(0.0, 0.0, 1.0))

    def __call__(self, system, t, z, v) -> Float[Array, ""]:
        xa, xb, xm = self._points(system.nodal_vectors(z))
        chord = (xb - xa) / jnp.linalg.norm(xb - xa)
        left = jnp.cross(jnp.asarray(self.normal), chord)
        return (xm - xa) @ left


class SectionAngle(eqx.Module):
    """The angle by which the section frame at a marker's node has turned about ``axis`` (in space,
    from the reference; ``section_frame``): a beam's twist about its axis, a slope about a section
    axis; atan2 of the turned reference direction normal to the axis, in (−π, π]."""

    marker: Marker = eqx.field(static=True)
    axis: tuple[float, float, float] = eqx.field(static=True)
    measure: object = eqx.field(default=None, kw_only=True)

    def resolve(self, system) -> "SectionAngle":
        from .markers import hinge_angle  # the measure of a hinge's angle, relative to the ground

        _node(system, self.marker)
        geometry = tuple(b.geometry() for b in system.bodies)
        return dataclasses.replace(self, measure=hinge_angle(geometry, None, self.marker, self.axis))

    def __call__(self, system, t, z, v) -> Float[Array, ""]:
        if self.measure is None:
            raise ValueError("a sensor on markers must be resolved against its system first (sensors.observe)")
        return self.measure(system.nodal_vectors(z))


class JointReaction(eqx.Module):
    """The multipliers of joint ``index`` at the state (``system.reactions``)."""

    index: int = eqx.field(static=True)

    def __call__(self, system, t, z, v) -> Float[Array, " m"]:
        lam = system.reactions(t, z, v)
        return lam[system.joint_slices()[self.index]]


class DriverEffort(eqx.Module):
    """The driving torque or force of the driver ``index`` (``drivers``: −λ)."""

    index: int = eqx.field(static=True)

    def __call__(self, system, t, z, v) -> Float[Array, ""]:
        joint = system.joints[self.index]
        if not hasattr(joint, "effort"):
            raise ValueError(f"joint {self.index} ({type(joint).__name__}) is not a driver")
        lam = system.reactions(t, z, v)
        return joint.effort(lam[system.joint_slices()[self.index]])


class ElementForce(eqx.Module):
    """Force element ``index``'s ``"force"`` f (a torque for a hinge's elements), ``"measure"`` g,
    ``"rate"`` ġ or ``"power"`` f ġ (the work it does on the system per second)."""

    index: int = eqx.field(static=True)
    quantity: str = eqx.field(static=True, default="force")

    def __check_init__(self):
        if self.quantity not in ("force", "measure", "rate", "power"):
            raise ValueError(f"quantity must be 'force', 'measure', 'rate' or 'power', got {self.quantity!r}")

    def __call__(self, system, t, z, v) -> Float[Array, ""]:
        if not 0 <= self.index < len(system.forces):
            raise ValueError(f"force element {self.index}: the system has {len(system.forces)}")
        g, g_dot, f = (y[self.index] for y in system.element_state(t, z, v))
        return {"force": f, "measure": g, "rate": g_dot, "power": f * g_dot}[self.quantity]


class Energy(eqx.Module):
    """``"kinetic"``, ``"potential"`` (strain and gravity) or ``"total"``."""

    kind: str = eqx.field(static=True, default="total")

    def __check_init__(self):
        if self.kind not in ("kinetic", "potential", "total"):
            raise ValueError(f"energy kind must be 'kinetic', 'potential' or 'total', got {self.kind!r}")

    def __call__(self, system, t, z, v) -> Float[Array, ""]:
        if self.kind == "kinetic":
            return system.kinetic_energy(z, v)
        if self.kind == "potential":
            return system.potential_energy(z)
        return system.energy(z, v)


class AngularMomentum(eqx.Module):
    """The system's angular momentum about the origin, Σ_b Σ_vw M_b,vw x_v × ẋ_w: for the nodal
    vectors x(ξ) = Σ_v N_v(ξ) x_v of any body, ∫ρ x × ẋ dV is this sum (on a rigid body's
    axes, Σ Θ'_kl g_k × ġ_l is its spin J ω). All three components, or one (``component``)."""

    component: int | None = eqx.field(static=True, default=None)

    def __call__(self, system, t, z, v) -> Float[Array, "..."]:
        xs, vs = system.nodal_vectors(z), system.nodal_velocities(z, v)
        H = sum(jnp.sum(jnp.cross(x[:, None, :], xv[None, :, :]) * M[:, :, None], axis=(0, 1))
                for M, x, xv in zip(system.masses, xs, vs))
        return _component(H, self.component)


class Observer(eqx.Module):
    """``observer(t, z, v) -> {name: value}``: every sensor of ``sensors`` on ``system``'s state.
    A module, so that the system's arrays are arguments of a compiled run, not constants in it
    (a rerun with new parameter values and the same shapes is the same program)."""

    system: Any
    sensors: dict

    def __call__(self, t, z, v):
        shared = _SharedEvaluations(self.system)
        return {name: jnp.asarray(sensor(shared, t, z, v)) for name, sensor in self.sensors.items()}


class _SharedEvaluations:
    """The system as the sensors of one observation see it: the evaluations that several sensors
    read (the nodal vectors and velocities, the joints' reactions, the force elements' states)
    are computed once per state and shared; every other attribute is the system's own.

    Traced sensor by sensor, each recomputed them: the same nodal vectors once per position
    sensor and a linear solve for the reactions once per driver or joint sensor, all of it
    lowered into the program that XLA compiles (deduplicated only after lowering). The memo is
    keyed on the arguments' identities, which hold within one observation (the same traced
    ``t``, ``z``, ``v``)."""

    SHARED = ("nodal_vectors", "nodal_velocities", "reactions", "element_state")

    def __init__(self, system):
        self._system = system
        self._memo = {}

    def __getattr__(self, name):
        attr = getattr(self._system, name)
        if name not in self.SHARED:
            return attr

        def shared(*args, **kwargs):
            if kwargs:
                return attr(*args, **kwargs)
            key = (name, *map(id, args))
            if key not in self._memo:
                self._memo[key] = (attr(*args), args)  # the args kept alive: their ids stay theirs
            return self._memo[key][0]

        return shared


def observe(system, sensors: dict) -> Observer:
    """``observe(t, z, v) -> {name: value}`` for ``simulate``: every sensor at the output times.
    The markers are resolved here, so that a bad one fails before the run."""
    for name, sensor in sensors.items():
        if not callable(sensor):
            raise ValueError(f"sensor {name!r} is not callable (a sensor is sensor(system, t, z, v))")
    sensors = {name: s.resolve(system) if isinstance(s, (_MarkerSensor, SectionAngle)) else s
               for name, s in sensors.items()}
    return Observer(system, sensors)


__all__ = ["AngularMomentum", "ChordDeflection", "DriverEffort", "ElementForce", "Energy", "JointReaction", "Observer",
           "Position", "SectionAngle", "Velocity", "observe"]
