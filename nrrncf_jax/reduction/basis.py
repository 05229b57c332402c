"""The NR-RNCF reduction basis (docs/theory.md, §5 Vibration modes and modal derivatives and §6
Selecting the basis; paper Algorithm 1): vibration modes, their modal derivatives and any further
columns, concatenated and deflated by SVD.

``X = [Φ_vms, Θ_pairs, E_1, E_2, ...]`` (n_dof × s): the kept vibration modes φ_i (Eqs. 26-28),
the static modal derivatives θ_ij = −K|eq⁻¹ (∂K/∂η_j) φ_i of the chosen pairs (Eqs. 33-36) and
extra columns E (a joint's static modes, the spinning-state vectors), in that order. The basis
is ``Ψ = deflate(X)`` (Algorithm 1: the left singular vectors of X with normalised columns
whose singular values exceed ϑ σ₁), or ``Ψ = X T`` with a fixed deflation map T (``deflation_map``)
where Ψ must stay a smooth function of the model's parameters.

Built from concrete values the columns are glued together in NumPy: slicing and concatenating
JAX arrays outside a ``jit`` compiles a kernel for every operation and shape on a cold start.
Inside a trace (the differentiable offline path, ``studies.families``) they are JAX arrays.
"""

import dataclasses
import functools

import jax.numpy as jnp
import numpy as np

from .._types import Array, Bool, Float
from .._validate import is_concrete
from ..bodies.body import Body
from .deflation import deflate, deflation_map
from .modal_derivatives import modal_derivatives


@dataclasses.dataclass(frozen=True)
class ModalBasis:
    """The columns ``X = [Φ_vms, Θ_pairs, extra]`` of a reduction basis (``columns``, n_dof × s:
    ``n_vms`` vibration modes, ``n_mds`` modal derivatives, then the extra columns) and their SVD
    deflation ``Psi`` (computed when first asked for, with ``deflation_tol``)."""

    columns: Float[Array, "ndof s"]
    n_vms: int
    n_mds: int
    deflation_tol: float = 1e-6

    @property
    def theta(self) -> Float[Array, "ndof n_mds"] | None:
        """The modal-derivative columns, in the order of the pairs (None without pairs)."""
        return self.columns[:, self.n_vms: self.n_vms + self.n_mds] if self.n_mds else None

    @functools.cached_property
    def Psi(self) -> Float[Array, "ndof km"]:
        """``deflate(X, deflation_tol)``: the orthonormal basis Ψ of Algorithm 1 (concrete columns only)."""
        return deflate(self.columns, self.deflation_tol)

    def deflation_map(self, km: int | None = None) -> np.ndarray:
        """``T = diag(1/‖x_j‖) V_r Σ_r⁻¹`` (s × km) with ``X T`` the first ``km`` columns of
        ``Psi`` (default: all of them). It comes from the same SVD as ``Psi`` (``reduction.deflation``),
        so ``X T`` reproduces Ψ column signs included: a map from any other factorisation would
        give the same span with other signs, and the reduced coordinates would not match."""
        return deflation_map(self.columns, self.Psi.shape[1] if km is None else km)


def modal_basis(body: Body, free: Bool[Array, " ndof"], phi: Float[Array, "ndof k"], pairs=(), *, vms=None,
                extra=(), theta: Float[Array, "ndof npairs"] | None = None, md_method: str = "closed_form",
                pad_to: int | None = None, q_eq: Float[Array, "n 3"] | None = None,
                deflation_tol: float = 1e-6) -> ModalBasis:
    """The NR-RNCF basis of ``body`` from its vibration modes ``phi`` (mass-normalised columns,
    zero on the constrained coordinates, ``free`` the others).

    ``vms``: the indices of the modes kept as columns (default: all of ``phi``, in order).
    ``pairs``: the (i, j) of the modal derivatives θ_ij of the modes ``phi`` (indices into
    ``phi``, not into ``vms``), computed by ``modal_derivatives`` (``md_method``, ``pad_to``,
    about ``q_eq``, default the reference configuration) unless ``theta`` (n_dof × len(pairs),
    in the order of ``pairs``) holds them already. ``extra``: further column blocks (n_dof × m
    each), appended in order. ``deflation_tol``: ϑ of Algorithm 1 for ``ModalBasis.Psi``.

    Returns the ``ModalBasis`` of ``X = [Φ_vms, Θ_pairs, extra]``. Differentiable with respect
    to ``phi``, ``theta``, ``extra`` and the body when traced (``ModalBasis.columns`` then is
    a JAX array; use it with a fixed ``deflation_map``, the SVD's rank being a discrete choice).
    """
    pairs = tuple((int(i), int(j)) for i, j in pairs)
    k = phi.shape[1]
    vms = None if vms is None else [int(i) for i in vms]
    if vms is not None and any(not 0 <= i < k for i in vms):
        raise ValueError(f"mode index out of range in vms (have {k} modes): {vms}")
    if theta is None and pairs:
        theta = modal_derivatives(body, free, phi, pairs, q_eq=q_eq, method=md_method, pad_to=pad_to).theta
    if theta is not None and tuple(theta.shape) != (phi.shape[0], len(pairs)):
        raise ValueError(f"theta must hold the {len(pairs)} modal derivatives of pairs as columns of "
                         f"{phi.shape[0]} coordinates, got shape {tuple(theta.shape)}")
    blocks = [phi] + ([theta] if pairs else []) + list(extra)
    if all(is_concrete(b) for b in blocks):
        blocks = [np.asarray(b) for b in blocks]
        concatenate = np.concatenate
    else:
        blocks = [jnp.asarray(b) for b in blocks]
        concatenate = jnp.concatenate
    if vms is not None:
        blocks[0] = blocks[0][:, vms]
    return ModalBasis(columns=concatenate(blocks, axis=1), n_vms=blocks[0].shape[1], n_mds=len(pairs),
                      deflation_tol=deflation_tol)
