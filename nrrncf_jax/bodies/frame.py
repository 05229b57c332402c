"""Frames: straight C1 beams rigidly joined at joints of any angle, and pin-ended bars, in one body.

**Rigid joints by links to the joint's gradient.** A joint node carries its position and its full
position gradient ``F = [r_X, r_Y, r_Z]`` (the derivatives along the global reference axes): four
nodal vectors. A beam member leaving the joint along the unit direction d, with section axes
(e₂, e₃), shares the joint's position and keeps its own end vectors
``[r_ξ, r_η, r_ξη, r_ζ, r_ξζ]``; an ``elements.JointLink`` ties its end triad (r_ξ, r_η, r_ζ) to
the joint's gradient along its directions (F d, F e₂, F e₃) in relative rotation and
axis–section shear, not in stretch. Every member at the joint is linked to the same F, so the joint transmits forces,
bending moments and torque and keeps the angles between the members' axes and sections (under a
rigid rotation of the frame F is the rotation and every member turns with it). The link is
quartic in the nodal vectors with a constant κ, so the frame stays one body with one sparse
matrix, and the reduction's tensors take it like any element.

F itself carries an ``elements.JointCell``, the elastic energy of the joint's own small solid
(default: a cube of the members' outer diameter), which gives F's stretches their stiffness
(nothing else resists them) and keeps F a rotation to within the joint's own compliance,
independent of the mesh.

**Why links, not a shared F.** Shabana & Mikkola's gradient transformation (*J. Mech. Des.* 125,
2003) makes each member's end triad *equal* to F times its directions. That ties the members'
strains at the joint point too, not only their rotations: a batten's section strain along the
truss axis becomes the longeron's axial strain there, and the element next to the joint carries
that constraint over its length, an over-stiffening of O(element length) that refinement removes
only slowly. With links the frequencies hardly change under refinement. The price is five more
nodal vectors at each member end.

**Pins**: a bar (``elements.Bar``) joins the position vectors of two joints and nothing else, so
it carries axial force only.

Interior nodes of a member carry the beam's own six vectors ``[r, r_ξ, r_η, r_ξη, r_ζ, r_ξζ]``.
"""

import dataclasses

import numpy as np

from ..elements.bar import Bar
from ..elements.beam import C1Beam
from ..elements.joint_cell import JointCell
from ..elements.joint_link import JointLink
from .body import Body, element_group

JOINT_VECTORS = 4
"""A joint node's nodal vectors: r, r_X, r_Y, r_Z (position and full gradient)."""


def section_axes(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Section axes (e₂, e₃) of a member along the unit vector d: e₂ = Z × d normalised (a member
    along X gets e₂ = Y, e₃ = Z, as ``mesh.straight_reference``), for a member along ±Z
    e₂ = d × X normalised; e₃ = d × e₂. (Circular sections, as here, do not care.)"""
    e2 = np.cross([0.0, 0.0, 1.0], d)
    if np.linalg.norm(e2) < 1e-8:
        e2 = np.cross(d, [1.0, 0.0, 0.0])
    e2 = e2 / np.linalg.norm(e2)
    return e2, np.cross(d, e2)


@dataclasses.dataclass(frozen=True)
class Frame:
    """A frame body and where its things are.

    ``joint_vectors[j]``: the nodal vectors [r, r_X, r_Y, r_Z] of joint j (clamp all four for a
    fully fixed joint); ``member_positions[m]``: the position vectors along member m from its start
    joint to its end joint (interior nodes included); ``n_beams``/``n_bars``: element counts."""

    body: Body
    joint_vectors: np.ndarray  # (n_joints, 4)
    member_positions: tuple[np.ndarray, ...]
    n_beams: int
    n_bars: int

    def clamp(self, joints) -> np.ndarray:
        """The nodal vectors that fix the given joints fully (position and gradient)."""
        return self.joint_vectors[np.asarray(joints, dtype=int)].reshape(-1)


def frame_body(joints, members, beam: C1Beam, n_elements, bars=(), bar: Bar | None = None,
               joint_volume: float | None = None, link_stiffness: float | None = None) -> Frame:
    """A frame of straight beam ``members`` (m × 2 joint indices, each meshed with ``n_elements``
    C1 elements of the element type ``beam``; an integer or one per member) rigidly joined at
    ``joints`` (n × 3 reference positions), and pin-ended ``bars`` (k × 2 joint indices) of the
    element type ``bar``. See the module docstring for the joint:

    - every joint gets a ``JointCell`` of the beam's material and ``joint_volume`` [m³] (default:
      a cube of the section's outer diameter);
    - every member end a ``JointLink`` of stiffness ``link_stiffness`` [N m] (default
      ``10 G A ℓ``, ten times the shear stiffness of the shortest member ℓ over its whole length:
      its compliance is below 1e-4 of the members' in the frame test, so the joint is rigid to
      that accuracy on any mesh)."""
    joints = np.asarray(joints, dtype=float)
    members = np.asarray(members, dtype=int).reshape(-1, 2)
    bars = np.asarray(bars, dtype=int).reshape(-1, 2)
    if joints.ndim != 2 or joints.shape[1] != 3:
        raise ValueError(f"joints must have shape (n_joints, 3), got {joints.shape}")
    n_j = len(joints)
    for name, pairs in (("members", members), ("bars", bars)):
        if pairs.size and (pairs.min() < 0 or pairs.max() >= n_j):
            raise ValueError(f"{name} refer to joint {int(pairs.max())} (or a negative one); there are {n_j} joints")
        if pairs.size and np.any(pairs[:, 0] == pairs[:, 1]):
            raise ValueError(f"{name} {np.flatnonzero(pairs[:, 0] == pairs[:, 1]).tolist()} join a joint to itself")
    if not isinstance(beam, C1Beam):
        raise ValueError(f"beam must be an elements.C1Beam, got {type(beam).__name__}")
    if len(bars) and not isinstance(bar, Bar):
        raise ValueError("bars need their element type: bar=elements.Bar(E, rho, area)")
    n_el = np.broadcast_to(np.asarray(n_elements, dtype=int), (len(members),))
    if len(members) == 0:
        raise ValueError("a frame needs at least one beam member")
    if n_el.min() < 1:
        raise ValueError(f"n_elements must be positive integers, got {n_el.tolist()}")
    used = np.zeros(n_j, bool)
    used[members.reshape(-1)] = True
    used[bars.reshape(-1)] = True
    if not used.all():
        raise ValueError(f"joints {np.flatnonzero(~used)[:10].tolist()} belong to no member or bar")

    eye = np.eye(3)
    q_hat = []  # the reference nodal vectors, appended in order

    def add(vectors):
        start = len(q_hat)
        q_hat.extend(np.asarray(vectors, dtype=float))
        return np.arange(start, start + len(vectors))

    joint_vectors = np.stack([add([p, eye[0], eye[1], eye[2]]) for p in joints])

    conn, lengths, positions, links, link_T, member_lengths = [], [], [], [], [], []
    for (a, b), n in zip(members, n_el):
        span = joints[b] - joints[a]
        L = np.linalg.norm(span)
        if L <= 1e-12 * max(1.0, np.abs(joints).max()):
            raise ValueError(f"member ({a}, {b}) has zero length")
        member_lengths.append(L)
        d = span / L
        e2, e3 = section_axes(d)
        R = np.stack([d, e2, e3])  # rows: the member's directions in global components
        z = np.zeros(3)
        # Per node of the member: its six slots [r, r_ξ, r_η, r_ξη, r_ζ, r_ξζ] as body vectors.
        nodes = []
        for k in range(n + 1):
            if k in (0, n):
                j = joint_vectors[a if k == 0 else b]
                own = add([d, e2, z, e3, z])  # the member's own r_ξ, r_η, r_ξη, r_ζ, r_ξζ at the joint
                nodes.append(np.array([j[0], *own]))
                # the link: [r_ξ, r_η, r_ζ] against F's columns, turned to (F d, F e₂, F e₃) by R
                links.append(np.array([own[0], own[1], own[3], j[1], j[2], j[3]]))
                link_T.append(np.block([[np.eye(3), np.zeros((3, 3))], [np.zeros((3, 3)), R]]))
            else:
                c = joints[a] + (k / n) * span
                nodes.append(add([c, d, e2, z, e3, z]))
        positions.append(np.array([v[0] for v in nodes]))
        conn += [np.concatenate([nodes[k], nodes[k + 1]]) for k in range(n)]
        lengths += [L / n] * n
    q_hat = np.asarray(q_hat)
    volume = float((2.0 * beam.section.r_outer) ** 3) if joint_volume is None else float(joint_volume)
    if not volume > 0.0:
        raise ValueError(f"joint_volume must be > 0 (F's stretches have no other stiffness), got {volume}")
    k_link = (10.0 * float(beam.material.G * beam.section.area) * min(member_lengths)
              if link_stiffness is None else float(link_stiffness))
    if not k_link > 0.0:
        raise ValueError(f"link_stiffness must be > 0, got {k_link}")
    groups = [element_group(beam, q_hat, np.asarray(conn), np.asarray(lengths)),
              element_group(JointCell(beam.material, volume), q_hat, joint_vectors[:, 1:], np.ones(n_j)),
              element_group(JointLink(k_link), q_hat, np.asarray(links), np.ones(len(links)), np.asarray(link_T))]
    if len(bars):
        bar_conn = joint_vectors[bars, 0]
        bar_len = np.linalg.norm(joints[bars[:, 1]] - joints[bars[:, 0]], axis=1)
        if bar_len.min() <= 1e-12 * max(1.0, np.abs(joints).max()):
            raise ValueError(f"bars {np.flatnonzero(bar_len <= 1e-12)[:10].tolist()} have zero length")
        groups.append(element_group(bar, q_hat, bar_conn, bar_len))
    is_position = np.zeros(len(q_hat), bool)
    is_position[joint_vectors[:, 0]] = True
    for p in positions:
        is_position[p] = True
    body = Body(q_hat, groups, is_position=is_position, vectors_per_node=1)
    return Frame(body=body, joint_vectors=joint_vectors, member_positions=tuple(positions),
                 n_beams=int(n_el.sum()), n_bars=len(bars))


__all__ = ["JOINT_VECTORS", "Frame", "frame_body", "section_axes"]
