"""Constant coefficients of the reduced equations (THEORY §4, paper Appendix A).

Elastic: ``F_i(p) = f_i + K_ij p_j + L_ijk p_j p_k + N_ijkl p_j p_k p_l`` (Eq. 24, A-5), built by
jit-compiled einsum kernels accumulated element by element with ``lax.scan`` (memory O(Km⁴)
for N; κ is never assembled globally). L and N are stored symmetrised over their trailing
indices, which leaves F unchanged and makes the Jacobian ``K + 2 L p + 3 N p p``.

Inertia under prescribed rotation about e (from Eq. 41, ``E = I ⊗ ẽ``):
``Ī = ΨᵀMΨ, Ḡ = ΨᵀMEΨ, C̄ = ΨᵀMEEΨ, ḡ = ΨᵀMEq°, c̄ = ΨᵀMEEq°``.
"""

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jax import lax

from .._types import Array, Float, Int
from ..body import Body


class ElasticTensors(eqx.Module):
    """f, K, L, N of Eq. 24, with N also kept in packed symmetric forms for evaluation.

    ``N`` is symmetric in (j, k, l), so only the Km(Km+1)(Km+2)/6 distinct triples matter:
    ``N3`` holds them (multiplicities folded in) for the force alone. The force derives from the
    strain energy, so N is in fact symmetric in all four indices and the Jacobian's cubic part
    ``3 N p p`` is a symmetric matrix: ``N2u`` holds N on the Km(Km+1)/2 distinct (i, j) rows
    and (k, l) columns, and ``unpack`` maps a symmetric (i, j) back to its row. On the
    24-element beam with Km = 20 this makes the force 5× and the Jacobian 4× cheaper than
    contracting the full Km⁴ tensor (the contraction is memory-bound: 0.6 MB instead of 2.6).
    """

    f: Float[Array, " km"]
    K: Float[Array, "km km"]
    L: Float[Array, "km km km"]  # symmetric in (j, k)
    N: Float[Array, "km km km km"]  # symmetric in (j, k, l)
    N3: Float[Array, "km t3"]
    N2u: Float[Array, "t2 t2"]
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
        self.N3 = N[:, t3[0], t3[1], t3[2]] * mult3
        self.N2u = N[t2[0], t2[1]][:, t2[0], t2[1]] * mult2
        unpack = np.zeros((km, km), dtype=int)
        unpack[t2[0], t2[1]] = unpack[t2[1], t2[0]] = np.arange(t2.shape[1])
        self.unpack = jnp.asarray(unpack)

    def scaled(self, s) -> "ElasticTensors":
        """The tensors times ``s``: κ is linear in Young's modulus, so with the basis held fixed
        ``tensors(E) = (E / E0) · tensors(E0)``; differentiable in ``s``."""
        return eqx.tree_at(lambda t: (t.f, t.K, t.L, t.N, t.N3, t.N2u), self,
                           (s * self.f, s * self.K, s * self.L, s * self.N, s * self.N3, s * self.N2u))

    def force(self, p: Float[Array, " km"]) -> Float[Array, " km"]:
        """F(p) = f + K p + L p p + N p p p (Eq. 24)."""
        j, k, l = self.triples
        return self.f + self.K @ p + (self.L @ p) @ p + self.N3 @ (p[j] * p[k] * p[l])

    def force_and_jacobian(self, p: Float[Array, " km"]):
        """``(F(p), ∂F/∂p)`` (Eq. 25) sharing the contractions."""
        k, l = self.pairs
        Npp = (self.N2u @ (p[k] * p[l]))[self.unpack]  # N p p, symmetric
        # L p as a dot (faster than a broadcast sum, batched or not); the last product as an
        # elementwise sum, which XLA fuses with the additions around it.
        Lp = self.L @ p
        F = self.f + jnp.sum((self.K + Lp + Npp) * p, axis=1)  # f + (K + L p + N p p) p
        return F, self.K + 2.0 * Lp + 3.0 * Npp


def _fact(counts):
    out = 1
    for c in counts:
        out *= int(np.prod(np.arange(1, c + 1)))
    return out


class RotationInertia(eqx.Module):
    I: Float[Array, "km km"]
    G: Float[Array, "km km"]
    C: Float[Array, "km km"]
    g: Float[Array, " km"]
    c: Float[Array, " km"]


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
                     axis: Float[Array, " 3"]) -> RotationInertia:
    """Ī, Ḡ, C̄, ḡ, c̄ for rotation about the fixed unit ``axis`` (THEORY §4)."""
    km = Psi.shape[1]
    M = body.mass_matrix()
    P = Psi.reshape(body.n_vectors, 3, km)
    MP = jnp.einsum("ab,bkJ->akJ", M, P)  # (M ⊗ I3) Ψ
    e = axis
    EP = jnp.cross(e[None, :, None], P, axisa=1, axisb=1, axisc=1)  # e × ψ_β
    EEP = jnp.cross(e[None, :, None], EP, axisa=1, axisb=1, axisc=1)
    Eq = jnp.cross(e, q_eq)
    EEq = jnp.cross(e, Eq)
    inner = lambda A, B: jnp.einsum("akI,akJ->IJ", A, B)  # noqa: E731
    return RotationInertia(
        I=inner(MP, P), G=inner(MP, EP), C=inner(MP, EEP),
        g=jnp.einsum("akI,ak->I", MP, Eq), c=jnp.einsum("akI,ak->I", MP, EEq),
    )
