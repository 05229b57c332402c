"""Prescribed reference motion: the spin-up driver of Eq. 43 about a fixed axis."""

import equinox as eqx
import jax.numpy as jnp

from . import _validate
from ._types import Array, Float, ScalarLike


class SpinUp(eqx.Module):
    """θ(t) = (ωs/Ts)[t²/2 + (Ts/2π)²(cos(2πt/Ts) − 1)] for t ≤ Ts, ωs(t − Ts/2) after (Eq. 43).

    θ̇ and θ̈ are continuous; θ̈(0) = θ̈(Ts) = 0. ``omega_s`` and ``T_s`` are arrays, so the
    motion can be vmapped over or differentiated.
    """

    omega_s: Float[Array, ""]
    T_s: Float[Array, ""]

    def __init__(self, omega_s: ScalarLike, T_s: ScalarLike = 15.0):
        _validate.positive("omega_s (steady spin rate)", omega_s)
        _validate.positive("T_s (spin-up time)", T_s)
        self.omega_s = jnp.asarray(omega_s, dtype=float)
        self.T_s = jnp.asarray(T_s, dtype=float)

    def __call__(self, t: ScalarLike) -> tuple[Float[Array, ""], Float[Array, ""], Float[Array, ""]]:
        """``(θ, θ̇, θ̈)`` at time t."""
        w, T = self.omega_s, self.T_s
        t = jnp.asarray(t, dtype=float)
        tc = jnp.minimum(t, T)
        c = 2.0 * jnp.pi / T
        up = (
            (w / T) * (0.5 * tc**2 + (jnp.cos(c * tc) - 1.0) / c**2),
            (w / T) * (tc - jnp.sin(c * tc) / c),
            (w / T) * (1.0 - jnp.cos(c * tc)),
        )
        after = (w * (t - 0.5 * T), w, jnp.zeros_like(t))
        spinning = t > T
        return tuple(jnp.where(spinning, a, u) for a, u in zip(after, up))


def rotation_about(axis: Float[Array, " 3"], theta: Float[Array, ""]) -> Float[Array, "3 3"]:
    """Rotation matrix A = exp(θ ẽ) about a unit axis (Rodrigues)."""
    E = skew(axis)
    return jnp.eye(3) + jnp.sin(theta) * E + (1.0 - jnp.cos(theta)) * (E @ E)


def skew(a: Float[Array, " 3"]) -> Float[Array, "3 3"]:
    """ã with ã b = a × b (Eq. 21)."""
    return jnp.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


class SteadySpin(eqx.Module):
    """Spin at the constant rate ω: θ = ωt, θ̇ = ω, θ̈ = 0 (the state after a spin-up; the
    spinning equilibrium and its modes, ``reduction.spin_state``)."""

    omega: Float[Array, ""]

    def __init__(self, omega: ScalarLike):
        _validate.positive("omega (spin rate)", omega)
        self.omega = jnp.asarray(omega, dtype=float)

    def __call__(self, t: ScalarLike) -> tuple[Float[Array, ""], Float[Array, ""], Float[Array, ""]]:
        t = jnp.asarray(t, dtype=float)
        return self.omega * t, self.omega + jnp.zeros_like(t), jnp.zeros_like(t)


class Stationary(eqx.Module):
    """No reference motion: θ = θ̇ = θ̈ = 0 (static problems, free vibration)."""

    def __call__(self, t: ScalarLike) -> tuple[Float[Array, ""], Float[Array, ""], Float[Array, ""]]:
        z = jnp.zeros_like(jnp.asarray(t, dtype=float))
        return z, z, z
