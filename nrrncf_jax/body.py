"""A meshed flexible body: element κ's and inertia integrals, index maps, and the elastic
force and tangent stiffness of THEORY §2 (Eqs. 9-11).

κ is stored element by element (``n_e⁴`` numbers each) and every global quantity is assembled
through the element index map; no dense global κ is ever formed.
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ._types import Array, Bool, Float, Int
from .elements.beam import NODAL_VECTORS_PER_NODE, beam_element_integrals
from .material import Material
from .mesh import BeamReference
from .section import TubeSection


class Body(eqx.Module):
    """A flexible body in its own frame: the data of THEORY §1-2.

    Nodal vectors are ordered node by node, ``vectors_per_node`` to a node. A ``chain`` body has
    element e on nodes (e, e+1), which makes every assembled matrix block-tridiagonal.
    """

    q_hat: Float[Array, "n 3"]
    elements: Int[Array, "n_el ne"]
    kappa: Float[Array, "n_el ne ne ne ne"]
    M_e: Float[Array, "n_el ne ne"]
    varrho_e: Float[Array, "n_el ne"]
    mass: Float[Array, ""]
    is_position: Bool[Array, " n"]  # position vectors (a rigid translation moves these only)
    vectors_per_node: int = eqx.field(static=True)
    chain: bool = eqx.field(static=True)

    @property
    def n_vectors(self) -> int:
        return self.q_hat.shape[0]

    @property
    def n_dof(self) -> int:
        return 3 * self.n_vectors

    @property
    def n_nodes(self) -> int:
        return self.n_vectors // self.vectors_per_node

    @property
    def n_elements(self) -> int:
        return self.elements.shape[0]

    # --- elastic energy, force and stiffness (Eqs. 9-11) --------------------------------------
    def _element_Q(self, q: Float[Array, "n 3"]) -> Float[Array, "n_el ne ne"]:
        qe = q[self.elements]
        qh = self.q_hat[self.elements]
        # Q_μν = ½(q_μ·q_ν − q̂_μ·q̂_ν)
        return 0.5 * (jnp.einsum("emi,eni->emn", qe, qe) - jnp.einsum("emi,eni->emn", qh, qh))

    def _theta(self, q: Float[Array, "n 3"]) -> Float[Array, "n_el ne ne"]:
        """Θ_αβ = κ^{αβμν} Q_μν per element (a flat matvec; the hot path)."""
        Q = self._element_Q(q)
        n_el, ne = Q.shape[:2]
        return jnp.einsum("eij,ej->ei", self.kappa.reshape(n_el, ne * ne, ne * ne), Q.reshape(n_el, -1)).reshape(
            n_el, ne, ne
        )

    def strain_energy(self, q: Float[Array, "n 3"]) -> Float[Array, ""]:
        """U = ½ κ^{αβμν} Q_αβ Q_μν."""
        return 0.5 * jnp.sum(self._theta(q) * self._element_Q(q))

    def element_elastic_forces(self, q: Float[Array, "n 3"]) -> Float[Array, "n_el ne 3"]:
        # F^α = κ^{αβμν} Q_μν q_β   (Eq. 9)
        return jnp.einsum("eab,ebi->eai", self._theta(q), q[self.elements])

    def elastic_force(self, q: Float[Array, "n 3"]) -> Float[Array, "n 3"]:
        """F^α = ∂U/∂q_α, assembled."""
        return jnp.zeros_like(q).at[self.elements].add(self.element_elastic_forces(q))

    def element_tangents(self, q: Float[Array, "n 3"]) -> Float[Array, "n_el ne 3 ne 3"]:
        """∂F^α/∂q_β = κ^{αβμν} Q_μν I3 + κ^{αμβν} q_μ q_νᵀ per element (Eq. 11)."""
        qe = q[self.elements]
        theta = self._theta(q)
        kq = jnp.einsum("eambn,emi->eaibn", self.kappa, qe)
        geo = jnp.einsum("eaibn,enj->eaibj", kq, qe)
        return geo + jnp.einsum("eab,ij->eaibj", theta, jnp.eye(3))

    def element_dofs(self) -> Int[Array, "n_el nd"]:
        """Flat DOF indices (3α + i) of each element."""
        n_el, ne = self.elements.shape
        return (3 * self.elements[:, :, None] + jnp.arange(3)).reshape(n_el, 3 * ne)

    def stiffness_matrix(self, q: Float[Array, "n 3"]) -> Float[Array, "ndof ndof"]:
        """Dense tangent stiffness ∂F/∂q (for modal analysis and checks; the integrator
        assembles its own iteration matrix in banded form)."""
        Kt = self.element_tangents(q)
        n_el, ne = self.elements.shape
        dofs = self.element_dofs()
        n = self.n_dof
        return jnp.zeros((n, n)).at[dofs[:, :, None], dofs[:, None, :]].add(Kt.reshape(n_el, 3 * ne, 3 * ne))

    def rigid_modes(self) -> np.ndarray:
        """Infinitesimal rigid motions of the reference: 3 translations (position vectors only)
        and 3 rotations ω × q̂_α (all vectors). Each gives zero elastic force.

        NumPy, on the concrete reference (not traceable): it feeds a one-off check outside any
        trace (``vibration_modes``), where jnp compiled a dozen small kernels op by op."""
        e = np.eye(3)
        trans = np.where(np.asarray(self.is_position)[None, :, None], e[:, None, :], 0.0)
        rot = np.cross(e[:, None, :], np.asarray(self.q_hat)[None, :, :])
        return np.concatenate([trans, rot]).reshape(6, -1).T

    # --- inertia (THEORY §1) ------------------------------------------------------------------
    def mass_matrix(self) -> Float[Array, "n n"]:
        """The scalar M_αβ (the full mass matrix is ``M ⊗ I3``)."""
        n = self.n_vectors
        idx = self.elements
        return jnp.zeros((n, n)).at[idx[:, :, None], idx[:, None, :]].add(self.M_e)

    def varrho(self) -> Float[Array, " n"]:
        """ϱ_α = ∫ρ S_α."""
        return jnp.zeros(self.n_vectors).at[self.elements].add(self.varrho_e)


def beam_body(material: Material, section: TubeSection, reference: BeamReference, n_axial: int = 5) -> Body:
    """Assemble the C1 ANCF beam body: κ, M, ϱ, m of every element (jit-compiled kernel)."""
    q_nodes = reference.q_hat
    n_el = reference.n_elements
    per = NODAL_VECTORS_PER_NODE
    elem_q = jnp.concatenate([q_nodes[:-1], q_nodes[1:]], axis=1)  # (n_el, 12, 3)
    kappa, M_e, varrho_e, m_e = _beam_integrals(elem_q, reference.lengths, material, section, n_axial)
    elements = jnp.arange(n_el)[:, None] * per + jnp.arange(2 * per)[None, :]
    return Body(
        q_hat=q_nodes.reshape(-1, 3),
        elements=elements,
        kappa=kappa,
        M_e=M_e,
        varrho_e=varrho_e,
        mass=jnp.sum(m_e),
        is_position=(jnp.arange(q_nodes.shape[0] * per) % per) == 0,
        vectors_per_node=per,
        chain=True,
    )


_element_integrals_jit = eqx.filter_jit(beam_element_integrals)


def _beam_integrals(elem_q, lengths, material, section, n_axial):
    leaves = jax.tree_util.tree_leaves((elem_q, lengths, material, section))
    if any(isinstance(x, jax.core.Tracer) for x in leaves):
        # Inside a user's jit/grad: one vmapped kernel in their trace.
        return jax.vmap(lambda qh, l: beam_element_integrals(qh, l, material, section, n_axial))(elem_q, lengths)
    # Concrete input: one compiled single-element kernel, called per element, so meshes of any
    # size share one compilation (recompiling per element count costs seconds each).
    per_element = [
        _element_integrals_jit(elem_q[e], lengths[e], material, section, n_axial) for e in range(elem_q.shape[0])
    ]
    return tuple(jnp.stack(parts) for parts in zip(*per_element))
