"""The reduced NR-RNCF equations of a body under prescribed frame motion (docs/theory.md, §4 Reduction); for a
spin θ(t) about a fixed axis

    Ī p̈ + (2θ̇ Ḡ + D̄) ṗ + θ̈(Ḡ p + ḡ) + θ̇²(C̄ p + c̄) + F(p) = Ψᵀ Q,   q = q° + Ψ p,

and in general, with ω = Σ_k w_k b_k on the motion's directions b_k, Ḡ and C̄ are the sums
Σ_k w_k Ḡ_k and Σ_kl w_k w_l C̄_kl (``reduction.tensors.RotationInertia``).

D̄ = α Ī + β K̄ is the projection of the full model's Rayleigh damping (zero unless given).

F(p) is the cubic polynomial of Eq. 24 (``force="tensor"``), or the projection of the
element-wise full elastic force ``Ψᵀ F(q° + Ψ p)`` (``force="projected"``); the two are equal
to round-off and differ only in cost (O(Km⁴) against O(n_el n_e⁴ + 3n Km)).
"""

from typing import ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .. import _validate
from .._types import Array, Bool, Float
from ..bodies.body import Body
from ..linalg import DenseLU, solve_once
from ..models.base import AbstractModel
from ..models.damping import RayleighDamping
from ..models.full_order import RotatingFrameModel
from ..motion import AbstractMotion
from .tensors import ElasticTensors, RotationInertia, elastic_tensors, rotation_inertia, sum_terms


class ReducedRotatingModel(AbstractModel):
    """NR-RNCF model: modal coordinates p of the basis Ψ about q°; an equinox Module."""

    Psi: Float[Array, "ndof km"]
    q_eq: Float[Array, "n 3"]
    q_hat: Float[Array, "n 3"]
    elastic: ElasticTensors
    inertia: RotationInertia
    gravity_map: Float[Array, "km 3"]  # Σ_α ϱ_α ψ^i_α: Ψᵀ of a uniform body-frame acceleration
    point_load: Float[Array, " km"]  # Ψᵀ of the point forces
    point_history: eqx.Module | None  # their time history (``Loads.point_history``; None: constant)
    gravity: Float[Array, " 3"]
    physical_mask: Bool[Array, " ndof"]  # the full model's free coordinates
    motion: AbstractMotion
    directions: Float[Array, "3 d"]  # the directions b_k the rotation-inertia tensors are built for
    body: Body | None
    force: str = eqx.field(static=True)
    linear: bool = eqx.field(static=True)
    damping: RayleighDamping | None = None
    error_basis: tuple | None = None
    """``(q°_r, Ψ_r, mask_r)``: the rows of the physical coordinates the step error is measured on
    (``reduce_rotating_model(error_rows=...)``); None: all of them."""
    """``linear=True``: the linear model of the MMI criterion (Eq. 39), ``Ī p̈ + (f + K p) =
    −θ̈ ḡ − θ̇² c̄ + Ψᵀ Q``: linearised elastic force, and the rotation only as the load it exerts
    (the parametric Coriolis/centrifugal terms would make it unstable above the first critical
    speed, since the centrifugal stiffening is nonlinear)."""
    # Full Newton: ``newton_update`` takes F and ∂F/∂p from one cubic contraction, so an iteration
    # with a fresh factor costs about what a modified-Newton residual does, and converges
    # quadratically.
    preferred_newton: ClassVar[str] = "full"

    @property
    def small_kernels(self) -> bool:
        """True with the cubic tensors (or linear): a step is a few Km-sized contractions. The
        ``"projected"`` force evaluates the body's elements, large kernels
        (``models.base.AbstractModel.small_kernels``)."""
        return self.linear or self.force == "tensor"

    @property
    def n_dof(self) -> int:
        return self.Psi.shape[1]

    def free_mask(self):
        return jnp.ones(self.n_dof, bool)

    def initial_state(self, t0):
        z = jnp.zeros(self.n_dof)
        return z, z

    def constrain(self, t, q, v, a):
        return q, v, a

    def elastic_force(self, p):
        """F(p) (Eq. 24)."""
        if self.linear:
            return self.elastic.f + self.elastic.K @ p
        if self.force == "tensor":
            return self.elastic.force(p)
        q = (self.q_eq.reshape(-1) + self.Psi @ p).reshape(-1, 3)
        return self.Psi.T @ self.body.elastic_force(q).reshape(-1)

    def elastic_force_and_jacobian(self, p):
        """``(F(p), ∂F/∂p)`` (Eqs. 24-25)."""
        if self.linear:
            return self.elastic.f + self.elastic.K @ p, self.elastic.K
        if self.force == "tensor":
            return self.elastic.force_and_jacobian(p)
        body = self.body
        q = (self.q_eq.reshape(-1) + self.Psi @ p).reshape(-1, 3)
        F = self.Psi.T @ body.elastic_force(q).reshape(-1)
        J = 0.0
        for Ke, dofs in body.tangent_parts(q):
            Pe = self.Psi[dofs]  # (n_el, 3ne, km)
            J = J + jnp.einsum("eaI,eab,ebJ->IJ", Pe, Ke, Pe)
        return F, J

    def damping_matrix(self):
        """D̄ = α Ī + β K̄ (K̄ = Ψᵀ K̂ Ψ, the tensors' K about q° = q̂); ``None`` when undamped."""
        if self.damping is None:
            return None
        return self.damping.alpha * self.inertia.I + self.damping.beta * self.elastic.K

    def rates(self, t):
        """``(w, ẇ)``: ω(t) and ω̇(t) on the model's directions (ω = Σ_k w_k b_k)."""
        B = self.directions
        return B.T @ self.motion.angular_velocity(t), B.T @ self.motion.angular_acceleration(t)

    def with_motion(self, motion: AbstractMotion) -> "ReducedRotatingModel":
        """This model under another prescribed motion, whose ω(t) must stay in the span of the
        directions the model's inertia tensors were built for (checked on concrete input)."""
        if not isinstance(motion, AbstractMotion):
            raise ValueError(f"motion must be a motion.AbstractMotion, got {type(motion).__name__}")
        if _validate.is_concrete(motion.directions) and _validate.is_concrete(self.directions):
            B, Bm = np.asarray(self.directions), np.asarray(motion.directions)
            if np.linalg.norm(Bm - B @ (B.T @ Bm)) > 1e-12:
                raise ValueError("the new motion rotates about directions the reduced model was not built for; "
                                 "reduce the full model under that motion instead")
        return eqx.tree_at(lambda m: m.motion, self, motion)

    def external(self, t):
        A = self.motion.rotation(t)
        g = self.gravity - self.motion.origin_acceleration(t)
        point = self.point_load if self.point_history is None else self.point_load * self.point_history(t)
        return self.gravity_map @ (A.T @ g) + point

    def residual(self, t, p, v, a):
        return self._residual(t, p, v, a, self.elastic_force(p))

    def factor_iteration_matrix(self, t, p, v, c_M, c_C, c_K):
        _, J = self.elastic_force_and_jacobian(p)
        return DenseLU.factor(self._iteration_matrix(t, J, c_M, c_C, c_K))

    def newton_update(self, t, p, v, a, c_M, c_C, c_K):
        """One full-Newton update ``S⁻¹ r`` from one evaluation of F and ∂F/∂p (they share the
        cubic contraction N p p, the bulk of the cost), solved by one factorisation of the
        augmented matrix ``[S | r]`` (``linalg.solve_once``)."""
        F, J = self.elastic_force_and_jacobian(p)
        return solve_once(self._iteration_matrix(t, J, c_M, c_C, c_K), self._residual(t, p, v, a, F))

    def _residual(self, t, p, v, a, F):
        w, wd = self.rates(t)
        I = self.inertia
        mats, loads = I.forces(w, wd, p, v)
        load = sum_terms(loads) - self.external(t)
        D = self.damping_matrix()
        if D is not None:
            load = load + D @ v
        if self.linear:  # the rotation acts only as the load it exerts (see ``linear``)
            return I.I @ a + F + load
        # Ī a + Σ Ḡ_k (2w_k v + ẇ_k p) + Σ C̄_kl w_k w_l p as elementwise products and one sum, which
        # XLA fuses with the rest of the residual: on a small model each separate kernel costs a
        # dispatch.
        inertial = sum_terms([I.I * a] + mats)
        return jnp.sum(inertial, axis=1) + F + load

    def _iteration_matrix(self, t, J, c_M, c_C, c_K):
        """S = c_M ∂r/∂a + c_C ∂r/∂v + c_K ∂r/∂p (Eq. 25 with the rotation terms)."""
        I = self.inertia
        if self.linear:
            S = c_M * I.I + c_K * J
        else:
            vel, pos = I.tangent(*self.rates(t), c_C, c_K, J)
            S = c_M * I.I + vel + pos
        D = self.damping_matrix()
        if D is not None:
            S = S + c_C * D
        return S

    def error_space(self, p, e):
        # Measure the step error in the physical coordinates q = q° + Ψp (only those that move),
        # or in the rows of them chosen at reduction (``error_basis``).
        if self.error_basis is not None:
            q_r, Psi_r, mask_r = self.error_basis
            return q_r + Psi_r @ p, Psi_r @ e, mask_r
        return self.q_eq.reshape(-1) + self.Psi @ p, self.Psi @ e, self.physical_mask

    def with_error_rows(self, rows) -> "ReducedRotatingModel":
        """This model with its step error measured on the physical coordinates ``rows`` only
        (concrete indices; see ``reduce_rotating_model``)."""
        rows = np.asarray(rows, dtype=int).reshape(-1)
        n = self.Psi.shape[0]
        if rows.size == 0 or rows.min() < 0 or rows.max() >= n:
            raise ValueError(f"error_rows must be indices of the {n} physical coordinates")
        basis = (self.q_eq.reshape(-1)[rows], self.Psi[rows], self.physical_mask[rows])
        return eqx.tree_at(lambda m: m.error_basis, self, basis, is_leaf=lambda x: x is None)

    def coordinates(self, p: Float[Array, " km"]) -> Float[Array, "n 3"]:
        """q = q° + Ψ p (Eq. 13)."""
        return (self.q_eq.reshape(-1) + self.Psi @ p).reshape(-1, 3)

    def displacements(self, t, p):
        """w = q − q̂ in the rotating frame (docs/theory.md, §9 Accuracy measures and checks)."""
        return self.coordinates(p) - self.q_hat


def force_evaluation_costs(body: Body, km: int) -> dict:
    """Multiply-adds per Newton iteration of the two ways to evaluate F(p) and ∂F/∂p.

    tensor: the packed Jacobian contraction (Km² · Km(Km+1)/2) plus the force (Km · triples);
    projected: element tangents (n_el · 3 n_e⁴) and their projection (n_el · (3 n_e)² · Km).
    Returns ``{"tensor": ..., "projected": ...}``; ``force='auto'`` takes the smaller. The estimate
    agrees with measured run times.
    """
    tensor = km * km * km * (km + 1) // 2 + km * km * (km + 1) * (km + 2) // 6
    projected = sum(g.n_elements * (3 * g.elements.shape[1] ** 4 + (3 * g.elements.shape[1]) ** 2 * km)
                    for g in body.groups)
    return {"tensor": tensor, "projected": projected}


def reduce_rotating_model(full: RotatingFrameModel, Psi: Float[Array, "ndof km"], q_eq=None,
                          force: str = "auto", linear: bool = False, error_rows=None) -> ReducedRotatingModel:
    """Galerkin projection of the full RNCF model onto the basis Ψ about q° (default q̂).

    ``error_rows`` (indices of physical coordinates, e.g. those of the position vectors): the
    integrator's step error is measured on these rows of q = q° + Ψp only, instead of all of
    them. Each step maps the error to the physical coordinates (``Ψ e``), which for a large body
    costs more than the reduced step itself, so measuring it on fewer rows makes the run faster.

    ``force='auto'`` evaluates the elastic force the cheaper way for this model (see
    ``force_evaluation_costs``); ``'tensor'`` or ``'projected'`` force a choice. The full
    model's Rayleigh damping carries over as D̄ = α Ī + β Ψᵀ K̂ Ψ (which needs q° = q̂).
    """
    if force not in ("auto", "tensor", "projected"):
        raise ValueError(f"force must be 'auto', 'tensor' or 'projected', got {force!r}")
    body = full.body
    Psi = jnp.asarray(Psi, dtype=float)
    if Psi.ndim != 2 or Psi.shape[0] != body.n_dof:
        raise ValueError(f"Psi must have shape ({body.n_dof}, Km), got {Psi.shape}")
    if full.damping is not None and q_eq is not None:
        raise ValueError("a damped model reduces about the reference q° = q̂ only (D̄ uses K̂): leave q_eq unset")
    q_eq = body.q_hat if q_eq is None else q_eq
    if force == "auto":
        costs = force_evaluation_costs(body, Psi.shape[1])
        force = min(costs, key=costs.get)
    gravity_map, point_load = _load_maps(full, Psi)
    model = ReducedRotatingModel(
        Psi=Psi, q_eq=q_eq, q_hat=body.q_hat,
        elastic=elastic_tensors(body, q_eq, Psi),
        inertia=rotation_inertia(body, q_eq, Psi, full.motion.directions),
        gravity_map=gravity_map, point_load=point_load, point_history=full.loads.point_history,
        gravity=full.loads.gravity, physical_mask=full.free_mask(), motion=full.motion,
        directions=full.motion.directions,
        body=body if force == "projected" else None, force=force, linear=linear, damping=full.damping,
    )
    return model if error_rows is None else model.with_error_rows(error_rows)


def _load_maps(full: RotatingFrameModel, Psi):
    """``(Σ_α ϱ_α ψ^i_α, Ψᵀ Q_point)``: Ψᵀ of a uniform body-frame acceleration and of the
    point forces."""
    body, loads = full.body, full.loads
    P = Psi.reshape(body.n_vectors, 3, Psi.shape[1])
    return (jnp.einsum("a,akI->Ik", body.varrho(), P),
            jnp.einsum("pkI,pk->I", P[loads.point_vectors], loads.point_forces))


@eqx.filter_jit
def modal_loads(full: RotatingFrameModel, Psi: Float[Array, "ndof km"], ts: Float[Array, " nt"]):
    """The loads of the linear MMI model (``linear=True``) on the basis Ψ about q̂:
    ``l(t) = −θ̈ ḡ − θ̇² c̄ + Ψᵀ Q(t)`` at the times ``ts`` (nt × Km; for a general motion the sums
    over its directions, ``RotationInertia``), and the constant load vectors
    ``[ḡ_k..., c̄_kl..., Ψᵀ ϱ g, Ψᵀ Q_point]`` (Km × (d + d² + 2); d = 1 for a fixed axis) they
    combine."""
    B = full.motion.directions
    inertia = rotation_inertia(full.body, full.body.q_hat, Psi, B)
    gravity_map, point_load = _load_maps(full, Psi)

    def at(t):
        _, loads = inertia.forces(B.T @ full.motion.angular_velocity(t), B.T @ full.motion.angular_acceleration(t),
                                  0.0, 0.0)
        g = full.loads.gravity - full.motion.origin_acceleration(t)
        point = point_load * full.loads.point_scale(t)
        return -sum_terms(loads) + gravity_map @ (full.motion.rotation(t).T @ g) + point

    d = inertia.g.shape[0]
    vectors = jnp.column_stack([*inertia.g, *inertia.c.reshape(d * d, -1), gravity_map @ full.loads.gravity,
                                point_load])
    return jax.vmap(at)(ts), vectors
