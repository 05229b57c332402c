"""Rigid bodies: mass, centre of mass, inertia tensor, and the points where things attach.

A rigid body is described, as the flexible ones are, by nodal vectors (natural coordinates,
García de Jalón): each attachment point carries a node of four vectors [r, g₁, g₂, g₃], its
position and the body's three unit axes, and the centre of mass a node of its own. In the body's
frame, with ξ measured from the centre of mass and η = Oᵀξ the components along the axes
g_k = O e_k, a point moves as x(ξ) = r_c + Σ_k η_k g_k, so the kinetic energy of the body is

    T = ½ ∫ρ |ẋ|² = ½ m |ṙ_c|² + ½ Σ_kl Θ'_kl ġ_k·ġ_l,   Θ' = Oᵀ Θ O,   Θ = ½ tr(J) I − J,

with J the inertia tensor about the centre of mass and Θ = ∫ρ ξξᵀ the second moments: a constant
mass matrix on the centre of mass's node (m on r_c, Θ' on the axes) and none on the attachment
points, whose vectors follow the same rigid motion. ``multibody.rigid`` puts the body in a
floating frame with no deformation coordinates (R, e: 7 coordinates, |e| = 1), so joints, markers
and sensors treat it as any other body.

Θ ⪰ 0 is the triangle inequality of the principal moments (J₁ ≤ J₂ + J₃ and its permutations),
which every physical mass distribution satisfies; J ≻ 0 is required too (a body without
rotational inertia is a point mass, ``multibody.point_mass``).
"""

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .._types import Array, Bool, Float

VECTORS_PER_NODE = 4
"""[r, g₁, g₂, g₃] at each node."""


class RigidBody(eqx.Module):
    """A rigid body of ``mass`` [kg] with centre of mass ``com`` and inertia tensor ``inertia``
    (3 × 3 [kg m²], about the centre of mass, in the system's axes) in the reference
    configuration, and attachment ``points`` (k × 3, in the system's frame) where markers may
    sit (the centre of mass is always one). ``axes`` (3 × 3, proper rotation; identity by
    default): the directions, as columns, that its nodes carry as gradient vectors, i.e. along
    which hinge and slider axes may point. Its nodal vectors in the body's frame (origin at the
    centre of mass, axes of the system) are ``q_hat``; see the module docstring."""

    mass_value: Float[Array, ""]
    com: Float[Array, " 3"]
    inertia: Float[Array, "3 3"]
    axes: Float[Array, "3 3"]
    q_hat: Float[Array, "n 3"]
    is_position: Bool[Array, " n"]
    vectors_per_node: int = eqx.field(static=True)

    def __init__(self, mass, inertia, com=(0.0, 0.0, 0.0), points=(), axes=None):
        m = float(mass)
        if not np.isfinite(m) or m <= 0:
            raise ValueError(f"a rigid body's mass must be finite and > 0, got {mass!r}")
        J = np.asarray(inertia, dtype=float)
        if J.shape == (3,):
            J = np.diag(J)
        if J.shape != (3, 3) or not np.all(np.isfinite(J)):
            raise ValueError(f"inertia must be a finite 3 × 3 tensor (or its 3 principal moments), got shape {J.shape}")
        if not np.allclose(J, J.T, rtol=0, atol=1e-12 * np.abs(J).max()):
            raise ValueError("the inertia tensor must be symmetric")
        moments = np.linalg.eigvalsh(J)
        if moments[0] <= 0:
            raise ValueError(f"the inertia tensor must be positive definite; its principal moments are "
                             f"{moments.tolist()}")
        if np.linalg.eigvalsh(0.5 * np.trace(J) * np.eye(3) - J)[0] < -1e-12 * moments[-1]:
            raise ValueError(f"the principal moments {moments.tolist()} violate the triangle inequality "
                             "(J1 <= J2 + J3): no mass distribution has them")
        c = np.asarray(com, dtype=float).reshape(-1)
        if c.shape != (3,) or not np.all(np.isfinite(c)):
            raise ValueError(f"com must be a finite 3-vector, got {com!r}")
        P = np.asarray(points, dtype=float).reshape(-1, 3) if len(points) else np.zeros((0, 3))
        if not np.all(np.isfinite(P)):
            raise ValueError("points must be finite")
        O = np.eye(3) if axes is None else np.asarray(axes, dtype=float)
        if O.shape != (3, 3) or not np.allclose(O.T @ O, np.eye(3), atol=1e-10) or np.linalg.det(O) < 0:
            raise ValueError("axes must be a proper 3 × 3 rotation matrix (the directions as columns)")
        nodes = np.concatenate([c[None], P]) - c[None]
        self.q_hat = jnp.asarray(np.concatenate([np.concatenate([x[None], O.T]) for x in nodes]))
        self.is_position = jnp.asarray(np.tile([True, False, False, False], len(nodes)))
        self.vectors_per_node = VECTORS_PER_NODE
        self.mass_value, self.com = jnp.asarray(m), jnp.asarray(c)
        self.inertia, self.axes = jnp.asarray(J), jnp.asarray(O)

    @property
    def n_vectors(self) -> int:
        return int(self.q_hat.shape[0])

    @property
    def n_dof(self) -> int:
        return 3 * self.n_vectors

    @property
    def n_nodes(self) -> int:
        return self.n_vectors // VECTORS_PER_NODE

    @property
    def section_slots(self) -> tuple[int, ...]:
        """Two of a node's axes, g₁ and g₂: its frame for joints (``multibody.section_frame``)."""
        return (1, 2)

    def mass(self) -> Float[Array, ""]:
        return self.mass_value

    def mass_matrix(self) -> Float[Array, "n n"]:
        """The scalar mass matrix on the nodal vectors (module docstring): m on the centre of
        mass's position, Θ' = Oᵀ(½ tr(J) I − J)O on the axes, zero on the attachment points."""
        Theta = 0.5 * jnp.trace(self.inertia) * jnp.eye(3) - self.inertia
        M = jnp.zeros((self.n_vectors, self.n_vectors))
        M = M.at[0, 0].set(self.mass_value)
        return M.at[1:4, 1:4].set(self.axes.T @ Theta @ self.axes)

    def varrho(self) -> Float[Array, " n"]:
        """The weights of a uniform body force: the mass on the centre of mass's position."""
        return jnp.zeros(self.n_vectors).at[0].set(self.mass_value)


def slender_rod(mass, length, start, end, points=()) -> RigidBody:
    """A uniform slender rigid rod from ``start`` to ``end`` (its inertia m L²/12 about the two
    axes normal to it at the centre and a small axial moment, m L² 1e-4, so that the tensor is
    positive definite); attachment points at both ends and at ``points``."""
    a, b = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
    d = b - a
    L = float(np.linalg.norm(d))
    if L <= 0:
        raise ValueError("a rod needs two distinct ends")
    e = d / L
    J = float(mass) * L**2 * ((1.0 / 12.0) * (np.eye(3) - np.outer(e, e)) + 1e-4 * np.outer(e, e))
    return RigidBody(mass, J, com=0.5 * (a + b), points=np.concatenate([a[None], b[None],
                                                                          np.asarray(points, float).reshape(-1, 3)]))


__all__ = ["RigidBody", "slender_rod"]
