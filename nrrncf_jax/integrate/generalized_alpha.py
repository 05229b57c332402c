"""Generalized-α coefficients and the step's kinematics (THEORY §8).

Arnold-Brüls form: the equations hold at t_{n+1} with the true acceleration a_{n+1}; an
auxiliary acceleration ā carries the α-weighting,

    (1 − α_m) ā_{n+1} + α_m ā_n = (1 − α_f) a_{n+1} + α_f a_n
    q_{n+1} = q_n + h v_n + h²(½ − β) ā_n + h² β ā_{n+1}
    v_{n+1} = v_n + h(1 − γ) ā_n + h γ ā_{n+1}

so that with a_{n+1} as the Newton unknown, ∂q/∂a = h²β(1−α_f)/(1−α_m) and
∂v/∂a = hγ(1−α_f)/(1−α_m). Second order for every ρ∞ ∈ [0, 1]; for ρ∞ = 1 and linear
problems it conserves energy exactly.
"""

import equinox as eqx
import jax
import jax.numpy as jnp

from .._types import Array, Float


class GeneralizedAlpha(eqx.Module):
    """Chung-Hulbert parameters from the spectral radius at infinity ρ∞ ∈ [0, 1].

    ρ∞ is an array, so runs with different ρ∞ share one compilation (and can be vmapped).
    """

    rho_inf: Float[Array, ""]

    def __init__(self, rho_inf=0.9):
        if not isinstance(rho_inf, jax.core.Tracer) and not (0.0 <= float(rho_inf) <= 1.0):
            raise ValueError(f"rho_inf must lie in [0, 1], got rho_inf={float(rho_inf)!r}")
        self.rho_inf = jnp.asarray(rho_inf, dtype=float)

    @property
    def alpha_m(self) -> float:
        r = self.rho_inf
        return (2.0 * r - 1.0) / (r + 1.0)

    @property
    def alpha_f(self) -> float:
        r = self.rho_inf
        return r / (r + 1.0)

    @property
    def gamma(self) -> float:
        return 0.5 + self.alpha_f - self.alpha_m

    @property
    def beta(self) -> float:
        return 0.25 * (self.gamma + 0.5) ** 2

    def kinematics(self, h, q, v, a, abar, a1):
        """``(q1, v1, abar1)`` given the new true acceleration ``a1``."""
        am, af, g, b = self.alpha_m, self.alpha_f, self.gamma, self.beta
        abar1 = ((1.0 - af) * a1 + af * a - am * abar) / (1.0 - am)
        q1 = q + h * v + h**2 * ((0.5 - b) * abar + b * abar1)
        v1 = v + h * ((1.0 - g) * abar + g * abar1)
        return q1, v1, abar1

    def derivatives(self, h):
        """``(∂v/∂a, ∂q/∂a)`` of the step: the iteration matrix weights c_C and c_K."""
        s = (1.0 - self.alpha_f) / (1.0 - self.alpha_m)
        return h * self.gamma * s, h**2 * self.beta * s

    def error_estimate(self, h, a, a1):
        """Local error of q, Zienkiewicz-Xie: ``h²(β − 1/6)(a_{n+1} − a_n)``."""
        return h**2 * (self.beta - 1.0 / 6.0) * (a1 - a)


def hermite_interpolate(s, h, q0, v0, q1, v1):
    """Cubic Hermite interpolation of (q, v) at the fraction s ∈ [0, 1] of a step of size h."""
    s2, s3 = s * s, s * s * s
    q = (2 * s3 - 3 * s2 + 1) * q0 + (s3 - 2 * s2 + s) * h * v0 + (-2 * s3 + 3 * s2) * q1 + (s3 - s2) * h * v1
    v = (6 * s2 - 6 * s) / h * (q0 - q1) + (3 * s2 - 4 * s + 1) * v0 + (3 * s2 - 2 * s) * v1
    return q, v


__all__ = ["GeneralizedAlpha", "hermite_interpolate"]
