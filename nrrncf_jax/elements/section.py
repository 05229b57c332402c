"""Beam cross-sections: area properties and the quadratures the C1 beam integrates over them.

- ``TubeSection``: a hollow or solid circle; the continuum over it is exact (no warping);
- ``RectangleSection``: a solid rectangle, with Saint-Venant's torsion constant and a shear
  correction carried by a second quadrature for the shear strains (its docstring says why);
- ``sectional``: a section given by its stiffnesses (EA, EI_y, EI_z, GJ, GA_y, GA_z, ρA).

A section supplies ``quadrature()`` (axial, bending and mass integrals) and, where the shear
strains need their own, ``shear_quadrature()`` and ``shear_moduli_factors()``.
"""

import abc

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .. import _validate
from .._types import Array, Float, ScalarLike


class AbstractSection(eqx.Module):
    """What the C1 beam integrates over: ``quadrature()``, points (y, z) and weights of the
    section, and, where the shear strains need their own (torsion and shear corrections),
    ``shear_quadrature()`` with ``shear_moduli_factors()``; None by default, the continuum's own."""

    @abc.abstractmethod
    def quadrature(self) -> tuple[Float[Array, " ns"], Float[Array, " ns"], Float[Array, " ns"]]:
        """Points (y, z) and weights w with ``Σ w f(y, z) ≈ ∫_A f dA``."""

    def shear_quadrature(self):
        """The shear strains' quadrature, or None: ``quadrature``'s, with D's own shear moduli."""
        return None

    def shear_moduli_factors(self) -> Float[Array, " 3"]:
        """Factors on D's shear rows (2E23, 2E13, 2E12) over ``shear_quadrature``."""
        return jnp.ones(3)


class TubeSection(AbstractSection):
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


def rectangle_torsion_constant(width, height, terms: int = 50) -> float:
    """Saint-Venant's torsion constant of a solid ``width`` × ``height`` rectangle (Timoshenko &
    Goodier, §109): with a ≥ b the long and short sides,
    J = a b³/3 [1 − (192/π⁵)(b/a) Σ_{n odd} tanh(nπa/2b)/n⁵] (a square: 0.1406 a⁴)."""
    a, b = max(float(width), float(height)), min(float(width), float(height))
    n = np.arange(1, 2 * terms, 2, dtype=float)
    series = np.sum(np.tanh(n * np.pi * a / (2.0 * b)) / n**5)
    return a * b**3 / 3.0 * (1.0 - 192.0 / np.pi**5 * (b / a) * series)


class RectangleSection(AbstractSection):
    """A solid rectangle, ``width`` along the section's y and ``height`` along its z, with the
    torsion constant ``torsion_constant`` (default: Saint-Venant's, ``rectangle_torsion_constant``)
    and the transverse shear correction ``shear_factors`` (k_y, k_z: GA_y = k_y G A; default 5/6,
    the rectangle's classic value).

    **Why a section says more than its shape.** The C1 beam's section field is linear in (y, z):
    it has no warping, so the continuum over the rectangle twists with G·(I_y + I_z), the polar
    moment, which is 18.6 % stiffer than Saint-Venant's G·J for a square and far stiffer for a
    thin strip; and its transverse shear is uniform over the section (k = 1). The element
    therefore integrates the shear strains (Voigt rows 2E23, 2E13, 2E12) over a second quadrature
    (``shear_quadrature``): the same points with y scaled by c_y and z by c_z and the shear
    moduli by k (``shear_factors``, on 2E12 and 2E13), so that the transverse shear stiffness is
    k G A and the torsional stiffness G J exactly. In twist the two section vectors turn apart:
    2E13 = θ_y' y (r_y's turn) and 2E12 = −θ_z' z (r_z's), resisted by G k_z c_y² I_z and
    G k_y c_z² I_y (I_y = ∫z², I_z = ∫y²); each is made G J/2, so that a torque on the section
    frame turns both alike and the section does not distort in its plane (which the in-plane
    shear 2E23 would resist over a boundary layer, a compliance that grew under mesh
    refinement). Axial, bending and mass integrals keep the geometric quadrature (EA, EI and
    the inertia exact). Gauss-Legendre ``n`` × ``n`` points integrate the
    strain energy's polynomials in (y, z) (degree ≤ 4 a variable) exactly for n ≥ 3."""

    width: Float[Array, ""]
    height: Float[Array, ""]
    torsion_constant: Float[Array, ""]
    shear_factors: Float[Array, " 2"]
    n: int = eqx.field(static=True)

    def __init__(self, width: ScalarLike, height: ScalarLike | None = None, torsion_constant: ScalarLike | None = None,
                 shear_factors=(5.0 / 6.0, 5.0 / 6.0), n: int = 3):
        height = width if height is None else height
        _validate.positive("width", width)
        _validate.positive("height", height)
        self.width = jnp.asarray(width, dtype=float)
        self.height = jnp.asarray(height, dtype=float)
        if torsion_constant is None:
            if not (_validate.is_concrete(width) and _validate.is_concrete(height)):
                raise ValueError("a traced rectangle needs its torsion_constant given (the closed form is NumPy)")
            torsion_constant = rectangle_torsion_constant(float(width), float(height))
        _validate.positive("torsion_constant", torsion_constant)
        self.torsion_constant = jnp.asarray(torsion_constant, dtype=float)
        k = jnp.asarray(shear_factors, dtype=float).reshape(-1)
        if k.shape != (2,):
            raise ValueError(f"shear_factors must be two numbers (k_y, k_z), got {shear_factors!r}")
        if _validate.is_concrete(k) and not np.all(np.asarray(k) > 0):
            raise ValueError(f"shear_factors must be > 0, got {shear_factors!r}")
        self.shear_factors = k
        self.n = _validate.positive_int("n", n)

    @property
    def area(self) -> Float[Array, ""]:
        return self.width * self.height

    @property
    def second_moments(self) -> tuple[Float[Array, ""], Float[Array, ""]]:
        """(I_y, I_z) = (∫z² dA, ∫y² dA): bending about the section's y and z axes."""
        return self.width * self.height**3 / 12.0, self.height * self.width**3 / 12.0

    def quadrature(self):
        """Points (y, z) and weights w with ``Σ w f(y, z) = ∫_A f dA`` (Gauss-Legendre n × n)."""
        x, wx = np.polynomial.legendre.leggauss(self.n)
        y = 0.5 * self.width * jnp.asarray(x)
        z = 0.5 * self.height * jnp.asarray(x)
        w = 0.25 * self.width * self.height * jnp.asarray(np.outer(wx, wx).reshape(-1))
        return jnp.repeat(y, self.n), jnp.tile(z, self.n), w

    def shear_quadrature(self):
        """The quadrature of the shear strains: ``quadrature``'s points with y scaled by c_y and z
        by c_z, its weights unchanged (class docstring)."""
        y, z, w = self.quadrature()
        I_y, I_z = self.second_moments
        k_y, k_z = self.shear_factors[0], self.shear_factors[1]
        c_y = jnp.sqrt(0.5 * self.torsion_constant / (k_z * I_z))
        c_z = jnp.sqrt(0.5 * self.torsion_constant / (k_y * I_y))
        return c_y * y, c_z * z, w

    def shear_moduli_factors(self) -> Float[Array, " 3"]:
        """Factors on D's shear rows (2E23, 2E13, 2E12): 1 on the section's own shear, k_z, k_y."""
        return jnp.stack([jnp.ones(()), self.shear_factors[1], self.shear_factors[0]])


def sectional(EA, EI_y, EI_z, GJ, rhoA, GA_y=None, GA_z=None, nu: float = 0.3):
    """A section given by its stiffnesses, as MBDyn and Exudyn take it: ``(Material,
    RectangleSection)`` for ``beam_body``, whose C1 beam has the axial stiffness EA, the bending
    stiffnesses EI_y = E∫z² and EI_z = E∫y², the torsional stiffness GJ, the transverse shear
    stiffnesses GA_y, GA_z (default 5/6 G A) and the mass per length ρA. The equivalent rectangle
    has A = EA/E with E from its second moments' ratio to the area (width √(12 EI_z/EA), height
    √(12 EI_y/EA)), G = E/(2(1 + ν)), ρ = ρA/A; its rotary inertia ρ(I_y + I_z) is that of the
    same rectangle."""
    from .material import Material

    for name, value in (("EA", EA), ("EI_y", EI_y), ("EI_z", EI_z), ("GJ", GJ), ("rhoA", rhoA)):
        _validate.positive(name, value)
    EA, EI_y, EI_z, GJ, rhoA = (float(v) for v in (EA, EI_y, EI_z, GJ, rhoA))
    width, height = np.sqrt(12.0 * EI_z / EA), np.sqrt(12.0 * EI_y / EA)
    area = width * height
    E = EA / area
    G = E / (2.0 * (1.0 + nu))
    k = [5.0 / 6.0 if GA is None else float(GA) / (G * area) for GA in (GA_y, GA_z)]
    return Material(E, rhoA / area, nu), RectangleSection(width, height, torsion_constant=GJ / G, shear_factors=k)
