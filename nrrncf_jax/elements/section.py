"""Beam cross-sections: area properties and the quadrature used to integrate over them."""

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .. import _validate
from .._types import Array, Float, ScalarLike


class TubeSection(eqx.Module):
    """Hollow circular section (a solid circle when ``r_inner = 0``).

    Integrals over the section use polar quadrature: Gauss-Legendre in the radius (weight r dr)
    and the trapezoidal rule in the angle, which is exact for the trigonometric polynomials that
    the beam's (y, z)-polynomial integrands become (degree < ``n_theta``).
    """

    r_outer: Float[Array, ""]
    r_inner: Float[Array, ""]
    n_r: int = eqx.field(static=True)
    n_theta: int = eqx.field(static=True)

    def __init__(self, r_outer: ScalarLike, r_inner: ScalarLike = 0.0, n_r: int = 3, n_theta: int = 8):
        _validate.positive("r_outer (outer radius)", r_outer)
        _validate.non_negative("r_inner (inner radius)", r_inner)
        if _validate.is_concrete(r_outer) and _validate.is_concrete(r_inner):
            if float(r_inner) >= float(r_outer):
                raise ValueError(
                    f"inner radius must be smaller than outer radius, got r_inner={float(r_inner)!r}"
                    f" >= r_outer={float(r_outer)!r}"
                )
        self.r_outer = jnp.asarray(r_outer, dtype=float)
        self.r_inner = jnp.asarray(r_inner, dtype=float)
        self.n_r = _validate.positive_int("n_r", n_r)
        self.n_theta = _validate.positive_int("n_theta", n_theta)

    @property
    def area(self) -> Float[Array, ""]:
        return jnp.pi * (self.r_outer**2 - self.r_inner**2)

    @property
    def second_moment(self) -> Float[Array, ""]:
        """I_yy = I_zz."""
        return jnp.pi / 4.0 * (self.r_outer**4 - self.r_inner**4)

    def quadrature(self) -> tuple[Float[Array, " ns"], Float[Array, " ns"], Float[Array, " ns"]]:
        """Points (y, z) and weights w with ``Σ w f(y, z) ≈ ∫_A f dA``."""
        x, wx = np.polynomial.legendre.leggauss(self.n_r)
        a, b = self.r_inner, self.r_outer
        r = 0.5 * (b - a) * jnp.asarray(x) + 0.5 * (a + b)
        wr = 0.5 * (b - a) * jnp.asarray(wx) * r
        th = 2.0 * jnp.pi * jnp.arange(self.n_theta) / self.n_theta
        wth = 2.0 * jnp.pi / self.n_theta
        y = (r[:, None] * jnp.cos(th)[None, :]).reshape(-1)
        z = (r[:, None] * jnp.sin(th)[None, :]).reshape(-1)
        w = (wr[:, None] * wth * jnp.ones_like(th)[None, :]).reshape(-1)
        return y, z, w
