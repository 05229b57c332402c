"""Extended Craig-Bampton reduction of a body with joints (docs/theory.md, §7 Jointed bodies;
docs/multibody-theory.md, §Extended Craig-Bampton; paper Eqs. 44-46).

The body's free coordinates split into boundary ones B (those its joints act on) and interior
ones I. The deformation is

    w = [u_B; w_I] = [I; Φ_IB] u_B + [0; Ψ_I] p,        Φ_IB = −K_II⁻¹ K_IB,

u_B the boundary coordinates themselves (kept as coordinates of the reduced model), Φ_IB the
static constraint modes (the interior's static response to a unit displacement of each boundary
coordinate), and Ψ_I the interior basis: the vibration modes of (M_II, K_II), the fixed-interface
modes, and their modal derivatives, computed with the boundary held, deflated by SVD (Eq. 38).
The columns of the basis are [Φ_B | Ψ]: the first ``n_boundary`` reduced coordinates are the
boundary coordinates' displacements exactly (the interior columns vanish on B), and the reduced
cubic elastic force of the whole basis is ``reduction.elastic_tensors``'s, as for any basis.

With the boundary coordinates as coordinates, a joint's equations act on reduced coordinates
that are the joint node's own displacements; a static load on the boundary is reproduced
exactly (Guyan), and the interior modes need not bend to meet the joint.

The constraint modes' own modal derivatives (``boundary_mds``: θ_ab = −K_II⁻¹ (∂K/∂u_b Φ_a)_I for
every pair of constraint modes, and of a constraint mode with each fixed-interface mode, solved with
the boundary held as the interior's are) are the "static derivatives" of the extended basis of Wu &
Tiso (2016), beyond the interior-only list of docs/theory.md, §7 Jointed bodies. A body that bends
through its constraint modes (a rod moved at its joint) needs them: a transverse deflection
stretches the centre line to second order, the constraint modes carry no axial shortening to go with
it, and without their derivatives the basis locks, much as vibration modes without modal derivatives
do (the slider-crank's rod).
"""

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .._types import Array, Float
from ..bodies.body import Body
from .basis import modal_basis
from .modal_derivatives import modal_derivatives
from .modes import vibration_modes


class CraigBampton(eqx.Module):
    """The basis [Φ_B | Ψ] (n_dof × (n_boundary + k)), ``boundary`` the DOFs of its first
    columns (in order), and the fixed-interface modes' angular frequencies ``omega``."""

    basis: Float[Array, "ndof m"]
    boundary: tuple[int, ...] = eqx.field(static=True)
    omega: Float[Array, " k"]

    @property
    def n_boundary(self) -> int:
        return len(self.boundary)


def craig_bampton(body: Body, free, boundary, n_vms: int, pairs="all", q_eq=None, deflate_tol: float = 1e-6,
                  boundary_mds: bool = True) -> CraigBampton:
    """The extended Craig-Bampton basis of ``body`` at ``q_eq`` (default its reference): ``free``
    (n_dof booleans) the coordinates not held by its reference conditions, ``boundary`` the free
    DOFs (indices) its joints act on, ``n_vms`` fixed-interface vibration modes and their modal
    derivatives for ``pairs`` (``"all"``: every i ≤ j; a list of (i, j), e.g. from
    ``reduction.select``'s maximum modal interaction; or ``[]``). ``boundary_mds``: the
    constraint modes' modal derivatives too, with each other and with the fixed-interface modes
    (module docstring), deflated with the interior's columns.

    Raises ``ValueError`` for a boundary DOF that is not free or is repeated, and (through
    ``vibration_modes``) when the interior's stiffness is singular.
    """
    free = np.asarray(free, dtype=bool).reshape(-1)
    if free.shape[0] != body.n_dof:
        raise ValueError(f"free must have one entry per DOF ({body.n_dof}), got {free.shape[0]}")
    boundary = tuple(int(b) for b in np.asarray(boundary, dtype=int).reshape(-1))
    if len(set(boundary)) != len(boundary):
        raise ValueError(f"boundary DOFs must be distinct, got {boundary}")
    if any(not 0 <= b < body.n_dof or not free[b] for b in boundary):
        raise ValueError("boundary DOFs must be free coordinates of the body (not held by its reference "
                         f"conditions), got {boundary}")
    q_eq = body.q_hat if q_eq is None else q_eq
    interior = free.copy()
    interior[list(boundary)] = False
    modes = vibration_modes(body, jnp.asarray(interior), n_vms, q_eq=q_eq)
    pairs = [(i, j) for i in range(n_vms) for j in range(i, n_vms)] if pairs == "all" else [tuple(p) for p in pairs]
    # Φ_IB = −K_II⁻¹ K_IB: the interior's static response to unit boundary displacements.
    K = np.asarray(body.stiffness_matrix(q_eq))
    I, B = np.flatnonzero(interior), np.asarray(boundary, dtype=int)
    Phi_B = np.zeros((body.n_dof, len(B)))
    Phi_B[B, np.arange(len(B))] = 1.0
    if len(B):
        Phi_B[I] = -np.linalg.solve(K[np.ix_(I, I)], K[np.ix_(I, B)])
    extra = ()
    if boundary_mds and len(B):  # θ of (constraint, constraint) and (constraint, fixed-interface) pairs
        both = np.concatenate([Phi_B, np.asarray(modes.phi)], axis=1)
        nb = len(B)
        extra = (np.asarray(modal_derivatives(body, jnp.asarray(interior), jnp.asarray(both),
                                              [(a, b) for a in range(nb) for b in range(a, nb + n_vms)],
                                              q_eq=q_eq).theta),)
    Psi = np.array(modal_basis(body, jnp.asarray(interior), modes.phi, pairs, q_eq=q_eq, deflation_tol=deflate_tol,
                               extra=extra).Psi)
    Psi[~interior] = 0.0  # the SVD's round-off (1e-17) off the interior: the boundary rows are u_B's alone
    return CraigBampton(basis=jnp.asarray(np.concatenate([Phi_B, Psi], axis=1)), boundary=boundary,
                        omega=modes.omega)


def attachment_modes(body: Body, free, loads, q_eq=None) -> np.ndarray:
    """The static deflections of ``body`` at ``q_eq`` (default its reference), held on its
    reference conditions (``free``'s complement), under each column of ``loads`` (n_dof × m
    generalized forces, zero where the body is held): K_ff⁻¹ F, the attachment modes of those
    loads (a unit force on a coordinate, ``static_modes``; a moment on a node's section,
    ``multibody.reduce``'s ``interface_rotations``)."""
    free = np.asarray(free, dtype=bool).reshape(-1)
    F = np.asarray(loads, dtype=float).reshape(body.n_dof, -1)
    if np.abs(F[~free]).max(initial=0.0) > 0:
        raise ValueError("attachment_modes: a load acts on coordinates the reference conditions hold")
    K = np.asarray(body.stiffness_matrix(body.q_hat if q_eq is None else q_eq))[np.ix_(free, free)]
    psi = np.zeros_like(F)
    psi[free] = np.linalg.solve(K, F[free])
    return psi


def static_modes(body: Body, free, dofs, q_eq=None) -> np.ndarray:
    """The static deflections of ``body`` at ``q_eq`` (default its reference), held on its
    reference conditions (``free``'s complement), under a unit force on each of the free
    coordinates ``dofs`` (n_dof × len(dofs)): the attachment modes of those coordinates, K_ff⁻¹
    on unit loads. Kept as basis vectors beside a body's vibration modes (``multibody.reduce``'s
    ``interface_modes``), they span the same space as the static constraint modes Φ_B of
    ``craig_bampton`` (Eq. 45) for boundary ``dofs``, without making the boundary coordinates
    coordinates of the reduced model."""
    free = np.asarray(free, dtype=bool).reshape(-1)
    dofs = np.asarray(dofs, dtype=int).reshape(-1)
    if any(not 0 <= d < body.n_dof or not free[d] for d in dofs):
        raise ValueError(f"static_modes: the loaded DOFs must be free coordinates of the body, got {dofs.tolist()}")
    F = np.zeros((body.n_dof, len(dofs)))
    F[dofs, np.arange(len(dofs))] = 1.0
    return attachment_modes(body, free, F, q_eq)


__all__ = ["CraigBampton", "attachment_modes", "craig_bampton", "static_modes"]
