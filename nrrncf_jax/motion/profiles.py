"""Parameterised profiles for control design: the spin-up of Eq. 43 plus a smooth, trainable
correction (``FourierSpinUp``), and a rest-to-rest move with one (``RestToRest``).

The correction lives in the space of trigonometric polynomials on [0, Ts] that vanish at both
ends and have zero mean, so every coefficient vector gives a continuous θ̈ that reaches the
steady spin rate ωs exactly at Ts (the end-speed constraint is built into the basis rather than
imposed by a penalty). θ̇ and θ are the exact integrals, in closed form.
"""

import jax.numpy as jnp
import numpy as np

from .. import _validate
from .._types import Array, ArrayLike, Float, ScalarLike
from .prescribed import AbstractAxisMotion, spin_up_angle, unit_axis


class FourierSpinUp(AbstractAxisMotion):
    """Spin-up about a fixed ``axis`` (default Z): Eq. 43's θ̈ plus a zero-mean Fourier correction.

    With τ = 2πt/Ts and n terms, for 0 ≤ t ≤ Ts

        θ̈(t) = (ωs/Ts)(1 − cos τ) + Σ_{k=1..n} [a_k sin kτ + b_k (cos kτ − cos (k+1)τ)],

    and θ̈ = 0, θ̇ = ωs after Ts. Every basis function vanishes at t = 0 and t = Ts (θ̈ is
    continuous, starting and ending at zero) and integrates to zero over [0, Ts] (θ̇(Ts) = ωs
    for any coefficients). The b-functions also have zero slope at both ends; the a-functions
    do not, so a profile with a ≠ 0 has a jump in jerk at 0 and Ts. θ̇ and θ are exact integrals;
    θ(Ts) = ωs Ts/2 + Σ a_k Ts²/(2πk). With all coefficients zero this is ``SpinUp`` (Eq. 43).

    ``coeffs`` has shape (2, n): row 0 the a_k, row 1 the b_k [rad/s²]. Every field is an array,
    so the profile can be differentiated with respect to its coefficients (swap them with
    ``eqx.tree_at``) or vmapped over.
    """

    omega_s: Float[Array, ""]
    T_s: Float[Array, ""]
    coeffs: Float[Array, "2 n"]
    axis: Float[Array, " 3"]

    def __init__(self, omega_s: ScalarLike, T_s: ScalarLike = 15.0, coeffs: Float[ArrayLike, "2 n"] | None = None,
                 n_terms: int | None = None, axis=(0.0, 0.0, 1.0)):
        _validate.positive("omega_s (steady spin rate)", omega_s)
        _validate.positive("T_s (spin-up time)", T_s)
        if coeffs is None:
            if n_terms is None:
                raise ValueError("give the coefficients (shape (2, n)) or n_terms for a zero correction")
            coeffs = jnp.zeros((2, _validate.positive_int("n_terms", n_terms)))
        elif n_terms is not None:
            raise ValueError("give either coeffs or n_terms, not both")
        _check_coeffs(coeffs)
        self.omega_s = jnp.asarray(omega_s, dtype=float)
        self.T_s = jnp.asarray(T_s, dtype=float)
        self.coeffs = jnp.asarray(coeffs, dtype=float)
        self.axis = unit_axis(axis)

    @property
    def n_terms(self) -> int:
        return self.coeffs.shape[1]

    def __call__(self, t: ScalarLike) -> tuple[Float[Array, "..."], Float[Array, "..."], Float[Array, "..."]]:
        """``(θ, θ̇, θ̈)`` at time t (any shape)."""
        w, T = self.omega_s, self.T_s
        t = jnp.asarray(t, dtype=float)
        (th, dth, ddth), tc, spinning = spin_up_angle(w, T, t)  # Eq. 43
        c = 2.0 * jnp.pi / T
        # The correction: sin kτ, and cos mτ with weight d_m = b_m − b_{m−1} (m = 1..n+1).
        a, d = self.sine_coeffs, self.cosine_coeffs
        ka = c * jnp.arange(1, a.shape[0] + 1, dtype=float)
        kd = c * jnp.arange(1, d.shape[0] + 1, dtype=float)
        xa = tc[..., None] * ka
        xd = tc[..., None] * kd
        sa, ca, sd, cd = jnp.sin(xa), jnp.cos(xa), jnp.sin(xd), jnp.cos(xd)
        ddth = ddth + sa @ a + cd @ d
        dth = dth + ((1.0 - ca) / ka) @ a + (sd / kd) @ d
        th = th + ((tc[..., None] - sa / ka) / ka) @ a + ((1.0 - cd) / kd**2) @ d
        return (th + w * (t - tc), jnp.where(spinning, w, dth), jnp.where(spinning, 0.0, ddth))

    @property
    def sine_coeffs(self) -> Float[Array, " n"]:
        """a_k, the weights of sin kτ."""
        return self.coeffs[0]

    @property
    def cosine_coeffs(self) -> Float[Array, " n+1"]:
        """d_m = b_m − b_{m−1} (b_0 = b_{n+1} = 0), the weights of cos mτ, m = 1..n+1; Σ d_m = 0."""
        b = self.coeffs[1]
        z = jnp.zeros((1,), b.dtype)
        return jnp.concatenate([b, z]) - jnp.concatenate([z, b])

    def correction_mean_square(self) -> Float[Array, ""]:
        """Mean over [0, Ts] of (θ̈ − θ̈_Eq.43)², in closed form: ½(Σ a_k² + Σ d_m²) [rad²/s⁴].

        Smooth in the coefficients (its square root, the RMS, has no derivative at zero).
        """
        return 0.5 * (jnp.sum(self.sine_coeffs**2) + jnp.sum(self.cosine_coeffs**2))


class RestToRest(AbstractAxisMotion):
    """A rest-to-rest move about a fixed ``axis`` by ``delta`` [rad] in ``T`` [s], with a
    trainable correction: with τ = t/T ∈ [0, 1],

        θ(t) = Δ (τ − sin 2πτ / 2π) + Σ_{k=1..n} c_k sin²(πτ) sin kπτ,

    and θ = Δ after T. The cycloid starts and ends with zero speed and acceleration, and each
    correction term is O(τ³) at both ends, so for any coefficients θ is C² (the acceleration
    continuous: a driver's torque has no jump) and the move ends at rest at Δ. ``coeffs``
    (n,) [rad] are the control variables of a trajectory optimisation
    (``examples.two_link_arm``); (θ, θ̇, θ̈) in closed form."""

    delta: Float[Array, ""]
    T: Float[Array, ""]
    coeffs: Float[Array, " n"]
    axis: Float[Array, " 3"]

    def __init__(self, delta: ScalarLike, T: ScalarLike, coeffs=None, n_terms: int = 0, axis=(0.0, 0.0, 1.0)):
        _validate.positive("T (move time)", T)
        if coeffs is None:
            coeffs = jnp.zeros((int(n_terms),))
        elif _validate.is_concrete(coeffs) and (np.ndim(coeffs) != 1 or not np.all(np.isfinite(coeffs))):
            raise ValueError(f"coeffs must be a finite vector (n,), got {np.shape(coeffs)}")
        self.delta = jnp.asarray(delta, dtype=float)
        self.T = jnp.asarray(T, dtype=float)
        self.coeffs = jnp.asarray(coeffs, dtype=float)
        self.axis = unit_axis(axis)

    def __call__(self, t: ScalarLike) -> tuple[Float[Array, "..."], Float[Array, "..."], Float[Array, "..."]]:
        """``(θ, θ̇, θ̈)`` at time t (any shape)."""
        t = jnp.asarray(t, dtype=float)
        moving = t < self.T
        tau = jnp.clip(t / self.T, 0.0, 1.0)
        w = 2.0 * jnp.pi
        th = self.delta * (tau - jnp.sin(w * tau) / w)
        dth = self.delta * (1.0 - jnp.cos(w * tau))
        ddth = self.delta * w * jnp.sin(w * tau)
        # c_k sin²(πτ) sin(kπτ) = c_k (1 − cos 2πτ)/2 · sin kπτ, and its τ-derivatives
        k = jnp.pi * jnp.arange(1, self.coeffs.shape[0] + 1, dtype=float)
        x = tau[..., None]
        b, db, ddb = 0.5 * (1.0 - jnp.cos(w * x)), 0.5 * w * jnp.sin(w * x), 0.5 * w**2 * jnp.cos(w * x)
        s, ds, dds = jnp.sin(k * x), k * jnp.cos(k * x), -(k**2) * jnp.sin(k * x)
        th = th + (b * s) @ self.coeffs
        dth = dth + (db * s + b * ds) @ self.coeffs
        ddth = ddth + (ddb * s + 2.0 * db * ds + b * dds) @ self.coeffs
        return th, jnp.where(moving, dth / self.T, 0.0), jnp.where(moving, ddth / self.T**2, 0.0)


def _check_coeffs(coeffs) -> None:
    if not _validate.is_concrete(coeffs):
        return
    c = np.asarray(coeffs)
    if c.ndim != 2 or c.shape[0] != 2 or c.shape[1] < 1:
        raise ValueError(f"coeffs must have shape (2, n) with n >= 1 (row 0: sine, row 1: cosine-pair "
                         f"coefficients), got shape {c.shape}")
    if not np.all(np.isfinite(c)):
        raise ValueError("coeffs must be finite (got NaN or Inf)")


class SpinSchedule(AbstractAxisMotion):
    """A spin rate that moves between plateaus by half-cosine ramps: ``ramps`` rows (t₀, t₁, ω₀,
    ω₁), in time order and not overlapping, take the rate from ω₀ to ω₁ over [t₀, t₁] as
    ω = ω₀ + (ω₁ − ω₀)(1 − cos πs)/2, s = (t − t₀)/(t₁ − t₀); between ramps the rate holds (the
    first ramp's ω₀ before it). θ̇ is C¹ and θ̈ continuous; θ is the exact integral,
    ω₀τ + (ω₁ − ω₀)(τ − (T/π) sin(πτ/T))/2 over a ramp (τ = t − t₀, T = t₁ − t₀), in closed form
    (the validation set's rotating shaft: 0 → 48 rad/s over 0-0.5 s, 48 → 72 over 1-1.25 s)."""

    ramps: Float[Array, "k 4"]
    axis: Float[Array, " 3"]

    def __init__(self, ramps, axis=(1.0, 0.0, 0.0)):
        r = np.asarray(ramps, dtype=float).reshape(-1, 4)
        if not r.size or not np.all(np.isfinite(r)) or np.any(r[:, 1] <= r[:, 0]) or np.any(r[1:, 0] < r[:-1, 1]):
            raise ValueError("ramps must be rows (t0, t1, omega0, omega1) with t0 < t1, in time order, not "
                             f"overlapping; got {ramps!r}")
        if np.any(np.abs(r[1:, 2] - r[:-1, 3]) > 1e-12 * max(1.0, np.abs(r[:, 2:]).max())):
            raise ValueError("each ramp must start at the rate the one before it ended at (omega0 = previous omega1)")
        self.ramps = jnp.asarray(r)
        self.axis = unit_axis(axis)

    def __call__(self, t):
        t = jnp.asarray(t, dtype=float)
        t0, t1, w0, w1 = (self.ramps[:, k] for k in range(4))
        T = t1 - t0
        tau = jnp.clip(t[..., None] - t0, 0.0, T)  # time into each ramp, held at its end
        s = tau / T
        # each ramp's angle, rate and acceleration beyond the rate it starts from
        angle = 0.5 * (w1 - w0) * (tau - T / jnp.pi * jnp.sin(jnp.pi * s))
        angle = angle + (w1 - w0) * jnp.maximum(t[..., None] - t1, 0.0)  # its rate change held after it
        rate = 0.5 * (w1 - w0) * (1.0 - jnp.cos(jnp.pi * s))
        inside = (t[..., None] > t0) & (t[..., None] < t1)
        acc = jnp.where(inside, 0.5 * (w1 - w0) * jnp.pi / T * jnp.sin(jnp.pi * s), 0.0)
        return (self.ramps[0, 2] * t + angle.sum(-1), self.ramps[0, 2] + rate.sum(-1), acc.sum(-1))


class HalfCosine(AbstractAxisMotion):
    """A rotation by ``angle`` about ``axis`` along a half cosine over ``T``, then held:
    θ(t) = (angle/2)(1 − cos(π t/T)) for 0 ≤ t ≤ T, ``angle`` after (MBDyn's ``cosine`` drive over
    half a cycle; the validation set's lateral buckling turns its crank so). θ̇ starts and ends at
    zero; θ̈ jumps at 0 and T."""

    angle: Float[Array, ""]
    T: Float[Array, ""]
    axis: Float[Array, " 3"]

    def __init__(self, angle, T, axis=(0.0, 0.0, 1.0)):
        if not float(T) > 0:
            raise ValueError(f"T must be > 0, got {T!r}")
        self.angle = jnp.asarray(angle, dtype=float)
        self.T = jnp.asarray(T, dtype=float)
        self.axis = unit_axis(axis)

    def __call__(self, t):
        t = jnp.asarray(t, dtype=float)
        w = jnp.pi / self.T
        s = w * jnp.clip(t, 0.0, self.T)
        moving = (t > 0.0) & (t < self.T)
        half = 0.5 * self.angle
        return (half * (1.0 - jnp.cos(s)), jnp.where(moving, half * w * jnp.sin(s), 0.0),
                jnp.where(moving, half * w**2 * jnp.cos(s), 0.0))
