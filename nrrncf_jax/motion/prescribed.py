"""Prescribed motion of a body's reference frame (docs/theory.md, §3 Equations of motion of one
body): the frame's rotation A(t), its angular velocity ω(t) and acceleration ω̇(t) (3-vectors
resolved in the reference frame, so that Ȧ = A ω̃), and the acceleration of its origin.

- ``AbstractMotion``: what a model asks of a prescribed frame motion. A new motion is one
  subclass implementing ``rotation``, ``angular_velocity`` and ``angular_acceleration``.
- ``AbstractAxisMotion``: rotation by an angle θ(t) about a fixed unit axis e, ω = θ̇ e,
  ω̇ = θ̈ e; its subclasses give the angle profile ``(θ, θ̇, θ̈)``. Cases: ``SpinUp`` (the paper's
  Eq. 43, written once here as ``spin_up_angle``), ``SteadySpin``, ``Stationary``, and the
  trainable ``profiles.FourierSpinUp``.
- ``HarmonicTranslation``: a translation of the frame's origin without rotation.
- ``ComposedMotion``: one motion carried by another (A = A_outer A_inner), e.g. a spin about a
  body axis that itself precesses, or a spin on an oscillating hub.

``directions`` is a basis of the space that ω(t) and ω̇(t) never leave (one column for a fixed
axis, the identity otherwise): the reduced model (``reduction.tensors.rotation_inertia``)
precomputes its rotation-inertia matrices for those directions only.
"""

import abc

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .. import _validate
from .._types import Array, Float, ScalarLike


def skew(a: Float[Array, " 3"]) -> Float[Array, "3 3"]:
    """ã with ã b = a × b (Eq. 21)."""
    return jnp.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def rotation_about(axis: Float[Array, " 3"], theta: Float[Array, ""]) -> Float[Array, "3 3"]:
    """Rotation matrix A = exp(θ ẽ) about a unit axis (Rodrigues)."""
    E = skew(axis)
    return jnp.eye(3) + jnp.sin(theta) * E + (1.0 - jnp.cos(theta)) * (E @ E)


class AbstractMotion(eqx.Module):
    """A prescribed motion of the reference frame; an ``equinox.Module``, so its parameters are
    arrays that can be traced, vmapped over and differentiated."""

    @abc.abstractmethod
    def rotation(self, t: ScalarLike) -> Float[Array, "3 3"]:
        """A(t): reference-frame components to inertial ones."""

    @abc.abstractmethod
    def angular_velocity(self, t: ScalarLike) -> Float[Array, " 3"]:
        """ω(t) in the reference frame (Ȧ = A ω̃)."""

    @abc.abstractmethod
    def angular_acceleration(self, t: ScalarLike) -> Float[Array, " 3"]:
        """ω̇(t) in the reference frame."""

    def origin_acceleration(self, t: ScalarLike) -> Float[Array, " 3"]:
        """r̈₀(t), the acceleration of the frame's origin, in the inertial frame (zero by default).
        In the reference frame it acts as a uniform body load −Aᵀr̈₀, like gravity (Eq. 12)."""
        return jnp.zeros(3)

    def origin(self, t: ScalarLike) -> tuple[Float[Array, " 3"], Float[Array, " 3"]]:
        """``(r₀, ṙ₀)`` of the frame's origin in the inertial frame (zero by default; a motion that
        translates overrides this and ``origin_acceleration`` together)."""
        return jnp.zeros(3), jnp.zeros(3)

    @property
    def directions(self) -> Float[Array, "3 d"]:
        """Orthonormal columns spanning every ω(t) and ω̇(t) (default: all of R³)."""
        return jnp.eye(3)

    def frame_terms(self, t, Q: Float[Array, "n 3"], V: Float[Array, "n 3"]):
        """The three frame terms of the acceleration of points at Q moving with V (rows) in the
        reference frame (Eq. 8): ``(2ω×V, ω̇×Q, ω×(ω×Q))``."""
        w, wd = self.angular_velocity(t), self.angular_acceleration(t)
        return 2.0 * jnp.cross(w, V), jnp.cross(wd, Q), jnp.cross(w, jnp.cross(w, Q))

    def frame_matrices(self, t) -> tuple[Float[Array, "3 3"], Float[Array, "3 3"], Float[Array, "3 3"]]:
        """``(ω̃, ω̇̃, ω̃ω̃)`` at t: the frame terms as matrices, for the iteration matrix."""
        W = skew(self.angular_velocity(t))
        return W, skew(self.angular_acceleration(t)), W @ W


class AbstractAxisMotion(AbstractMotion):
    """Rotation by θ(t) about the fixed unit ``axis`` e: A = exp(θ ẽ), ω = θ̇ e, ω̇ = θ̈ e.
    Subclasses implement ``__call__(t) -> (θ, θ̇, θ̈)``."""

    axis: eqx.AbstractVar[Float[Array, " 3"]]

    @abc.abstractmethod
    def __call__(self, t: ScalarLike) -> tuple[Float[Array, "..."], Float[Array, "..."], Float[Array, "..."]]:
        """``(θ, θ̇, θ̈)`` at time t."""

    def rotation(self, t):
        return rotation_about(self.axis, self(t)[0])

    def angular_velocity(self, t):
        return self(t)[1] * self.axis

    def angular_acceleration(self, t):
        return self(t)[2] * self.axis

    @property
    def directions(self):
        return self.axis[:, None]

    # The frame terms with the rates factored out, θ̇ ẽ and θ̈ ẽ: fewer products than the general
    # form. The general form rounds differently inside the integrator's fused loop, which can move
    # an adaptive step decision; this form keeps the fixed-axis models' results unchanged to the
    # bit.
    def frame_terms(self, t, Q, V):
        _, dth, ddth = self(t)
        e = self.axis
        return 2.0 * dth * jnp.cross(e, V), ddth * jnp.cross(e, Q), dth**2 * jnp.cross(e, jnp.cross(e, Q))

    def frame_matrices(self, t):
        _, dth, ddth = self(t)
        E = skew(self.axis)
        return dth * E, ddth * E, dth**2 * (E @ E)


def unit_axis(axis) -> Float[Array, " 3"]:
    """``axis`` as a unit 3-vector; a ``ValueError`` for a wrong shape or a zero vector."""
    a = jnp.asarray(axis, dtype=float)
    if a.shape != (3,):
        raise ValueError(f"axis must be a 3-vector, got shape {a.shape}")
    if _validate.is_concrete(a) and not np.linalg.norm(np.asarray(a)) > 0.0:
        raise ValueError("axis must be a non-zero 3-vector")
    return a / jnp.linalg.norm(a)


def spin_up_angle(omega_s, T_s, t):
    """Eq. 43 and its derivatives: θ(t) = (ωs/Ts)[t²/2 + (Ts/2π)²(cos(2πt/Ts) − 1)] for t ≤ Ts,
    ωs(t − Ts/2) after; returns ``(θ, θ̇, θ̈)`` with θ clamped at Ts (the caller adds the steady
    part, see ``SpinUp``) and the spinning mask ``t > Ts``."""
    w, T = omega_s, T_s
    tc = jnp.minimum(t, T)
    c = 2.0 * jnp.pi / T
    up = (
        (w / T) * (0.5 * tc**2 + (jnp.cos(c * tc) - 1.0) / c**2),
        (w / T) * (tc - jnp.sin(c * tc) / c),
        (w / T) * (1.0 - jnp.cos(c * tc)),
    )
    return up, tc, t > T


class SpinUp(AbstractAxisMotion):
    """The spin-up of Eq. 43 about ``axis`` (default Z): θ̇ and θ̈ are continuous;
    θ̈(0) = θ̈(Ts) = 0, θ̇ = ωs after Ts. ``omega_s`` and ``T_s`` are arrays, so the motion can
    be vmapped over or differentiated."""

    omega_s: Float[Array, ""]
    T_s: Float[Array, ""]
    axis: Float[Array, " 3"]

    def __init__(self, omega_s: ScalarLike, T_s: ScalarLike = 15.0, axis=(0.0, 0.0, 1.0)):
        _validate.positive("omega_s (steady spin rate)", omega_s)
        _validate.positive("T_s (spin-up time)", T_s)
        self.omega_s = jnp.asarray(omega_s, dtype=float)
        self.T_s = jnp.asarray(T_s, dtype=float)
        self.axis = unit_axis(axis)

    def __call__(self, t):
        w, T = self.omega_s, self.T_s
        t = jnp.asarray(t, dtype=float)
        up, _, spinning = spin_up_angle(w, T, t)
        after = (w * (t - 0.5 * T), w, jnp.zeros_like(t))
        return tuple(jnp.where(spinning, a, u) for a, u in zip(after, up))


class SteadySpin(AbstractAxisMotion):
    """Spin at the constant rate ω about ``axis``: θ = ωt, θ̇ = ω, θ̈ = 0 (the state after a
    spin-up; the spinning equilibrium and its modes, ``reduction.spin_state``)."""

    omega: Float[Array, ""]
    axis: Float[Array, " 3"]

    def __init__(self, omega: ScalarLike, axis=(0.0, 0.0, 1.0)):
        _validate.positive("omega (spin rate)", omega)
        self.omega = jnp.asarray(omega, dtype=float)
        self.axis = unit_axis(axis)

    def __call__(self, t):
        t = jnp.asarray(t, dtype=float)
        return self.omega * t, self.omega + jnp.zeros_like(t), jnp.zeros_like(t)


class Stationary(AbstractAxisMotion):
    """No reference motion: θ = θ̇ = θ̈ = 0 (static problems, free vibration)."""

    axis: Float[Array, " 3"]

    def __init__(self, axis=(0.0, 0.0, 1.0)):
        self.axis = unit_axis(axis)

    def __call__(self, t):
        z = jnp.zeros_like(jnp.asarray(t, dtype=float))
        return z, z, z


class HarmonicTranslation(AbstractMotion):
    """The frame translates without rotating: r₀(t) = a sin(2π f t) (``amplitude`` a, a 3-vector
    in metres, ``frequency`` f in Hz), e.g. the hub's axial oscillation of the paper's rotating
    membrane (Sec. 4.3); compose it with a spin (``ComposedMotion(outer=translation, inner=spin)``)."""

    amplitude: Float[Array, " 3"]
    frequency: Float[Array, ""]

    def __init__(self, amplitude, frequency: ScalarLike):
        a = jnp.asarray(amplitude, dtype=float)
        if a.shape != (3,):
            raise ValueError(f"amplitude must be a 3-vector, got shape {a.shape}")
        _validate.positive("frequency [Hz]", frequency)
        self.amplitude = a
        self.frequency = jnp.asarray(frequency, dtype=float)

    def rotation(self, t):
        return jnp.eye(3)

    def angular_velocity(self, t):
        return jnp.zeros(3)

    def angular_acceleration(self, t):
        return jnp.zeros(3)

    def origin(self, t):
        w = 2.0 * jnp.pi * self.frequency
        return self.amplitude * jnp.sin(w * t), self.amplitude * (w * jnp.cos(w * t))

    def origin_acceleration(self, t):
        w = 2.0 * jnp.pi * self.frequency
        return self.amplitude * (-(w**2) * jnp.sin(w * t))

    @property
    def directions(self):
        return jnp.zeros((3, 0))


class ComposedMotion(AbstractMotion):
    """``inner`` carried by ``outer``: A = A_o A_i, so (with Ȧ = A ω̃)

        ω = A_iᵀ ω_o + ω_i,    ω̇ = A_iᵀ ω̇_o − ω_i × (A_iᵀ ω_o) + ω̇_i,

    and the origin moves with the outer motion. E.g. a disc spinning about its own axis
    (``inner``) while that axis precesses (``outer``)."""

    outer: AbstractMotion
    inner: AbstractMotion

    def rotation(self, t):
        return self.outer.rotation(t) @ self.inner.rotation(t)

    def angular_velocity(self, t):
        return self.inner.rotation(t).T @ self.outer.angular_velocity(t) + self.inner.angular_velocity(t)

    def angular_acceleration(self, t):
        Ai = self.inner.rotation(t)
        wi = self.inner.angular_velocity(t)
        return Ai.T @ self.outer.angular_acceleration(t) - jnp.cross(wi, Ai.T @ self.outer.angular_velocity(t)) \
            + self.inner.angular_acceleration(t)

    def origin_acceleration(self, t):
        return self.outer.origin_acceleration(t)

    def origin(self, t):
        return self.outer.origin(t)

    @property
    def directions(self):
        # A translating outer motion adds no rotation: the inner motion's directions suffice.
        return self.inner.directions if self.outer.directions.shape[1] == 0 else jnp.eye(3)
