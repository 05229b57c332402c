"""Free-floating reference frames with reduced deformation: NR-RNCF for jointed systems
(docs/theory.md, §3 Equations of motion of one body, Eqs. 4-6; docs/multibody-theory.md, §The RNCF
frame; paper Sec. 4.4).

Each body b has a reference frame, origin R_b and orientation from Euler parameters e_b, and its
deformation in that frame reduced to a basis, w_b = Ψ_b p_b (vibration modes and modal
derivatives, zero on the body's reference conditions). Its nodal vectors in the inertial frame:

    position vectors   x_α = R + Â(e) (q̂_α + w_α),      gradient vectors   x_α = Â(e) (q̂_α + w_α),

x_b = f_b(z_b) with z_b = (R_b, e_b, p_b) (3 + 4 + k coordinates), Â(e) = (e0² − ēᵀē) I + 2 ē ēᵀ
+ 2 e0 ẽ the rotation matrix written as a quadratic form in e (a rotation exactly when |e| = 1,
which is one more constraint per body). The joints (``joints``) act on x = f(z) as in the full
system. With M_b constant in the inertial nodal vectors, Lagrange's equations of the map are

    J_bᵀ (M_b ẍ_b − Q_b) + ∂U_b/∂z_b + C_zᵀ λ = 0,    ẍ_b = J_b z̈_b + J̇_b ż_b,    J_b = ∂f_b/∂z_b,

and the strain energy U_b depends on p_b alone (it is invariant under the frame's motion): its
gradient is the reduced cubic force f + K p + L p p + N p p p of Eq. 24 (``reduction.tensors``).
These are Eqs. 4-6 (translation, rotation, deformation) written in one piece.

Choices, and why:

- **Euler parameters** for the orientation, with |e_b|² = 1 as one more constraint per body: no
  singular orientation (a rotation vector is singular at |ψ| = 2π, Euler angles at gimbal lock),
  and Â is quadratic in e, so J, J̇ż and their derivatives are polynomials with constant
  coefficients (``_B``). Off |e| = 1, Â scales the body; the constraint's reaction (its row is
  2eᵀ) takes the strain energy's part along e, so the equations hold on the constraint.
- **Inertia in closed form** from the map: J ᵀF, J z̈ and J̇ż as a few small products with u =
  q̂ + Ψ p (``FloatingBody.tangent``/``acceleration``/``generalized``: the cost grows linearly
  with the full body's size, products with the constant M_b), and the mass matrix M_z from the
  paper's precomputed inertia invariants (``FloatingBody.mass_matrix``: 3 × 3 × k × k products,
  tested against J ᵀM J). J itself is formed only for the joints' rows. Bodies of one structure
  (a chain of equal beams) are evaluated in one ``vmap``: on a CPU the time of these small models
  is per XLA operation. The elastic force, the costly part at full order, is the reduced cubic
  one.
- The iteration matrix is block-diagonal, one dense block a body (z_b has a few tens of
  coordinates): the mass matrix J ᵀM J and the reduced elastic stiffness K + 2Lp + 3Npp, and,
  in the index-3 step, the inertia terms' derivatives with respect to p and ṗ in closed form
  (``FloatingBody.deformation_tangent``: the frame's angular acceleration, centrifugal and
  Coriolis terms on the deformation, and J_e's change with p against the body's forces). Those
  with respect to the frame's coordinates and the rest of the joints' Hessian are left to
  Newton's iterations. The p columns make modified Newton contract faster, on the full-order
  pendulum (frames on the left ends' tangents, ``scenarios.pendulum.LEFT_END_FRAME``) and on the
  reduced one. The constrained matrix is factored body by body with the joints' Schur complement
  (``factor_augmented``).
- ``project_velocities``: the index-3 step (``integrate.GeneralizedAlphaIndex3``) projects ż onto
  C_z ż = 0 after each step. Without it the frames' accelerations oscillate from step to step
  (the O(h) velocity-constraint violation that index 3 leaves), which the step-size control
  reads as error: it takes needlessly small steps, and with ρ∞ = 1, which leaves the
  oscillation undamped, stalls (``integrate.index3``).
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._types import Array, Float
from ..bodies.body import Body, stiffened
from ..linalg.contract import contract
from ..reduction.tensors import ElasticTensors
from .kinds import AbstractBodyKind
from .markers import BodyGeometry


def rotation(e: Float[Array, " 4"]) -> Float[Array, "3 3"]:
    """The rotation matrix of the Euler parameters e = (e0, e1, e2, e3), normalised first:
    A = (e0² − ēᵀē) I + 2 ē ēᵀ + 2 e0 ẽ, divided by |e|²."""
    e0, eb = e[0], e[1:]
    skew = jnp.array([[0.0, -eb[2], eb[1]], [eb[2], 0.0, -eb[0]], [-eb[1], eb[0], 0.0]])
    A = (e0**2 - eb @ eb) * jnp.eye(3) + 2.0 * jnp.outer(eb, eb) + 2.0 * e0 * skew
    return A / (e @ e)


def euler_parameters(A) -> np.ndarray:
    """Euler parameters (e0 ≥ 0) of a proper rotation matrix (host-side, for initial states)."""
    A = np.asarray(A, dtype=float)
    if A.shape != (3, 3) or not np.allclose(A.T @ A, np.eye(3), atol=1e-10) or np.linalg.det(A) < 0:
        raise ValueError("the frame's orientation must be a proper 3 × 3 rotation matrix")
    w, V = np.linalg.eigh(np.array([  # the largest eigenvector of Bar-Itzhack's symmetric matrix
        [A[0, 0] + A[1, 1] + A[2, 2], A[2, 1] - A[1, 2], A[0, 2] - A[2, 0], A[1, 0] - A[0, 1]],
        [A[2, 1] - A[1, 2], A[0, 0] - A[1, 1] - A[2, 2], A[0, 1] + A[1, 0], A[0, 2] + A[2, 0]],
        [A[0, 2] - A[2, 0], A[0, 1] + A[1, 0], A[1, 1] - A[0, 0] - A[2, 2], A[1, 2] + A[2, 1]],
        [A[1, 0] - A[0, 1], A[0, 2] + A[2, 0], A[1, 2] + A[2, 1], A[2, 2] - A[0, 0] - A[1, 1]]]) / 3.0)
    e = V[:, -1]
    return e if e[0] >= 0 else -e


def axis_angle(axis, angle) -> Float[Array, " 4"]:
    """Euler parameters of the rotation by ``angle`` [rad] about the unit vector ``axis``:
    (cos(θ/2), sin(θ/2) n). Traceable (``FloatingFrameSystem.turned`` under ``vmap``)."""
    n = jnp.asarray(axis, dtype=float).reshape(3)
    half = 0.5 * jnp.asarray(angle, dtype=float)
    return jnp.concatenate([jnp.cos(half)[None], jnp.sin(half) * n])


def _compose(a: Float[Array, " 4"], b: Float[Array, " 4"]) -> Float[Array, " 4"]:
    """The Euler parameters of the rotation A(a) A(b) (the quaternion product a ⊗ b)."""
    return jnp.concatenate([(a[0] * b[0] - a[1:] @ b[1:])[None],
                            a[0] * b[1:] + b[0] * a[1:] + jnp.cross(a[1:], b[1:])])


def _rotation_basis() -> np.ndarray:
    """B (4, 4, 3, 3), symmetric in its first two indices, with Â(e) = Σ_kl e_k e_l B_kl the
    unnormalised rotation matrix (e0² − ēᵀē) I + 2 ē ēᵀ + 2 e0 ẽ: a quadratic form in e, so its
    derivatives are ∂Â/∂e_k = 2 Σ_l B_kl e_l and ∂²Â/∂e_k∂e_l = 2 B_kl."""
    B = np.zeros((4, 4, 3, 3))
    B[0, 0] = np.eye(3)
    for i in range(3):
        B[i + 1, i + 1] -= np.eye(3)
        for j in range(3):
            B[i + 1, j + 1, i, j] += 1.0  # 2 ē ēᵀ, split over (k, l) = (i, j) and (j, i)
            B[j + 1, i + 1, i, j] += 1.0
    skew = np.zeros((3, 3, 3))  # ẽ = Σ_i ē_i skew[i]
    skew[0, 2, 1], skew[0, 1, 2] = 1.0, -1.0
    skew[1, 0, 2], skew[1, 2, 0] = 1.0, -1.0
    skew[2, 1, 0], skew[2, 0, 1] = 1.0, -1.0
    for i in range(3):
        B[0, i + 1] += skew[i]
        B[i + 1, 0] += skew[i]
    return B


_B = _rotation_basis()


def rigid_motions_left(body: Body, free) -> np.ndarray:
    """The infinitesimal rigid motions of ``body`` (``Body.rigid_modes``) that its held
    coordinates (``free``'s complement) leave free, as columns (n_dof × r): six on a free body,
    the three in-plane ones on a planar body (``reduce``'s ``plane_normal`` holds the mirror-odd
    coordinates), none under clamped, pinned or bearing conditions."""
    free = np.asarray(free, dtype=bool).reshape(-1)
    rigid = body.rigid_modes()
    held = rigid[~free]
    if not held.size or not np.abs(held).max() > 0:
        return rigid
    _, s, Vt = np.linalg.svd(held)
    rank = int(np.sum(s > 1e-8 * s[0]))
    return rigid @ Vt[rank:].T


class FloatingBody(AbstractBodyKind):
    """A body in a floating frame, deformation reduced: ``body`` in its own frame (its ``q_hat``
    the stress-free state in frame coordinates), the deformation basis ``basis`` (n_dof × k,
    zero on the reference conditions), its ``tensors`` (``reduction.elastic_tensors(body,
    body.q_hat, basis)``; or ``full_order_frame.NodalElasticForce``, the elements' own force, for
    the full-order RNCF body), and the frame's initial origin ``R0`` and orientation ``A0``.
    ``free`` (optional, n_dof booleans): the coordinates its reference conditions leave free, of
    which the basis moves some; the full-order counterpart of the body keeps them all
    (``multibody.error_estimate.full_counterpart``). ``modes`` (optional, n_dof × n): the
    vibration modes the basis was built from, whose modal interaction in the mechanism's motion
    chooses modal derivatives (``multibody.modal_interaction``). ``multibody.reduce`` records
    both. ``awaiting_mds``: reduced with ``mds="mmi"``, its modal derivatives not chosen yet
    (``modal_interaction.select_modal_derivatives`` chooses them; a model file that runs such a
    body is refused, ``scenarios.mechanism_file.run_setup``)."""

    body: Body
    basis: Float[Array, "ndof k"]
    basis_rows: Float[Array, "k ndof"]  # Ψᵀ: Ψ p as the row p Ψᵀ (``_deflection``)
    tensors: ElasticTensors  # or full_order_frame.NodalElasticForce: n_coordinates, force, force_and_jacobian
    R0: Float[Array, " 3"]
    e0: Float[Array, " 4"]
    is_position: Float[Array, " nv"]  # 1.0 on position vectors, 0.0 on gradient vectors
    mass: Float[Array, "nv nv"]  # M_b on the nodal vectors (the same for each component)
    weights: Float[Array, " nv"]  # ϱ: the body force's weights on the nodal vectors
    # The inertia invariants (``mass_matrix``), with μ = M_b 1_pos and u = q̂ + Ψ p:
    m_total: Float[Array, ""]  # 1_posᵀ M_b 1_pos, the body's mass
    c0: Float[Array, " 3"]  # Σ_w μ_w q̂_w
    C: Float[Array, "3 k"]  # Σ_w μ_w Ψ_w
    U0: Float[Array, "3 3"]  # Σ M_vw q̂_v q̂_wᵀ
    G: Float[Array, "3 3 k"]  # Σ M_vw q̂_va Ψ_wbj
    H: Float[Array, "3 3 k k"]  # Σ M_vw Ψ_vaj Ψ_wbl
    H_trace: Float[Array, "k k"]  # Σ_a H_aa = Ψᵀ (M_b ⊗ I) Ψ
    free: Array | None  # the reference conditions' free coordinates (n_dof booleans), if known
    modes: Array | None  # the vibration modes Φ (n_dof × n) the basis was built from, if known
    mean_axis_rows: Array | None  # G (r × k): a full-order body's mean-axis conditions G p = 0, or None
    awaiting_mds: bool = eqx.field(static=True)  # mds="mmi": its modal derivatives still to be chosen
    note: str = eqx.field(static=True)  # how its basis was chosen, for ``describe`` (``multibody.reduce`` writes it)

    def __init__(self, body: Body, basis, tensors: ElasticTensors, R0=(0.0, 0.0, 0.0), A0=None, free=None,
                 modes=None, awaiting_mds: bool = False, note: str = "", mean_axis: bool = False):
        basis = jnp.asarray(basis)
        mean_axis_rows = None
        if basis.ndim != 2 or basis.shape[0] != body.n_dof:
            raise ValueError(f"basis must be (n_dof, k) = ({body.n_dof}, k), got {basis.shape}")
        if tensors.n_coordinates != basis.shape[1]:
            raise ValueError(f"tensors are for {tensors.n_coordinates} coordinates, the basis has {basis.shape[1]}")
        if free is not None:
            free = np.asarray(free, dtype=bool).reshape(-1)
            if free.shape != (body.n_dof,):
                raise ValueError(f"free must be a mask of the body's {body.n_dof} coordinates, got {free.shape}")
            B = np.abs(np.asarray(basis))
            if B.size and B[~free].max(initial=0.0) > 1e-9 * B.max():
                raise ValueError("the basis moves coordinates that free holds")
            if getattr(tensors, "full_order", False):
                left = rigid_motions_left(body, free)
                if left.shape[1] and not mean_axis:
                    raise ValueError(
                        f"a full-order floating body must hold its frame: its free coordinates leave "
                        f"{left.shape[1]} rigid motion(s) free, which the frame's coordinates carry already (its "
                        "mass matrix would be singular); hold them (reference conditions) or pass mean_axis=True, "
                        "which holds them by the mean-axis conditions")
                if left.shape[1]:
                    # G p = 0: the deformation's momenta Rᵀ M w on the free coordinates, w = Ψ p
                    # (reduce's MeanAxisSpace), each row scaled to unit length
                    G = (np.kron(np.asarray(body.mass_matrix()), np.eye(3)) @ left).T @ np.asarray(basis)
                    mean_axis_rows = jnp.asarray(G / np.linalg.norm(G, axis=1, keepdims=True))
            free = jnp.asarray(free)
        elif mean_axis:
            raise ValueError("mean_axis needs the free coordinates (free=) whose rigid motions it holds")
        if mean_axis and mean_axis_rows is None:
            raise ValueError("mean_axis goes with a full-order body (full_order_frame.full_floating_body) whose "
                             "free coordinates leave rigid motions free; a reduced mean-axis basis satisfies the "
                             "conditions already (multibody.reduce)")
        if modes is not None:
            modes = jnp.asarray(modes)
            if modes.ndim != 2 or modes.shape[0] != body.n_dof:
                raise ValueError(f"modes must be (n_dof, n) = ({body.n_dof}, n), got {modes.shape}")
        if awaiting_mds and modes is None:
            raise ValueError("a body awaiting its modal derivatives must record the vibration modes that choose them")
        self.body, self.basis, self.tensors, self.free, self.modes = body, basis, tensors, free, modes
        self.mean_axis_rows = mean_axis_rows
        self.basis_rows = jnp.asarray(np.asarray(basis).T.copy())
        self.awaiting_mds = bool(awaiting_mds)
        self.note = str(note)
        self.R0 = jnp.asarray(R0, dtype=float).reshape(3)
        self.e0 = jnp.asarray(euler_parameters(np.eye(3) if A0 is None else A0))
        self.is_position = jnp.asarray(np.asarray(body.is_position, dtype=float))
        self.mass = jnp.asarray(body.mass_matrix())
        self.weights = jnp.asarray(body.varrho())
        M, pos, q_hat = np.asarray(self.mass), np.asarray(self.is_position), np.asarray(body.q_hat)
        # nodal_force takes M_b ẍ as (ẍᵀ M_b)ᵀ and the invariants assume M_b = M_bᵀ: an element's
        # mass that is not symmetric would make both silently wrong (the bound is far above the
        # assembly's round-off, far below any real asymmetry)
        if np.abs(M - M.T).max(initial=0.0) > 1e-12 * np.abs(M).max(initial=0.0):
            raise ValueError("the body's mass matrix M_b must be symmetric (an element's mass matrix is not)")
        Psi = np.asarray(basis).reshape(body.n_vectors, 3, -1)
        mu = M @ pos
        self.m_total = jnp.asarray(pos @ mu)
        self.c0, self.C = jnp.asarray(mu @ q_hat), jnp.asarray(np.einsum("w,wbk->bk", mu, Psi))
        MPsi = np.einsum("vw,wbj->vbj", M, Psi)
        self.U0 = jnp.asarray(q_hat.T @ M @ q_hat)
        self.G = jnp.asarray(np.einsum("va,vbj->abj", q_hat, MPsi))
        self.H = jnp.asarray(np.einsum("vaj,vbl->abjl", Psi, MPsi))
        self.H_trace = jnp.asarray(np.einsum("vaj,val->jl", Psi, MPsi))

    @property
    def k(self) -> int:
        return int(self.basis.shape[1])

    @property
    def n_z(self) -> int:
        return 7 + self.k

    def _deflection(self, p):
        """Ψ p as nodal vectors, computed as the row p Ψᵀ (``linalg.contract``: fused where it is
        small): under ``vmap`` over bodies that share Ψ (``mechanism._stacks``), or over a batch,
        XLA's CPU backend runs a large one as one matrix product, where Ψ p becomes a product with
        a transposed operand that runs much slower."""
        return contract("k,kn->n", p, self.basis_rows).reshape(-1, 3)

    def _local(self, p):
        return self.body.q_hat + self._deflection(p)

    def nodal_vectors(self, z: Float[Array, " nz"]) -> Float[Array, "nv 3"]:
        """x = f(z) = R (on position vectors) + Â(e) (q̂ + Ψ p): the nodal vectors in the inertial
        frame."""
        R, e, p = z[:3], z[3:7], z[7:]
        return _times_transpose(self._local(p), _A_hat(e)) + self.is_position[:, None] * R[None, :]

    def jacobian(self, z: Float[Array, " nz"], rows=None) -> Float[Array, "nv 3 nz"]:
        """J = ∂x/∂z in closed form (of the nodal vectors ``rows``, all by default): the columns
        ∂x/∂R (the position vectors' identity), ∂x/∂e_k = ∂Â/∂e_k u and ∂x/∂p = Â Ψ,
        u = q̂ + Ψ p."""
        e, p = z[3:7], z[7:]
        nv = self.body.n_vectors
        Psi = self.basis.reshape(nv, 3, -1)
        u, pos = self._local(p), self.is_position
        if rows is not None:
            rows = jnp.asarray(rows, dtype=int)
            u, pos, Psi = u[rows], pos[rows], Psi[rows]
        J_R = pos[:, None, None] * jnp.eye(3)[None]
        J_e = contract("kij,vj->vik", _dA_hat(e), u)
        J_p = contract("ij,vjk->vik", _A_hat(e), Psi)
        return jnp.concatenate([J_R, J_e, J_p], axis=-1)

    def tangent(self, z, dz) -> Float[Array, "nv 3"]:
        """J dz (J not formed): dR on the position vectors, Σ_k ∂Â/∂e_k de_k u + Â Ψ dp."""
        e, p = z[3:7], z[7:]
        A_de = 2.0 * _A_bilinear(dz[3:7], e)
        return (self.is_position[:, None] * dz[None, :3] + _times_transpose(self._local(p), A_de)
                + _times_transpose(self._deflection(dz[7:]), _A_hat(e)))

    def acceleration(self, z, v, a) -> Float[Array, "nv 3"]:
        """ẍ = J z̈ + J̇ ż, with J̇ ż = Ä u + 2 Ȧ u̇, Ä = ∂²Â(ė, ė), Ȧ = ∂Â ė, u̇ = Ψ ṗ."""
        e, p, de, dp = z[3:7], z[7:], v[3:7], v[7:]
        A_dd = 2.0 * _A_bilinear(de, de)
        A_d = 2.0 * _A_bilinear(de, e)
        return (self.tangent(z, a) + _times_transpose(self._local(p), A_dd)
                + 2.0 * _times_transpose(self._deflection(dp), A_d))

    def generalized(self, z, F: Float[Array, "nv 3"]) -> Float[Array, " nz"]:
        """J ᵀF (J not formed): Σ F_α over the position vectors, Σ_α u_αᵀ ∂Â/∂e_kᵀ F_α, and
        Ψᵀ (Â ᵀF_α)_α."""
        e, p = z[3:7], z[7:]
        F_R = contract("v,vi->i", self.is_position, F)
        F_e = contract("kij,ij->k", _dA_hat(e), contract("vi,vj->ij", F, self._local(p)))
        F_p = contract("n,nk->k", _times_transpose(F, _A_hat(e).T).reshape(-1), self.basis)
        return jnp.concatenate([F_R, F_e, F_p])

    def mass_matrix(self, z: Float[Array, " nz"]) -> Float[Array, "nz nz"]:
        """M_z = J ᵀM_b J from the inertia invariants (the paper's approach): with u = q̂ + Ψ p,
        c = Σ μ_w u_w, U = Σ M_vw u_v u_wᵀ and V_abm = Σ M_vw u_va Ψ_wbm (each a polynomial in p
        with the constant coefficients ``c0, C, U0, G, H``) and D_k = ∂Â/∂e_k,

            M_RR = m I,  M_Re = [D_k c]_k,  M_Rp = Â C,  M_ee = [Σ D_k:(D_l U)]_kl,
            M_ep = [Σ D_k:(Â V_m)]_km,  M_pp = Σ Â_ia Â_ib H_ab = |e|⁴ Σ_a H_aa

        (Â(e) = |e|² A(e) with A orthogonal, so ÂᵀÂ = |e|⁴ I: M_pp is the constant ``H_trace``
        scaled, a k × k product saved, the largest one on a full-order body). A few 3 × 3 × k (× k)
        products instead of J ᵀM J over every nodal vector, which costs far more; equal to it to
        round-off (tests/test_floating.py)."""
        e, p = z[3:7], z[7:]
        A, D = _A_hat(e), _dA_hat(e)
        c = self.c0 + contract("ak,k->a", self.C, p)
        Gp = contract("abj,j->ab", self.G, p)
        V = self.G + contract("abjm,j->abm", self.H, p)
        U = self.U0 + Gp.T + contract("abm,m->ab", V, p)
        M_Re = contract("kij,j->ik", D, c)
        M_Rp = contract("ab,bk->ak", A, self.C)
        M_ee = contract("kia,lib,ab->kl", D, D, U)
        M_ep = contract("kia,ib,abm->km", D, A, V)
        M_pp = jnp.sum(e * e) ** 2 * self.H_trace
        return jnp.block([[self.m_total * jnp.eye(3), M_Re, M_Rp],
                          [M_Re.T, M_ee, M_ep],
                          [M_Rp.T, M_ep.T, M_pp]])

    def nodal_force(self, z, v, a, gravity) -> Float[Array, "nv 3"]:
        """F = M_b ẍ − ϱ g on the nodal vectors, ẍ = J z̈ + J̇ ż: the inertia and weight whose
        J ᵀF is the residual's frame and inertia part. M_b ẍ is computed as the rows (ẍᵀ M_b)ᵀ (M_b
        is symmetric), for the reason ``_deflection`` gives."""
        return (self.acceleration(z, v, a).T @ self.mass).T - self.weights[:, None] * gravity[None, :]

    def deformation_tangent(self, z, v, a, F: Float[Array, "nv 3"], c_C, c_K) -> Float[Array, "nz k"]:
        """The columns for p (and ṗ) of the residual's derivative that ``mass_matrix`` and the
        elastic stiffness leave out, c_K ∂r/∂p + c_C ∂r/∂ṗ of r = J ᵀF with F = M ẍ − Q held:

            c_K (∂J/∂p)ᵀ F + J ᵀM Y Ψ,   Y = c_K (Σ_k ∂Â/∂e_k ë_k + ∂²Â(ė, ė)) + 2 c_C Ȧ,

        as ẍ = J z̈ + J̇ ż has ∂ẍ/∂p = (Σ_k ∂Â/∂e_k ë_k + ∂²Â(ė, ė)) Ψ (the frame's angular
        acceleration and centrifugal terms acting on the deformation) and ∂ẍ/∂ṗ = 2 Ȧ Ψ
        (Coriolis), and only J_e = ∂Â/∂e u depends on p (∂J_e/∂p = ∂Â/∂e Ψ, contracted with F).
        From the inertia invariants: R rows Y C, e rows Σ D_k:(Y V) + c_K Σ D_k:(Fᵀ Ψ), p rows
        Σ (ÂᵀY)_ab H_ab. ``F`` is the body's total nodal force, the joints' reactions included
        (their Hessian's part through J). Small against c_M M_z in most directions, but on the
        full-order body a frame rotation undone by its deformation coordinates moves only the
        few vectors that hold the frame (the left node's section vectors, or its tangent), whose
        inertia is tiny: there these terms are not small, and with them modified Newton contracts
        much faster."""
        e, p, de = z[3:7], z[7:], v[3:7]
        A, D = _A_hat(e), _dA_hat(e)
        A_dd = 2.0 * _A_bilinear(de, de) + contract("k,kij->ij", a[3:7], D)
        Y = c_K * A_dd + 2.0 * c_C * contract("k,kij->ij", de, D)
        V = self.G + contract("abjm,j->abm", self.H, p)
        Psi = self.basis.reshape(self.body.n_vectors, 3, -1)
        W = contract("vi,vjm->ijm", F, Psi)
        rows_R = contract("ab,bk->ak", Y, self.C)
        rows_e = contract("kia,ib,abm->km", D, Y, V) + c_K * contract("kij,ijm->km", D, W)
        rows_p = contract("ia,ib,abmn->mn", A, Y, self.H)
        return jnp.concatenate([rows_R, rows_e, rows_p], axis=0)

    def initial(self) -> Float[Array, " nz"]:
        return jnp.concatenate([self.R0, self.e0, jnp.zeros(self.k)])

    # --- as a body kind of a mechanism (``kinds.AbstractBodyKind``) -------------------------------

    @property
    def kind(self) -> str:  # type: ignore[override]
        if self.k == 0:
            return "rigid"
        return "rncf" if self.tensors.full_order else "nr-rncf"

    def describe(self) -> str:
        """The body's kind, coordinates and, for a reduced body, how its basis was chosen."""
        if self.k == 0:
            return f"{self.kind}, {self.n_z} coordinates (its frame)"
        text = f"{self.kind}, {self.n_z} coordinates (frame 7 + {self.k} deformation)"
        return text + (f": {self.note}" if self.note else "")

    @property
    def n_vectors(self) -> int:
        return self.body.n_vectors

    @property
    def small_kernels(self) -> bool:  # type: ignore[override]
        """Rigid or reduced: the deformation's force is the reduced cubic one; a full-order RNCF
        body evaluates its elements."""
        return self.kind != "rncf"

    def moved(self, R0, A0=None) -> "FloatingBody":
        """The same reduced body with its frame's initial origin at ``R0`` (and orientation
        ``A0``, default as it is): a copy of one reduction placed elsewhere, as the equal beams of
        a chain are (its basis, tensors and invariants are in the frame, and do not change)."""
        e0 = self.e0 if A0 is None else jnp.asarray(euler_parameters(np.asarray(A0, dtype=float)))
        return eqx.tree_at(lambda b: (b.R0, b.e0), self, (jnp.asarray(R0, dtype=float).reshape(3), e0))

    def stiffened(self, s) -> "FloatingBody":
        """The elastic force times s: the reduced tensors scaled (exact: the vibration modes and
        their derivatives do not change when E is scaled uniformly), or, full-order, the elements'
        κ (``bodies.body.stiffened``)."""
        if hasattr(self.tensors, "scaled"):
            return eqx.tree_at(lambda b: b.tensors, self, self.tensors.scaled(s))
        if hasattr(self.tensors, "body"):
            return eqx.tree_at(lambda b: b.tensors.body, self, stiffened(self.tensors.body, s))
        return self

    def geometry(self) -> BodyGeometry:
        return BodyGeometry(np.asarray(self.nodal_vectors(self.initial())), np.asarray(self.body.is_position),
                            self.body.vectors_per_node, self.body.section_slots)

    def residual(self, z, v, a, gravity) -> Float[Array, " nz"]:
        """J ᵀ(M ẍ − Q) + ∂U/∂z, the elastic force the reduced cubic one (or the elements')."""
        return self.loaded_residual(z, v, a, gravity, None)

    def loaded_residual(self, z, v, a, gravity, F) -> Float[Array, " nz"]:
        """J ᵀ(M ẍ − Q + F) + ∂U/∂z: the nodal forces ``F`` (None: none) with the inertia and
        weight, one J ᵀ."""
        F_all = self.nodal_force(z, v, a, gravity) + (0.0 if F is None else F)
        return self.generalized(z, F_all).at[7:].add(self.tensors.force(z[7:]))

    def block(self, z, c_M, c_K, gravity, state=None, c_C=0.0) -> Float[Array, "nz nz"]:
        """c_M M_z and the elastic stiffness c_K (K + 2Lp + 3Npp); with ``state`` = (v, a, the
        joints' nodal forces) also the inertia terms' p columns (``deformation_tangent``; the
        system's docstring says why)."""
        _, K = self.tensors.force_and_jacobian(z[7:])
        S = (c_M * self.mass_matrix(z)).at[7:, 7:].add(c_K * K)
        if self.mean_axis_rows is not None:
            # A full-order mean-axis body's M and K are both singular along the rigid motions its
            # frame and its deformation share (G p = 0 tells them apart, a constraint of the
            # system). The block gains c_M m̄ GᵀG, m̄ its largest nodal mass: with G's rows among
            # the constraints, Newton's correction Δz is the same (C Δz = −c makes GᵀG Δz a shift
            # of the conditions' multipliers, zero once the linear G p = 0 holds), and the block
            # is regular.
            G = self.mean_axis_rows
            S = S.at[7:, 7:].add(c_M * jnp.max(jnp.diagonal(self.mass)) * (G.T @ G))
        if state is None:
            return S
        v, a, reaction = state
        F = self.nodal_force(z, v, a, gravity) + reaction
        return S.at[:, 7:].add(self.deformation_tangent(z, v, a, F, c_C, c_K))

    @property
    def n_own_equations(self) -> int:
        """|e|² = 1, and a full-order mean-axis body's r conditions G p = 0."""
        return 1 + (0 if self.mean_axis_rows is None else int(self.mean_axis_rows.shape[0]))

    def own_equations(self, z) -> Float[Array, " e"]:
        """|e|² − 1; for a full-order mean-axis body also G p (linear: the deformation's linear
        and angular momentum relative to the frame, linearised at q̂, Buckens' conditions, which a
        reduced mean-axis basis meets by construction)."""
        norm = jnp.atleast_1d(jnp.sum(z[3:7] * z[3:7]) - 1.0)
        if self.mean_axis_rows is None:
            return norm
        return jnp.concatenate([norm, contract("rk,k->r", self.mean_axis_rows, z[7:])])

    def own_jacobian(self, z) -> Float[Array, "e nz"]:
        """The row 2eᵀ (and [0, G] for a full-order mean-axis body)."""
        row = jnp.concatenate([jnp.zeros(3, z.dtype), 2.0 * z[3:7], jnp.zeros(self.k, z.dtype)])[None]
        if self.mean_axis_rows is None:
            return row
        G = self.mean_axis_rows
        return jnp.concatenate([row, jnp.concatenate([jnp.zeros((G.shape[0], 7), z.dtype), G], axis=1)])

    def kinetic_energy(self, z, v) -> Float[Array, ""]:
        xv = self.tangent(z, v)
        return 0.5 * jnp.sum(xv * (self.mass @ xv))

    def potential_energy(self, z, gravity) -> Float[Array, ""]:
        x = self.nodal_vectors(z)
        return self.tensors.energy(z[7:]) - jnp.sum(self.weights[:, None] * x * gravity[None, :])

    def turned(self, e, A) -> "FloatingBody":
        """The frame's origin and orientation turned (the deformation, in the frame, stays)."""
        return eqx.tree_at(lambda b: (b.R0, b.e0), self, (self.R0 @ A.T, _compose_last(e, self.e0)))

    def rigid_velocity(self, z, velocity, omega) -> Float[Array, " nz"]:
        """Ṙ = velocity + ω × R, ė = ½ ω ⊗ e (the quaternion rate of Ȧ = ω̃ A), ṗ = 0."""
        R, e = z[:3], z[3:7]
        w = jnp.asarray(omega, dtype=float).reshape(3)
        de = 0.5 * jnp.concatenate([(-w @ e[1:])[None], e[0] * w + jnp.cross(w, e[1:])])
        return jnp.concatenate([jnp.asarray(velocity, dtype=float).reshape(3) + jnp.cross(w, R), de,
                                jnp.zeros(self.k)])


def _compose_last(a, b):
    """``_compose(a, b)`` over b's leading axes (a stacked body's e0 is (bodies, 4))."""
    return _compose(a, b) if b.ndim == 1 else jax.vmap(lambda y: _compose(a, y))(b)


def _times_transpose(X: Float[Array, "nv 3"], A: Float[Array, "3 3"]) -> Float[Array, "nv 3"]:
    """X Aᵀ (each row of X turned by A) as three scaled columns added, not as a product. On a CPU,
    XLA hands a 3-wide product to a matrix-multiply library call (a batched one for a run of
    equal bodies, and more so under ``vmap`` over a batch of runs), which costs far more than its
    arithmetic; the added columns fuse with the operations around them. A (a few flops) is
    formed once and shared (``_A_bilinear``)."""
    return X[:, 0:1] * A[None, :, 0] + X[:, 1:2] * A[None, :, 1] + X[:, 2:3] * A[None, :, 2]


def _A_bilinear(a, b):
    """Σ_kl a_k b_l B_kl (``_B``): the symmetric bilinear form whose diagonal is Â(e) = Â(e, e)."""
    return contract("k,l,klij->ij", a, b, jnp.asarray(_B))


def _A_hat(e):
    """Â(e) = (e0² − ēᵀē) I + 2 ē ēᵀ + 2 e0 ẽ, the unnormalised rotation matrix (Eq. of ``_B``)."""
    return _A_bilinear(e, e)


def _dA_hat(e):
    """∂Â/∂e_k (4, 3, 3) = 2 Â(δ_k, e)."""
    return 2.0 * contract("l,klij->kij", e, jnp.asarray(_B))


__all__ = ["FloatingBody", "axis_angle", "euler_parameters", "rotation"]
