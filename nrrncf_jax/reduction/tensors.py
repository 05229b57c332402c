"""Constant coefficients of the reduced equations (docs/theory.md, §4 Reduction; paper Appendix A).

Elastic: ``F_i(p) = f_i + K_ij p_j + L_ijk p_j p_k + N_ijkl p_j p_k p_l`` (Eq. 24, A-5), built by
jit-compiled einsum kernels accumulated element by element with ``lax.scan`` (memory O(Km⁴)
for N; κ is never assembled globally). L and N are stored symmetrised over their trailing
indices, which leaves F unchanged and makes the Jacobian ``K + 2 L p + 3 N p p``.

Inertia under prescribed rotation about e (from Eq. 41, ``E = I ⊗ ẽ``):
``Ī = ΨᵀMΨ, Ḡ = ΨᵀMEΨ, C̄ = ΨᵀMEEΨ, ḡ = ΨᵀMEq°, c̄ = ΨᵀMEEq°``.
"""

from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jax import lax

from .._types import Array, Float, Int
from ..bodies.body import DENSE_MASS_MAX_VECTORS, Body


class ElasticTensors(eqx.Module):
    """f, K, L, N of Eq. 24, with L and N also kept in packed forms for evaluation.

    ``N`` is symmetric in (j, k, l), so only the Km(Km+1)(Km+2)/6 distinct triples matter:
    ``N3`` holds them (multiplicities folded in) for the force alone. The force derives from the
    strain energy, so N is in fact symmetric in all four indices and the Jacobian's cubic part
    ``3 N p p`` is a symmetric matrix: ``N2u`` holds N on the Km(Km+1)/2 distinct (k, l) rows
    and (i, j) columns, and ``unpack`` maps a symmetric (i, j) back to its column. The contraction
    is memory-bound, so reading about a sixth (force) or a quarter (Jacobian) of the Km⁴ entries
    makes it that much cheaper.

    The packed forms (and ``L_rows``, L with its contracted index first) put the index that is
    summed over on their rows: the contractions are a row vector times a matrix, ``x @ A``.
    Under ``vmap`` over bodies that share the tensors (a chain of equal beams) or over a batch,
    XLA's CPU backend runs that as one matrix product of the stacked rows, where ``A @ x`` became
    a product with the matrix's transpose that runs at a fraction of the speed.
    """

    full_order: ClassVar[bool] = False
    """A reduced force (NR-RNCF), not the elements' own."""

    f: Float[Array, " km"]
    K: Float[Array, "km km"]
    L: Float[Array, "km km km"]  # symmetric in (j, k)
    N: Float[Array, "km km km km"]  # symmetric in (j, k, l)
    L_rows: Float[Array, "km km2"]  # L_rows[k, i km + j] = L_ijk
    N3: Float[Array, "t3 km"]
    N2u: Float[Array, "t2 t2"]  # (k, l) rows, (i, j) columns
    triples: Int[Array, "3 t3"]
    pairs: Int[Array, "2 t2"]
    unpack: Int[Array, "km km"]

    def __init__(self, f, K, L, N):
        km = f.shape[0]
        self.f, self.K, self.L, self.N = f, K, L, N
        t3 = np.array([(j, k, l) for j in range(km) for k in range(j, km) for l in range(k, km)]).reshape(-1, 3).T
        mult3 = np.array([6 // (_fact(np.unique(t, return_counts=True)[1])) for t in t3.T])
        t2 = np.array([(k, l) for k in range(km) for l in range(k, km)]).reshape(-1, 2).T
        mult2 = np.where(t2[0] == t2[1], 1.0, 2.0)
        self.triples = jnp.asarray(t3, dtype=int)
        self.pairs = jnp.asarray(t2, dtype=int)
        self.L_rows = L.reshape(km * km, km).T
        self.N3 = (N[:, t3[0], t3[1], t3[2]] * mult3).T
        self.N2u = (N[t2[0], t2[1]][:, t2[0], t2[1]] * mult2).T
        unpack = np.zeros((km, km), dtype=int)
        unpack[t2[0], t2[1]] = unpack[t2[1], t2[0]] = np.arange(t2.shape[1])
        self.unpack = jnp.asarray(unpack)

    @property
    def n_coordinates(self) -> int:
        return int(self.f.shape[0])

    def scaled(self, s) -> "ElasticTensors":
        """The tensors times ``s``: κ is linear in Young's modulus, so with the basis held fixed
        ``tensors(E) = (E / E0) · tensors(E0)``; differentiable in ``s``."""
        return eqx.tree_at(lambda t: (t.f, t.K, t.L, t.N, t.L_rows, t.N3, t.N2u), self,
                           (s * self.f, s * self.K, s * self.L, s * self.N, s * self.L_rows, s * self.N3,
                            s * self.N2u))

    def _Lp(self, p: Float[Array, " km"]) -> Float[Array, "km km"]:
        """L p (contracted over L's last index)."""
        km = p.shape[0]
        return (p @ self.L_rows).reshape(km, km)

    def _Nppp(self, p: Float[Array, " km"]) -> Float[Array, " km"]:
        """N p p p over the distinct triples."""
        j, k, l = self.triples
        return _plain_operand(p[j] * p[k] * p[l]) @ self.N3

    def force(self, p: Float[Array, " km"]) -> Float[Array, " km"]:
        """F(p) = f + K p + L p p + N p p p (Eq. 24)."""
        return self.f + self.K @ p + self._Lp(p) @ p + self._Nppp(p)

    def energy(self, p: Float[Array, " km"]) -> Float[Array, ""]:
        """The strain energy U(p) − U(0) = p·(f + K p / 2 + L p p / 3 + N p p p / 4), whose
        gradient is ``force`` (κ constant: U is a quartic polynomial in p, and its terms of degree
        d are p·(their force)/d). Exact, not an approximation of the reduced model's energy: equal
        to the body's element strain energy at q̂ + Ψp, minus its value at q̂ (round-off,
        ``tests/test_floating.py``), for a few contractions instead of every element's quadrature."""
        return p @ (self.f + self.K @ p / 2.0 + self._Lp(p) @ p / 3.0 + self._Nppp(p) / 4.0)

    def force_and_jacobian(self, p: Float[Array, " km"]):
        """``(F(p), ∂F/∂p)`` (Eq. 25) sharing the contractions."""
        k, l = self.pairs
        Npp = (_plain_operand(p[k] * p[l]) @ self.N2u)[self.unpack]  # N p p, symmetric
        # L p as a dot (faster than a broadcast sum, batched or not); the last product as an
        # elementwise sum, which XLA fuses with the additions around it.
        Lp = self._Lp(p)
        F = self.f + jnp.sum((self.K + Lp + Npp) * p, axis=1)  # f + (K + L p + N p p) p
        return F, self.K + 2.0 * Lp + 3.0 * Npp


def _plain_operand(x):
    """x through ``lax.optimization_barrier``, for the product that reads it. Under ``vmap`` the
    gathered products p_j p_k (p_l) come out with the batch axis innermost, and XLA's CPU backend,
    left to itself, folds that layout into the product (it contracts the operand's first axis),
    which then runs at a fraction of a plain product's speed. The barrier (removed again before
    code generation) keeps the layout change a small copy of its own and the product a plain one."""
    return lax.optimization_barrier(x)


def _fact(counts):
    out = 1
    for c in counts:
        out *= int(np.prod(np.arange(1, c + 1)))
    return out


class RotationInertia(eqx.Module):
    """The reduced inertia of a frame rotating with ω = Σ_k w_k b_k, for the directions b_k (the
    columns of the motion's ``directions``; one for a fixed axis) (docs/theory.md, §4 Reduction):

        Ī = Ψᵀ(M⊗I)Ψ,  Ḡ_k = Ψᵀ(M⊗b̃_k)Ψ,  C̄_kl = Ψᵀ(M⊗b̃_k b̃_l)Ψ,
        ḡ_k = Ψᵀ(M⊗b̃_k)q°,  c̄_kl = Ψᵀ(M⊗b̃_k b̃_l)q°,

    so that Ψᵀ M (2ω̃ q̇ + (ω̇̃ + ω̃ω̃) q) = Σ_k Ḡ_k(2w_k ṗ + ẇ_k p) + Σ_kl w_k w_l C̄_kl p + ẇ_k ḡ_k + ..."""

    I: Float[Array, "km km"]
    G: Float[Array, "d km km"]
    C: Float[Array, "d d km km"]
    g: Float[Array, "d km"]
    c: Float[Array, "d d km"]

    def forces(self, w, wd, p, v):
        """``(Σ_k Ḡ_k ⊙ (2w_k v + ẇ_k p) + Σ_kl C̄_kl ⊙ (w_k w_l p),  Σ_k ẇ_k ḡ_k + Σ_kl w_k w_l c̄_kl)``:
        the rotation's velocity-dependent inertia as (km × km) elementwise products, for the caller
        to add to ``Ī ⊙ a`` and sum along rows (XLA fuses these with the rest of the residual; on
        a small model each separate kernel costs a dispatch), and its constant load."""
        d = self.G.shape[0]
        mats, loads = [], []
        for k in range(d):
            mats.append(self.G[k] * (2.0 * w[k] * v + wd[k] * p))
            loads.append(wd[k] * self.g[k])
        for k in range(d):
            for m in range(d):
                ww = w[k] * w[m]
                mats.append(self.C[k, m] * (ww * p))
                loads.append(ww * self.c[k, m])
        return mats, loads

    def tangent(self, w, wd, c_C, c_K, J):
        """``(c_C Σ_k 2w_k Ḡ_k,  c_K (J + Σ_k ẇ_k Ḡ_k + Σ_kl w_k w_l C̄_kl))``: the rotation's part of
        the iteration matrix (the reduced 2ω̃ and ω̇̃ + ω̃ω̃ terms), with the elastic tangent J."""
        d = self.G.shape[0]
        vel = sum_terms([c_C * 2.0 * w[k] * self.G[k] for k in range(d)])
        pos = [J] + [wd[k] * self.G[k] for k in range(d)]
        pos += [(w[k] * w[m]) * self.C[k, m] for k in range(d) for m in range(d)]
        return vel, c_K * sum_terms(pos)


def sum_terms(terms):
    """x₀ + x₁ + … left to right (0.0 for no terms)."""
    if not terms:
        return 0.0
    out = terms[0]
    for x in terms[1:]:
        out = out + x
    return out


def _sym_jk(L):
    return 0.5 * (L + L.transpose(0, 2, 1))


def _sym_jkl(N):
    perms = [(0, 1, 2, 3), (0, 1, 3, 2), (0, 2, 1, 3), (0, 2, 3, 1), (0, 3, 1, 2), (0, 3, 2, 1)]
    return sum(N.transpose(p) for p in perms) / 6.0


@eqx.filter_jit
def elastic_tensors(body: Body, q_eq: Float[Array, "n 3"], Psi: Float[Array, "ndof km"]) -> ElasticTensors:
    """f, K, L, N of Appendix A-5 for the basis Ψ about q° (element-by-element accumulation)."""
    km = Psi.shape[1]
    P = Psi.reshape(body.n_vectors, 3, km)

    def element(acc, x):
        idx, kap = x
        ne = idx.shape[0]
        kap = kap.reshape(ne * ne, ne * ne)
        q0, qh, Pe = q_eq[idx], body.q_hat[idx], P[idx]  # (ne, 3), (ne, 3), (ne, 3, km)
        Q0 = 0.5 * (q0 @ q0.T - qh @ qh.T)  # Q°_μν
        theta = kap @ Q0.reshape(-1)  # Θ_αβ = κ^{αβμν} Q°_μν
        Xh = jnp.einsum("mkI,nk->Imn", Pe, q0)
        X = (0.5 * (Xh + Xh.transpose(0, 2, 1))).reshape(km, -1)  # X^i_μν
        Yh = jnp.einsum("mkI,nkJ->IJmn", Pe, Pe)
        Y = (0.5 * (Yh + Yh.transpose(0, 1, 3, 2))).reshape(km * km, -1)  # Y^{ij}_μν
        KX = X @ kap  # (κ X^i)_μν (κ is symmetric under pair exchange)
        f = X @ theta  # f_i = Θ_αβ X^i_αβ
        K = (Y @ theta).reshape(km, km) + X @ KX.T  # K_ij = Θ:Y^{ij} + X^i:κ:X^j
        Z = (Y @ KX.T).reshape(km, km, km)  # Z_ijk = Y^{ij}:κ:X^k
        L = 0.5 * (Z + Z.transpose(1, 2, 0) + Z.transpose(2, 0, 1))  # Y^{ij}X^k + Y^{jk}X^i + Y^{ki}X^j
        N = 0.5 * ((Y @ kap) @ Y.T).reshape(km, km, km, km)  # N_ijkl = ½ Y^{ij}:κ:Y^{kl}
        return jax_tree_add(acc, (f, K, L, N)), None

    acc = (jnp.zeros(km), jnp.zeros((km, km)), jnp.zeros((km,) * 3), jnp.zeros((km,) * 4))
    for g in body.groups:  # one scan over the elements of each group
        acc, _ = lax.scan(element, acc, (g.elements, g.kappa))
    f, K, L, N = acc
    return ElasticTensors(f=f, K=K, L=_sym_jk(L), N=_sym_jkl(N))


def jax_tree_add(a, b):
    return tuple(x + y for x, y in zip(a, b))


@eqx.filter_jit
def rotation_inertia(body: Body, q_eq: Float[Array, "n 3"], Psi: Float[Array, "ndof km"],
                     directions: Float[Array, "3 d"]) -> RotationInertia:
    """Ī, Ḡ_k, C̄_kl, ḡ_k, c̄_kl for rotation about the unit ``directions`` b_k (3 × d; a fixed
    axis e is ``e[:, None]``) (docs/theory.md, §4 Reduction; ``RotationInertia``)."""
    km = Psi.shape[1]
    P = Psi.reshape(body.n_vectors, 3, km)
    if body.n_vectors <= DENSE_MASS_MAX_VECTORS:
        MP = jnp.einsum("ab,bkJ->akJ", body.mass_matrix(), P)  # (M ⊗ I3) Ψ
    else:
        MP = body.mass_product(P)
    B = jnp.asarray(directions, dtype=float).reshape(3, -1)
    d = B.shape[1]
    cross = lambda e, X: jnp.cross(e[None, :, None], X, axisa=1, axisb=1, axisc=1)  # noqa: E731
    inner = lambda A, X: jnp.einsum("akI,akJ->IJ", A, X)  # noqa: E731
    EP = [cross(B[:, k], P) for k in range(d)]  # b_k × ψ_β
    Eq = [jnp.cross(B[:, k], q_eq) for k in range(d)]
    stack = lambda xs, shape: jnp.stack(xs) if xs else jnp.zeros(shape)  # noqa: E731  (d = 0: no rotation)
    return RotationInertia(
        I=inner(MP, P),
        G=stack([inner(MP, EP[k]) for k in range(d)], (0, km, km)),
        C=stack([jnp.stack([inner(MP, cross(B[:, k], EP[m])) for m in range(d)]) for k in range(d)], (0, 0, km, km)),
        g=stack([jnp.einsum("akI,ak->I", MP, Eq[k]) for k in range(d)], (0, km)),
        c=stack([jnp.stack([jnp.einsum("akI,ak->I", MP, jnp.cross(B[:, k], Eq[m])) for m in range(d)])
                 for k in range(d)], (0, 0, km)),
    )
