"""A meshed flexible body: groups of elements on one set of nodal vectors, and the elastic
force, tangent stiffness and inertia of docs/theory.md, §1 RNCF kinematics and §2 Elastic force (Eqs. 9-11).

A body holds one ``ElementGroup`` per element type (beams, bars, ...), each with the element
integrals stacked element by element (κ: ``n_e⁴`` numbers each) and its connectivity into the
body's nodal vectors. Every global quantity is the sum over the groups, assembled through the
connectivity; no dense global κ is ever formed.
"""

from collections.abc import Sequence

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._static import StaticIndices
from .._types import Array, Bool, Float, Int
from ..elements.base import AbstractElement
from ..elements.beam import C1Beam
from ..elements.material import Material
from ..elements.section import TubeSection
from .mesh import BeamReference


class ElementGroup(eqx.Module):
    """Elements of one type on a body's nodal vectors: ``elements[e]`` lists the body's nodal
    vectors of element e (its n_e vectors in the element's order), with their integrals.

    The connectivity is static data (NumPy, ``_static.StaticIndices``): the structure of every
    assembled matrix, and the solver chosen for it, follow from it before anything is traced, so
    a model can be built inside ``jit``, ``grad`` or ``vmap``."""

    element: AbstractElement
    connectivity: StaticIndices = eqx.field(static=True)
    kappa: Float[Array, "n_el ne ne ne ne"]
    M_e: Float[Array, "n_el ne ne"]
    varrho_e: Float[Array, "n_el ne"]
    m_e: Float[Array, " n_el"]

    @property
    def elements(self) -> np.ndarray:
        """``(n_el, n_e)``: element e's nodal vectors (NumPy, read-only)."""
        return self.connectivity.array

    @property
    def n_elements(self) -> int:
        return self.elements.shape[0]

    @property
    def mass(self) -> Float[Array, ""]:
        return jnp.sum(self.m_e)

    def Q(self, q: Float[Array, "n 3"], q_hat: Float[Array, "n 3"]) -> Float[Array, "n_el ne ne"]:
        """Q_μν = ½(q_μ·q_ν − q̂_μ·q̂_ν) per element."""
        qe, qh = q[self.elements], q_hat[self.elements]
        return 0.5 * (jnp.einsum("emi,eni->emn", qe, qe) - jnp.einsum("emi,eni->emn", qh, qh))

    def theta(self, q, q_hat) -> Float[Array, "n_el ne ne"]:
        """Θ_αβ = κ^{αβμν} Q_μν per element (a flat matvec; the hot path)."""
        Q = self.Q(q, q_hat)
        n_el, ne = Q.shape[:2]
        k = self.kappa.reshape(n_el, ne * ne, ne * ne)
        return jnp.einsum("eij,ej->ei", k, Q.reshape(n_el, -1)).reshape(n_el, ne, ne)

    def strain_energy(self, q, q_hat) -> Float[Array, ""]:
        """U = ½ κ^{αβμν} Q_αβ Q_μν."""
        return 0.5 * jnp.sum(self.theta(q, q_hat) * self.Q(q, q_hat))

    def forces(self, q, q_hat) -> Float[Array, "n_el ne 3"]:
        """F^α = κ^{αβμν} Q_μν q_β per element (Eq. 9)."""
        return jnp.einsum("eab,ebi->eai", self.theta(q, q_hat), q[self.elements])

    def tangents(self, q, q_hat) -> Float[Array, "n_el ne 3 ne 3"]:
        """∂F^α/∂q_β = κ^{αβμν} Q_μν I3 + κ^{αμβν} q_μ q_νᵀ per element (Eq. 11)."""
        qe = q[self.elements]
        kq = jnp.einsum("eambn,emi->eaibn", self.kappa, qe)
        geo = jnp.einsum("eaibn,enj->eaibj", kq, qe)
        return geo + jnp.einsum("eab,ij->eaibj", self.theta(q, q_hat), jnp.eye(3))

    def dofs(self) -> np.ndarray:
        """Flat DOF indices (3α + i) of each element, ``(n_el, 3 n_e)`` (NumPy, static)."""
        n_el, ne = self.elements.shape
        return (3 * self.elements[:, :, None] + np.arange(3)).reshape(n_el, 3 * ne)


_integrals_jit = eqx.filter_jit(lambda element, q_hat, length: element.integrals(q_hat, length))
_integrals_vmap = eqx.filter_jit(lambda element, q_hat, length: jax.vmap(element.integrals)(q_hat, length))
_CHUNK = 64  # elements per vmapped call when integrating large meshes


def element_group(element: AbstractElement, q_hat: Float[Array, "n 3"], elements, lengths=None,
                  transforms=None) -> ElementGroup:
    """The group of ``element``-type elements with connectivity ``elements`` (n_el × n_e indices
    into the nodal vectors ``q_hat``), integrals computed from the reference configuration.
    ``lengths``: each element's reference length (default: the distance between the position
    vectors of its first and last node).

    ``transforms`` (n_el × n_e × n_e, optional): element e's own nodal vectors are the linear
    combinations ``q^e_α = T_αA q_{elements[e, A]}`` of the body's, not the body's vectors
    themselves: e.g. a frame's joint link (``frame.frame_body``), which sees the joint's full
    position gradient F along a member's directions, F d = Σ d_K r_K. Q is bilinear in the
    vectors, so ``Q^e = T Q Tᵀ`` and the integrals in the body's vectors are
    ``κ^{ABCD} = T_αA T_βB T_μC T_νD κ^{αβμν}``, ``Tᵀ M T``, ``Tᵀ ϱ``: constant still, and the
    group computes with them as with any other (Shabana & Mikkola's gradient transformation,
    2003)."""
    elements = StaticIndices(elements).array
    ne = element.vectors
    if elements.ndim != 2 or elements.shape[1] != ne:
        raise ValueError(f"{type(element).__name__} elements need {ne} nodal vectors each: connectivity of shape "
                         f"(n_elements, {ne}), got {tuple(elements.shape)}")
    if isinstance(elements, np.ndarray):
        n = q_hat.shape[0]
        if elements.size and (elements.min() < 0 or elements.max() >= n):
            raise ValueError(f"connectivity refers to nodal vector {int(elements.max())} (or a negative one); the "
                             f"body has {n}")
    q_e = jnp.asarray(q_hat)[elements]  # (n_el, ne, 3)
    if transforms is not None:
        transforms = jnp.asarray(transforms, dtype=float)
        if transforms.shape != (elements.shape[0], ne, ne):
            raise ValueError(f"transforms must have shape ({elements.shape[0]}, {ne}, {ne}), got "
                             f"{tuple(transforms.shape)}")
        q_e = jnp.einsum("eab,ebi->eai", transforms, q_e)  # the elements' own reference vectors
    if lengths is None:
        first, last = element.position_slots[0], (element.nodes - 1) * element.vectors_per_node
        lengths = jnp.linalg.norm(q_e[:, last] - q_e[:, first], axis=-1)
    lengths = jnp.asarray(lengths, dtype=float)
    leaves = jax.tree_util.tree_leaves((q_e, lengths, element))
    if any(isinstance(x, jax.core.Tracer) for x in leaves):
        # Inside a user's jit/grad: one vmapped kernel in their trace.
        ints = jax.vmap(element.integrals)(q_e, lengths)
    elif q_e.shape[0] <= _CHUNK:
        # Concrete input: one compiled single-element kernel, called per element (NumPy slices:
        # indexing a jax array costs a dispatch each), so meshes of any size share one
        # compilation instead of compiling again for every element count.
        q_np, len_np = np.asarray(q_e), np.asarray(lengths)
        per_element = [_integrals_jit(element, q_np[e], len_np[e]) for e in range(q_np.shape[0])]
        ints = [jnp.stack(parts) for parts in zip(*per_element)]
    else:
        # Large meshes: a vmapped kernel over chunks of _CHUNK elements (the last one padded by
        # repeating its last element), compiled once for the chunk's shape: per-element calls,
        # one dispatch each, would dominate the build of a large mesh.
        n_el = q_e.shape[0]
        pad = -n_el % _CHUNK
        q_np = np.concatenate([np.asarray(q_e), np.repeat(np.asarray(q_e)[-1:], pad, axis=0)])
        len_np = np.concatenate([np.asarray(lengths), np.repeat(np.asarray(lengths)[-1:], pad)])
        chunks = [_integrals_vmap(element, q_np[i:i + _CHUNK], len_np[i:i + _CHUNK])
                  for i in range(0, n_el + pad, _CHUNK)]
        ints = [jnp.concatenate([np.asarray(c[k]) for c in chunks])[:n_el] for k in range(4)]
    kappa, M, varrho, m = ints
    if transforms is not None:
        T = transforms
        kappa = jnp.einsum("eabmn,eaA,ebB,emC,enD->eABCD", kappa, T, T, T, T)
        M = jnp.einsum("eab,eaA,ebB->eAB", M, T, T)
        varrho = jnp.einsum("ea,eaA->eA", varrho, T)
    return ElementGroup(element=element, connectivity=StaticIndices(elements), kappa=kappa, M_e=M, varrho_e=varrho,
                        m_e=m)


DENSE_MASS_MAX_VECTORS = 1000
"""Up to this many nodal vectors, mass products use the assembled scalar M_αβ (8 MB and a 10⁶-flop
product at the limit); above it they go element by element (``Body.mass_product``)."""


class Body(eqx.Module):
    """A flexible body in its own frame: the data of docs/theory.md, §1 RNCF kinematics and §2 Elastic force.

    ``q_hat``: the stress-free nodal vectors (n × 3); ``groups``: the element groups on them;
    ``is_position``: which nodal vectors are positions (a rigid translation moves these only).
    Nodal vectors are ordered node by node, ``vectors_per_node`` to a node. A ``chain`` body
    has a single group whose element e is on nodes (e, e+1), which makes every assembled matrix
    block-tridiagonal.
    """

    q_hat: Float[Array, "n 3"]
    groups: tuple[ElementGroup, ...]
    is_position: Bool[Array, " n"]
    vectors_per_node: int = eqx.field(static=True)
    chain: bool = eqx.field(static=True)

    def __init__(self, q_hat, groups: Sequence[ElementGroup], is_position, vectors_per_node: int = 1,
                 chain: bool = False):
        self.q_hat = jnp.asarray(q_hat, dtype=float)
        self.groups = tuple(groups)
        self.is_position = jnp.asarray(is_position, dtype=bool)
        self.vectors_per_node = int(vectors_per_node)
        self.chain = bool(chain)
        if self.q_hat.ndim != 2 or self.q_hat.shape[1] != 3:
            raise ValueError(f"q_hat must have shape (n_vectors, 3), got {self.q_hat.shape}")
        if not self.groups:
            raise ValueError("a body needs at least one element group")
        if self.is_position.shape != (self.q_hat.shape[0],):
            raise ValueError(f"is_position must have shape ({self.q_hat.shape[0]},), got {self.is_position.shape}")
        if self.chain and len(self.groups) != 1:
            raise ValueError("a chain body has exactly one element group")
        used = np.zeros(self.q_hat.shape[0], bool)
        for g in self.groups:
            used[g.elements.reshape(-1)] = True
        if not used.all():
            raise ValueError(f"nodal vectors {np.flatnonzero(~used)[:10].tolist()} belong to no element")

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
    def section_slots(self) -> tuple[int, ...]:
        """The slots of a node's two section vectors (``AbstractElement.section_slots``), where
        every element group's element agrees and lays out its nodes as the body does; else none."""
        slots = {g.element.section_slots if g.element.vectors_per_node == self.vectors_per_node else ()
                 for g in self.groups}
        return slots.pop() if len(slots) == 1 else ()

    @property
    def n_elements(self) -> int:
        return sum(g.n_elements for g in self.groups)

    @property
    def mass(self) -> Float[Array, ""]:
        return sum(g.mass for g in self.groups)

    # --- elastic energy, force and stiffness (Eqs. 9-11) --------------------------------------
    def strain_energy(self, q: Float[Array, "n 3"]) -> Float[Array, ""]:
        """U = ½ κ^{αβμν} Q_αβ Q_μν, summed over the groups."""
        return sum(g.strain_energy(q, self.q_hat) for g in self.groups)

    def elastic_force(self, q: Float[Array, "n 3"]) -> Float[Array, "n 3"]:
        """F^α = ∂U/∂q_α, assembled."""
        F = jnp.zeros_like(q)
        for g in self.groups:
            F = F.at[g.elements].add(g.forces(q, self.q_hat))
        return F

    def tangent_parts(self, q: Float[Array, "n 3"]) -> list[tuple[Float[Array, "n_el nd nd"], Int[Array, "n_el nd"]]]:
        """The element tangent stiffnesses ∂F/∂q of each group as flat ``(n_el, 3n_e, 3n_e)``
        blocks with their DOFs: what ``linalg.assemble_and_factor`` assembles."""
        parts = []
        for g in self.groups:
            n_el, ne = g.elements.shape
            parts.append((g.tangents(q, self.q_hat).reshape(n_el, 3 * ne, 3 * ne), g.dofs()))
        return parts

    def stiffness_matrix(self, q: Float[Array, "n 3"]) -> Float[Array, "ndof ndof"]:
        """Dense tangent stiffness ∂F/∂q (for modal analysis and checks; the integrator
        assembles its own iteration matrix in its solver's storage)."""
        n = self.n_dof
        K = jnp.zeros((n, n), q.dtype)
        for Ke, dofs in self.tangent_parts(q):
            K = K.at[dofs[:, :, None], dofs[:, None, :]].add(Ke)
        return K

    def rigid_modes(self) -> np.ndarray:
        """Infinitesimal rigid motions of the reference: 3 translations (position vectors only)
        and 3 rotations ω × q̂_α (all vectors). Each gives zero elastic force.

        NumPy, on the concrete reference (not traceable): it feeds a one-off check outside any
        trace (``vibration_modes``), where jnp compiled a dozen small kernels op by op."""
        e = np.eye(3)
        trans = np.where(np.asarray(self.is_position)[None, :, None], e[:, None, :], 0.0)
        rot = np.cross(e[:, None, :], np.asarray(self.q_hat)[None, :, :])
        return np.concatenate([trans, rot]).reshape(6, -1).T

    # --- inertia (docs/theory.md, §1 RNCF kinematics) -----------------------------------------
    def mass_matrix(self) -> Float[Array, "n n"]:
        """The scalar M_αβ (the full mass matrix is ``M ⊗ I3``)."""
        n = self.n_vectors
        M = jnp.zeros((n, n))
        for g in self.groups:
            M = M.at[g.elements[:, :, None], g.elements[:, None, :]].add(g.M_e)
        return M

    def mass_product(self, X: Float[Array, "n ..."]) -> Float[Array, "n ..."]:
        """Σ_β M_αβ X_β (the product ``(M ⊗ I) X`` for X with a leading nodal-vector axis), element
        by element: O(n_el n_e²) work and no n × n matrix, for bodies too large for a dense M."""
        out = jnp.zeros_like(X)
        for g in self.groups:
            out = out.at[g.elements].add(jnp.einsum("eab,eb...->ea...", g.M_e, X[g.elements]))
        return out

    def mass_parts(self) -> list[tuple[Float[Array, "n_el ne ne"], Int[Array, "n_el ne"]]]:
        """The scalar element mass matrices of each group with their nodal vectors."""
        return [(g.M_e, g.elements) for g in self.groups]

    def varrho(self) -> Float[Array, " n"]:
        """ϱ_α = ∫ρ S_α."""
        v = jnp.zeros(self.n_vectors)
        for g in self.groups:
            v = v.at[g.elements].add(g.varrho_e)
        return v


def stiffened(body: Body, s) -> Body:
    """``body`` with its elastic tensors κ times ``s`` (every group): Young's modulus scaled by s
    at a fixed Poisson ratio, κ being linear in E; differentiable in ``s``."""
    return eqx.tree_at(lambda b: [g.kappa for g in b.groups], body, [s * g.kappa for g in body.groups])


def beam_body(material: Material, section: TubeSection, reference: BeamReference, n_axial: int = 5) -> Body:
    """The C1 ANCF beam body on a reference centreline: one chain group of ``C1Beam`` elements."""
    element = C1Beam(material, section, n_axial)
    q_nodes = reference.q_hat
    n_el = reference.n_elements
    per = element.vectors_per_node
    elements = np.arange(n_el)[:, None] * per + np.arange(2 * per)[None, :]
    q_hat = q_nodes.reshape(-1, 3)
    group = element_group(element, q_hat, elements, reference.lengths)
    return Body(q_hat, [group], is_position=(np.arange(q_hat.shape[0]) % per) == 0, vectors_per_node=per, chain=True)


def truss_body(nodes, connectivity, bar: AbstractElement) -> Body:
    """A pin-jointed truss: one position vector per node (``nodes``, n × 3) and one ``bar``
    element (e.g. ``elements.Bar``) per row of ``connectivity`` (n_bars × 2 node indices)."""
    nodes = np.asarray(nodes, dtype=float)
    conn = np.asarray(connectivity)
    if nodes.ndim != 2 or nodes.shape[1] != 3:
        raise ValueError(f"nodes must have shape (n_nodes, 3), got {nodes.shape}")
    if conn.ndim != 2 or conn.shape[1] != 2 or conn.size == 0:
        raise ValueError(f"connectivity must have shape (n_bars, 2), got {conn.shape}")
    if conn.min() < 0 or conn.max() >= len(nodes):
        raise ValueError(f"connectivity refers to node {int(conn.max())} (or a negative one); there are {len(nodes)}")
    lengths = np.linalg.norm(nodes[conn[:, 1]] - nodes[conn[:, 0]], axis=1)
    short = np.flatnonzero(lengths <= 1e-12 * max(1.0, float(np.abs(nodes).max())))
    if short.size:
        raise ValueError(f"bars {short.tolist()} have zero length")
    group = element_group(bar, nodes, conn, lengths)
    return Body(nodes, [group], is_position=np.ones(len(nodes), bool), vectors_per_node=1)
