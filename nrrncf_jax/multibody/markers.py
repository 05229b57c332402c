"""Joints in physical terms: markers (a body and a point of its reference configuration) and joint
specifications on them, which a system turns into the nodal-vector joints of ``joints``.

A multibody engineer says "a hinge about Z at the rod's left end"; the joints of ``joints`` say
``Revolute(k, end + R, (end + RX, end + RY), k + 1, R, RZ)``, nodal-vector indices of the C1
element's layout. ``Marker(body, point)`` names the point (in the system's frame, in the
reference configuration: where the placed body's stress-free state puts it), and
``hinge(a, b, axis)``, ``ball(a, b)`` and ``clamp(a, b)`` the joint; a system
(``MultibodySystem``, ``FloatingFrameSystem``) resolves them once, from its bodies' reference
nodal vectors, before anything is traced:

- a point is a node's position vector: the one position vector of the body at that point (to
  ``POINT_TOL`` of the body's size), else ``ValueError`` naming the nearest node;
- a direction at that node is one of the node's unit gradient vectors (for a C1 beam its slope r_x
  and its section vectors r_y, r_z): the one parallel to it (to ``ANGLE_TOL``), and the plane
  normal to an axis is spanned by the node's two unit gradient vectors normal to it.

The joint's equations are then those of ``joints`` (quadratic in the nodal vectors): the markers
change how a joint is written, not what it imposes.
"""

import dataclasses

import numpy as np

from .drivers import AngleDriver, DistanceDriver
from .joints import Fixed, Revolute, Spherical
from .prismatic import Prismatic
from .weld import Weld

POINT_TOL = 1e-9
"""A marker's point matches a node when closer than this times the body's size."""

ANGLE_TOL = 1e-9
"""A direction matches a gradient vector when |sin| of their angle is below this."""


@dataclasses.dataclass(frozen=True)
class Marker:
    """A point of body ``body`` (its index in the system) in the system's frame, in the reference
    (stress-free, initial) configuration."""

    body: int
    point: tuple[float, float, float]

    def __post_init__(self):
        p = np.asarray(self.point, dtype=float).reshape(-1)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise ValueError(f"a marker's point must be a finite 3-vector, got {self.point!r}")
        object.__setattr__(self, "point", tuple(float(x) for x in p))
        object.__setattr__(self, "body", int(self.body))


@dataclasses.dataclass(frozen=True)
class BodyGeometry:
    """What marker resolution reads of a body: its reference nodal vectors (n × 3, in the system's
    frame), which are positions, how many vectors a node carries, and which vectors only turn
    with a frame (a rigid body's, a floating frame's held ones: a clamp there is a ``Weld``)."""

    vectors: np.ndarray
    is_position: np.ndarray
    vectors_per_node: int
    rigid: frozenset = frozenset()  # vectors that only turn with the body's frame (no deformation)

    def node(self, marker: Marker) -> int:
        """The position vector at the marker's point."""
        pos = np.flatnonzero(self.is_position)
        d = np.linalg.norm(self.vectors[pos] - np.asarray(marker.point), axis=1)
        size = max(1.0, float(np.ptp(self.vectors[pos], axis=0).max()))
        i = int(np.argmin(d))
        if d[i] > POINT_TOL * size:
            raise ValueError(f"marker point {marker.point} is not a node of body {marker.body}: the nearest node is "
                             f"{tuple(float(x) for x in self.vectors[pos[i]])}, {d[i]:.3g} away")
        return int(pos[i])

    def unit_gradients(self, node: int) -> list[int]:
        """The node's gradient vectors of unit length in the reference (the frame directions: a C1
        beam's r_x, r_y, r_z; not r_xy, r_xz), in the node's order."""
        first = node - node % self.vectors_per_node
        block = range(first, first + self.vectors_per_node)
        return [v for v in block if not self.is_position[v] and abs(np.linalg.norm(self.vectors[v]) - 1.0) < 1e-6]

    def along(self, node: int, direction, what: str) -> int:
        """The node's unit gradient vector parallel to ``direction``."""
        e = _unit(direction)
        if not self.unit_gradients(node):
            raise ValueError(f"{what}: the node at {tuple(float(x) for x in self.vectors[node])} carries no direction "
                             "(a point mass, a bar's node): put the joint on a body with directions there")
        for v in self.unit_gradients(node):
            if np.linalg.norm(np.cross(self.vectors[v], e)) < ANGLE_TOL:
                return v
        raise ValueError(f"{what} {tuple(e)} is along none of the node's gradient vectors "
                         f"{[tuple(np.round(self.vectors[v], 12)) for v in self.unit_gradients(node)]}")

    def normal_to(self, node: int, direction, what: str) -> tuple[int, int]:
        """The node's two unit gradient vectors normal to ``direction``."""
        e = _unit(direction)
        normal = [v for v in self.unit_gradients(node) if abs(float(self.vectors[v] @ e)) < ANGLE_TOL]
        if len(normal) != 2:
            raise ValueError(f"{what} {tuple(e)}: the node has {len(normal)} unit gradient vectors normal to it, "
                             "not two")
        return normal[0], normal[1]


def _unit(direction) -> np.ndarray:
    e = np.asarray(direction, dtype=float).reshape(-1)
    if e.shape != (3,) or not np.all(np.isfinite(e)) or np.linalg.norm(e) == 0:
        raise ValueError(f"a direction must be a finite nonzero 3-vector, got {direction!r}")
    return e / np.linalg.norm(e)


@dataclasses.dataclass(frozen=True)
class JointSpec:
    """A joint on markers (``hinge``, ``ball``, ``clamp``), resolved by the system into a joint of
    ``joints`` (``resolve``). ``a`` is None for the ground."""

    kind: str
    a: Marker | None
    b: Marker
    axis: tuple[float, float, float] | None = None
    drive: object = None  # a motion, motion(t)[0] the prescribed angle or travel (``drivers``)

    def resolve(self, geometry: tuple[BodyGeometry, ...]):
        """The nodal-vector joint of these markers on the system's bodies."""
        for m in (self.a, self.b):
            if m is not None and not 0 <= m.body < len(geometry):
                raise ValueError(f"{self.kind}: marker on body {m.body}; the system has bodies 0..{len(geometry) - 1}")
        gb = geometry[self.b.body]
        nb = gb.node(self.b)
        if self.kind == "ball":
            if self.a is None:
                return Spherical(self.b.body, nb, point=self.b.point)
            return Spherical(self.a.body, geometry[self.a.body].node(self.a), self.b.body, nb)
        if self.kind == "hinge":
            axis_b = gb.along(nb, self.axis, "hinge axis")
            if self.a is None:
                joint = Revolute(None, None, None, self.b.body, nb, axis_b, point=self.b.point, axis=self.axis)
            else:
                ga = geometry[self.a.body]
                na = ga.node(self.a)
                if np.linalg.norm(ga.vectors[na] - gb.vectors[nb]) > POINT_TOL * max(1.0, np.abs(gb.vectors).max()):
                    raise ValueError(f"hinge: the markers' points differ, {self.a.point} and {self.b.point}")
                joint = Revolute(self.a.body, na, ga.normal_to(na, self.axis, "hinge axis"), self.b.body, nb, axis_b)
            if self.drive is None:
                return joint
            *bodies_and_vectors, ground = hinge_directions(geometry, self.a, self.b, self.axis)
            return joint, AngleDriver(*bodies_and_vectors, self.drive, ground=ground)
        if self.kind == "slider":
            axis = np.asarray(self.axis)
            axis_b = gb.along(nb, axis, "slider axis")
            if self.a is None:
                m_b = gb.normal_to(nb, axis, "slider axis")[0]
                m = gb.vectors[m_b] / np.linalg.norm(gb.vectors[m_b])
                joint = Prismatic(None, None, None, self.b.body, nb, axis_b, m_b, point=self.b.point,
                                  normals=(m, np.cross(axis, m)))
                driver = None if self.drive is None else DistanceDriver(None, None, None, self.b.body, nb, self.drive,
                                                                        point=self.b.point, axis=axis)
            else:
                ga = geometry[self.a.body]
                na = ga.node(self.a)
                gap = gb.vectors[nb] - ga.vectors[na]
                if np.linalg.norm(np.cross(gap, axis)) > POINT_TOL * max(1.0, np.abs(gb.vectors).max()):
                    raise ValueError(f"slider: the markers' points {self.a.point} and {self.b.point} are not on one "
                                     f"line along the axis {tuple(axis)}")
                normals = ga.normal_to(na, axis, "slider axis")
                m_b = gb.along(nb, ga.vectors[normals[0]], "the slider's reference direction")
                joint = Prismatic(self.a.body, na, normals, self.b.body, nb, axis_b, m_b)
                driver = None if self.drive is None else DistanceDriver(
                    self.a.body, na, ga.along(na, axis, "slider axis"), self.b.body, nb, self.drive,
                    s_ref=float(gap @ axis))
            return joint if driver is None else (joint, driver)
        if self.kind == "clamp":
            return self._clamp(geometry, gb, nb)
        raise ValueError(f"unknown joint kind {self.kind!r}")

    def _clamp(self, geometry, gb: BodyGeometry, nb: int):
        """A clamp: a ``Weld`` (six equations) where both nodes' directions only turn with their
        frames (rigid bodies, floating frames' held nodes), else ``Fixed`` on the position and
        the unit gradient vectors (twelve, mixed where the two nodes' vectors differ)."""
        vb = [nb] + gb.unit_gradients(nb)
        rigid_b = [v for v in gb.unit_gradients(nb) if v in gb.rigid]
        if self.a is None:
            if len(rigid_b) >= 2:
                d = gb.vectors[rigid_b[:2]]
                return Weld(None, None, None, self.b.body, nb, rigid_b[:2], Weld.reference_relation(d, d),
                            point=gb.vectors[nb], ground=d)
            return Fixed(self.b.body, vb, values=gb.vectors[vb])
        ga = geometry[self.a.body]
        na = ga.node(self.a)
        if np.linalg.norm(ga.vectors[na] - gb.vectors[nb]) > POINT_TOL * max(1.0, np.abs(gb.vectors).max()):
            raise ValueError(f"clamp: the markers' points differ, {self.a.point} and {self.b.point}")
        rigid_a = [v for v in ga.unit_gradients(na) if v in ga.rigid]
        if len(rigid_a) >= 2 and len(rigid_b) >= 2:
            return Weld(self.a.body, na, rigid_a[:2], self.b.body, nb, rigid_b[:2],
                        Weld.reference_relation(ga.vectors[rigid_a[:2]], gb.vectors[rigid_b[:2]]))
        va = [na] + ga.unit_gradients(na)
        if len(va) != len(vb) or len(va) != 4:
            raise ValueError(f"clamp: each node needs three unit gradient vectors (a frame), got {len(va) - 1} and "
                             f"{len(vb) - 1}")
        Ga, Gb = ga.vectors[va[1:]], gb.vectors[vb[1:]]
        if abs(np.linalg.det(Gb)) < 1e-9:
            raise ValueError("clamp: the node's unit gradient vectors do not span space")
        T = Ga @ np.linalg.inv(Gb)
        if np.allclose(T, np.eye(3), atol=1e-12):
            return Fixed(self.a.body, va, self.b.body, vb)
        mixing = np.eye(4)
        mixing[1:, 1:] = T
        return Fixed(self.a.body, va, self.b.body, vb, mixing=mixing)


def hinge_directions(geometry: tuple[BodyGeometry, ...], a: Marker | None, b: Marker, axis) -> tuple:
    """The directions that measure b's angle about a hinge's ``axis`` relative to a:
    ``(body_a, u_a, w_a, body_b, u_b, ground)``, u_a and w_a = axis × u_a a's two unit gradient
    vectors normal to the axis (None with ``a=None``: then ``ground`` holds them as fixed
    directions), u_b b's gradient vector along u_a in the reference (``drivers.AngleDriver``,
    ``forces.HingeAngle``)."""
    axis = _unit(axis)
    gb = geometry[b.body]
    nb = gb.node(b)
    if a is None:
        u_b = gb.normal_to(nb, axis, "hinge axis")[0]
        u = gb.vectors[u_b] / np.linalg.norm(gb.vectors[u_b])
        return None, None, None, b.body, u_b, np.stack([u, np.cross(axis, u)])
    ga = geometry[a.body]
    na = ga.node(a)
    normals = ga.normal_to(na, axis, "hinge axis")
    u_a, w_a = normals if np.cross(ga.vectors[normals[0]], ga.vectors[normals[1]]) @ axis > 0 else normals[::-1]
    u_b = gb.along(nb, ga.vectors[u_a], "the hinge's reference direction")
    return a.body, u_a, w_a, b.body, u_b, np.stack([np.eye(3)[0], np.eye(3)[1]])


def _check_drive(drive):
    if drive is not None and not callable(drive):
        raise ValueError("drive must be a motion (motion(t)[0] the prescribed angle or travel, e.g. "
                         f"motion.SteadySpin), got {type(drive).__name__}")
    return drive


def hinge(a: Marker | None, b: Marker, axis, drive=None) -> JointSpec:
    """A revolute joint about ``axis`` between the nodes at markers ``a`` and ``b`` (the same point),
    or of ``b`` to the ground (``a=None``) at its point: the positions coincide and b's gradient
    vector along the axis stays normal to a's two gradient vectors normal to it (``Revolute``).
    With ``drive`` (a motion: ``drive(t)[0]`` the angle, e.g. ``motion.SteadySpin``), b's angle
    about the axis relative to a follows drive(t)[0] − drive(0)[0] (``drivers.AngleDriver``,
    which the system puts right after the hinge)."""
    return JointSpec("hinge", a, b, tuple(float(x) for x in _unit(axis)), _check_drive(drive))


def slider(a: Marker | None, b: Marker, axis, drive=None) -> JointSpec:
    """A prismatic joint: b's node slides along ``axis`` through a's node (on one line along the
    axis), or through its own point when ``a=None``, keeping its orientation relative to a (or
    to the ground) (``prismatic.Prismatic``). Both nodes need directions: a gradient vector
    along the axis and two normal to it. With ``drive``, the travel along the axis follows
    drive(t)[0] − drive(0)[0] (``drivers.DistanceDriver``, right after the slider)."""
    return JointSpec("slider", a, b, tuple(float(x) for x in _unit(axis)), _check_drive(drive))


def ball(a: Marker | None, b: Marker) -> JointSpec:
    """A spherical joint: the nodes at ``a`` and ``b`` keep one position (``Spherical``); with
    ``a=None``, b's node stays at its point in space."""
    return JointSpec("ball", a, b)


def clamp(a: Marker | None, b: Marker) -> JointSpec:
    """A rigid joint: the node at ``b`` keeps its position and unit gradient vectors equal to a's
    node's (``Fixed``), or, with ``a=None``, to their reference values in space."""
    return JointSpec("clamp", a, b)


def resolve_joints(joints, geometry: tuple[BodyGeometry, ...]) -> tuple:
    """The system's joints with every ``JointSpec`` resolved (nodal-vector joints pass as they are;
    a driven joint becomes the joint and its driver, in that order)."""
    out = []
    for j in joints:
        r = j.resolve(geometry) if isinstance(j, JointSpec) else j
        out.extend(r if isinstance(r, tuple) else (r,))
    return tuple(out)


__all__ = ["ANGLE_TOL", "POINT_TOL", "BodyGeometry", "JointSpec", "Marker", "ball", "clamp", "hinge",
           "hinge_directions", "resolve_joints", "slider"]
