"""Joints in physical terms: markers (a body and a point of its reference configuration) and joint
specifications on them, which a system turns into the joints of ``joints``, ``weld``,
``prismatic``, ``universal`` and ``drivers``.

A multibody engineer says "a hinge about Z at the rod's left end"; ``Marker(body, point)`` names
the point (in the system's frame, in the reference configuration: where the placed body's
stress-free state puts it), and ``hinge(a, b, axis)``, ``ball(a, b)``, ``clamp(a, b)``,
``slider(a, b, axis)``, ``cylindrical(a, b, axis)`` and ``universal(a, b, axis_a, axis_b)`` the
joint; a system (``Mechanism``,
``MultibodySystem``, ``FloatingFrameSystem``) resolves them once, from its bodies' reference
nodal vectors, before anything is traced:

- a point is a node's position vector: the one position vector of the body at that point (to
  ``POINT_TOL`` of the body's size), else ``ValueError`` naming the nearest node;
- a direction (an axis, in space, in the reference configuration; any unit vector) is fixed in the
  node's *section frame*, the orthonormal triad of its two section vectors (``section_frame``):
  a C1 beam's r_y, r_z, a rigid body's axes. Never the beam's slope r_x: a moment through it
  loads one element's shear, and the joint would not converge under mesh refinement.

Every resolution error names the joint, its bodies and points, and the rule it broke.
"""

import dataclasses

import numpy as np

from .cylindrical import Cylindrical
from .drivers import AngleDriver, DistanceDriver
from .eccentric_ball import EccentricBall
from .joints import Revolute, Spherical, normals
from .measures import HingeAngle, Travel
from .prismatic import Prismatic
from .section_frame import Directions
from .universal import Universal
from .weld import Weld

POINT_TOL = 1e-9
"""A marker's point matches a node when closer than this times the body's size."""

ANGLE_TOL = 1e-9
"""Two axes count as normal to each other when |cos| of their angle is below this."""


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


def _fmt(p) -> str:
    return "(" + ", ".join(f"{float(x):.6g}" for x in np.asarray(p).reshape(-1)) + ")"


@dataclasses.dataclass(frozen=True)
class BodyGeometry:
    """What marker resolution reads of a body: its reference nodal vectors (n × 3, in the system's
    frame), which are positions, how many vectors a node carries, and ``directors``: the slots
    within a node of the two section vectors that span its section frame (a C1 beam's r_y, r_z;
    empty for a node without directions: a point mass, a bar's node)."""

    vectors: np.ndarray
    is_position: np.ndarray
    vectors_per_node: int
    directors: tuple[int, ...] = ()

    def node(self, marker: Marker) -> int:
        """The position vector at the marker's point."""
        pos = np.flatnonzero(self.is_position)
        d = np.linalg.norm(self.vectors[pos] - np.asarray(marker.point), axis=1)
        size = max(1.0, float(np.ptp(self.vectors[pos], axis=0).max()))
        i = int(np.argmin(d))
        if d[i] > POINT_TOL * size:
            raise ValueError(f"marker point {_fmt(marker.point)} is not a node of body {marker.body} (a joint sits on "
                             f"a node): the nearest node is {_fmt(self.vectors[pos[i]])}, {d[i]:.3g} away")
        return int(pos[i])

    def unit_gradients(self, node: int) -> list[int]:
        """The node's gradient vectors of unit length in the reference (a C1 beam's r_x, r_y,
        r_z; not r_xy, r_xz), in the node's order: the frame a reduced body is held in."""
        first = node - node % self.vectors_per_node
        block = range(first, first + self.vectors_per_node)
        return [v for v in block if not self.is_position[v] and abs(np.linalg.norm(self.vectors[v]) - 1.0) < 1e-6]

    def section(self, body: int, node: int) -> tuple[int, int]:
        """The node's two section vectors (body indices)."""
        if len(self.directors) < 2:
            raise ValueError(f"the node of body {body} at {_fmt(self.vectors[node])} carries no section frame (a "
                             "point mass, a bar's node): a joint that holds a direction needs a beam's or a rigid "
                             "body's node")
        first = node - node % self.vectors_per_node
        return first + self.directors[0], first + self.directors[1]

    def directions(self, body: int, node: int, directions) -> Directions:
        """``directions`` (k × 3, in space, in the reference) fixed in the node's section frame."""
        v = self.section(body, node)
        return Directions.in_section(body, v, self.vectors[list(v)], directions)


def _unit(direction) -> np.ndarray:
    e = np.asarray(direction, dtype=float).reshape(-1)
    if e.shape != (3,) or not np.all(np.isfinite(e)) or np.linalg.norm(e) == 0:
        raise ValueError(f"a direction must be a finite nonzero 3-vector, got {direction!r}")
    return e / np.linalg.norm(e)


@dataclasses.dataclass(frozen=True)
class JointSpec:
    """A joint on markers (``hinge``, ``ball``, ``clamp``, ``slider``, ``universal``), resolved by
    the system into joints (``resolve``). ``a`` is None for the ground; ``axis`` the joint's axis
    (for a universal joint, a's pin; ``axis_b`` b's pin)."""

    kind: str
    a: Marker | None
    b: Marker
    axis: tuple[float, float, float] | None = None
    drive: object = None  # a motion, motion(t)[0] the prescribed angle or travel (``drivers``)
    axis_b: tuple[float, float, float] | None = None

    def describe(self) -> str:
        """The joint in words, for error messages: its kind, bodies and points."""
        b = f"body {self.b.body} at {_fmt(self.b.point)}"
        where = f"{b} to the ground" if self.a is None else f"body {self.a.body} at {_fmt(self.a.point)} and {b}"
        axis = "" if self.axis is None else f" about {_fmt(self.axis)}"
        return f"{self.kind} between {where}{axis}"

    def resolve(self, geometry: tuple[BodyGeometry, ...]):
        """The joint (or the joint and its driver) of these markers on the system's bodies."""
        try:
            return self._resolve(geometry)
        except ValueError as error:
            raise ValueError(f"{self.describe()}: {error}") from None

    def _resolve(self, geometry):
        for m in (self.a, self.b):
            if m is not None and not 0 <= m.body < len(geometry):
                raise ValueError(f"marker on body {m.body}; the system has bodies 0..{len(geometry) - 1}")
        gb = geometry[self.b.body]
        nb = gb.node(self.b)
        na = None if self.a is None else geometry[self.a.body].node(self.a)
        if self.kind in ("slider", "cylindrical"):
            return self._slider(geometry, nb, na)
        if self.kind == "eccentric ball":
            offset = np.asarray(self.b.point) - geometry[self.a.body].vectors[na]
            return EccentricBall(self.a.body, na, geometry[self.a.body].directions(self.a.body, na, [offset]),
                                 self.b.body, nb)
        if self.a is not None and np.linalg.norm(geometry[self.a.body].vectors[na] - gb.vectors[nb]) > \
                POINT_TOL * max(1.0, np.abs(gb.vectors).max()):
            raise ValueError(f"the markers' points differ, {_fmt(self.a.point)} and {_fmt(self.b.point)} (the "
                             "joint's two nodes must coincide in the reference)")
        if self.kind == "ball":
            if self.a is None:
                return Spherical(self.b.body, nb, point=self.b.point)
            return Spherical(self.a.body, na, self.b.body, nb)
        if self.kind == "hinge":
            return self._hinge(geometry, nb, na)
        if self.kind == "angle":
            return AngleDriver(hinge_angle(geometry, self.a, self.b, self.axis), self.drive)
        if self.kind == "clamp":
            frame_a = Weld.axes(None, None, None) if self.a is None else \
                geometry[self.a.body].directions(self.a.body, na, np.eye(3))
            position_a = None if self.a is None else na
            return Weld(None if self.a is None else self.a.body, position_a, frame_a, self.b.body, nb,
                        gb.directions(self.b.body, nb, np.eye(3)), point=gb.vectors[nb])
        if self.kind == "universal":
            e_a, e_b = _unit(self.axis), _unit(self.axis_b)
            if abs(float(e_a @ e_b)) > ANGLE_TOL:
                raise ValueError(f"the pins {_fmt(e_a)} and {_fmt(e_b)} must be normal to each other in the reference")
            axis_a = Directions.ground([e_a]) if self.a is None else geometry[self.a.body].directions(self.a.body,
                                                                                                       na, [e_a])
            return Universal(None if self.a is None else self.a.body, na, axis_a, self.b.body, nb,
                             gb.directions(self.b.body, nb, [e_b]), point=self.b.point)
        raise ValueError(f"unknown joint kind {self.kind!r}")

    def _hinge(self, geometry, nb: int, na: int | None):
        e = _unit(self.axis)
        n = normals(e)
        gb = geometry[self.b.body]
        axis_b = gb.directions(self.b.body, nb, [e])
        if self.a is None:
            joint = Revolute(None, None, Directions.ground(n), self.b.body, nb, axis_b, point=self.b.point)
        else:
            joint = Revolute(self.a.body, na, geometry[self.a.body].directions(self.a.body, na, n), self.b.body, nb,
                             axis_b)
        if self.drive is None:
            return joint
        return joint, AngleDriver(hinge_angle(geometry, self.a, self.b, e), self.drive)

    def _check_on_axis(self, geometry, nb: int, na: int, e) -> np.ndarray:
        """b's node's offset from a's, refused unless along the axis (a slider's nodes are on it)."""
        gb = geometry[self.b.body]
        gap = gb.vectors[nb] - geometry[self.a.body].vectors[na]
        if np.linalg.norm(np.cross(gap, e)) > POINT_TOL * max(1.0, np.abs(gb.vectors).max()):
            raise ValueError(f"the markers' points {_fmt(self.a.point)} and {_fmt(self.b.point)} are not on one line "
                             "along the axis (the joint's nodes must be)")
        return gap

    def _slider(self, geometry, nb: int, na: int | None):
        """A slider, or (``kind="cylindrical"``) the slider without its hold on the turn about the axis."""
        e = _unit(self.axis)
        n = normals(e)
        gb = geometry[self.b.body]
        if self.kind == "cylindrical":
            normals_a = Directions.ground(n) if self.a is None else geometry[self.a.body].directions(self.a.body, na, n)
            if self.a is not None:
                self._check_on_axis(geometry, nb, na, e)
            return Cylindrical(None if self.a is None else self.a.body, na, normals_a, self.b.body, nb,
                               gb.directions(self.b.body, nb, [e]), point=self.b.point)
        frame_b = gb.directions(self.b.body, nb, [e, n[0]])
        if self.a is None:
            joint = Prismatic(None, None, Directions.ground(n), self.b.body, nb, frame_b, point=self.b.point)
            travel, s_ref = Travel(None, None, Directions.ground([e]), self.b.body, nb, point=self.b.point), 0.0
        else:
            ga = geometry[self.a.body]
            gap = self._check_on_axis(geometry, nb, na, e)
            joint = Prismatic(self.a.body, na, ga.directions(self.a.body, na, n), self.b.body, nb, frame_b)
            travel = Travel(self.a.body, na, ga.directions(self.a.body, na, [e]), self.b.body, nb)
            s_ref = float(gap @ e)
        return joint if self.drive is None else (joint, DistanceDriver(travel, self.drive, s_ref=s_ref))


def hinge_angle(geometry: tuple[BodyGeometry, ...], a: Marker | None, b: Marker, axis) -> HingeAngle:
    """b's angle about a hinge's ``axis`` relative to a (the ground for ``a=None``): u, w = axis × u
    fixed in a's section frame (in space for the ground) and u fixed in b's, zero in the
    reference (``measures.HingeAngle``; ``drivers.AngleDriver``, ``forces.torsion_spring``)."""
    u, w = normals(_unit(axis))
    gb = geometry[b.body]
    u_b = gb.directions(b.body, gb.node(b), [u])
    if a is None:
        return HingeAngle(Directions.ground([u, w]), u_b)
    ga = geometry[a.body]
    return HingeAngle(ga.directions(a.body, ga.node(a), [u, w]), u_b)


def _check_drive(drive):
    if drive is not None and not callable(drive):
        raise ValueError("drive must be a motion (motion(t)[0] the prescribed angle or travel, e.g. "
                         f"motion.SteadySpin), got {type(drive).__name__}")
    return drive


def hinge(a: Marker | None, b: Marker, axis, drive=None) -> JointSpec:
    """A revolute joint about ``axis`` (any direction, in space, in the reference) between the
    nodes at markers ``a`` and ``b`` (the same point), or of ``b`` to the ground (``a=None``) at
    its point: the positions coincide and the axis fixed in b's section frame stays normal to two
    directions fixed in a's (``joints.Revolute``). With ``drive`` (a motion: ``drive(t)[0]`` the
    angle, e.g. ``motion.SteadySpin``), b's angle about the axis relative to a follows
    drive(t)[0] − drive(0)[0] (``drivers.AngleDriver``, which the system puts right after the
    hinge)."""
    return JointSpec("hinge", a, b, tuple(float(x) for x in _unit(axis)), _check_drive(drive))


def slider(a: Marker | None, b: Marker, axis, drive=None) -> JointSpec:
    """A prismatic joint: b's node slides along ``axis`` through a's node (on one line along the
    axis), or through its own point when ``a=None``, keeping its orientation relative to a (or
    to the ground) (``prismatic.Prismatic``). Both nodes need section frames. With ``drive``, the
    travel along the axis follows drive(t)[0] − drive(0)[0] (``drivers.DistanceDriver``, right
    after the slider)."""
    return JointSpec("slider", a, b, tuple(float(x) for x in _unit(axis)), _check_drive(drive))


def angle_driver(a: Marker | None, b: Marker, axis, drive) -> JointSpec:
    """b's rotation about ``axis`` relative to a (or the ground) prescribed, drive(t)[0] −
    drive(0)[0], without a hinge: one equation (``drivers.AngleDriver``), whose multiplier's
    negative is the torque applied to b's cross-section about the axis (``AngleDriver.effort``).
    The markers' points must coincide (a rotation is measured at one place)."""
    if drive is None:
        raise ValueError("angle_driver needs a drive (a motion: drive(t)[0] the angle)")
    return JointSpec("angle", a, b, tuple(float(x) for x in _unit(axis)), _check_drive(drive))


def ball(a: Marker | None, b: Marker, eccentric: bool = False) -> JointSpec:
    """A spherical joint: the nodes at ``a`` and ``b`` keep one position (``Spherical``); with
    ``a=None``, b's node stays at its point in space. ``eccentric=True``: b's node may lie off a's;
    it keeps to the point at b's marker fixed in a's node's section frame, which turns with it
    (``eccentric_ball.EccentricBall``)."""
    if eccentric and a is None:
        raise ValueError("ball(None, b, eccentric=True): an eccentric ball's point is fixed in a's node; on the "
                         "ground, ball(None, b) holds b's node at its own point")
    return JointSpec("eccentric ball" if eccentric else "ball", a, b)


def clamp(a: Marker | None, b: Marker) -> JointSpec:
    """A rigid joint: the node at ``b`` keeps its position and its section frame's orientation
    relative to a's node's, or, with ``a=None``, those of the reference in space
    (``weld.Weld``, six equations). A beam's slope r_x, stretch and shear stay free there."""
    return JointSpec("clamp", a, b)


def cylindrical(a: Marker | None, b: Marker, axis) -> JointSpec:
    """A cylindrical joint: b's node stays on the line along ``axis`` through a's node (or through
    its own point, ``a=None``: a bearing on the ground) and its axis along the line; it turns
    about it and slides along it freely (``cylindrical.Cylindrical``, four equations)."""
    return JointSpec("cylindrical", a, b, tuple(float(x) for x in _unit(axis)))


def universal(a: Marker | None, b: Marker, axis_a, axis_b) -> JointSpec:
    """A universal (Cardan) joint between the nodes at ``a`` and ``b`` (the same point), or of
    ``b`` to the ground: the positions coincide and the pin ``axis_a`` fixed in a's section frame
    (in space for the ground) stays normal to the pin ``axis_b`` fixed in b's; the two pins must be
    normal in the reference (``universal.Universal``)."""
    return JointSpec("universal", a, b, tuple(float(x) for x in _unit(axis_a)),
                     axis_b=tuple(float(x) for x in _unit(axis_b)))


def resolve_joints(joints, geometry: tuple[BodyGeometry, ...]) -> tuple:
    """The system's joints with every ``JointSpec`` resolved (nodal-vector joints pass as they are;
    a driven joint becomes the joint and its driver, in that order)."""
    out = []
    for j in joints:
        r = j.resolve(geometry) if isinstance(j, JointSpec) else j
        out.extend(r if isinstance(r, tuple) else (r,))
    return tuple(out)


__all__ = ["ANGLE_TOL", "POINT_TOL", "BodyGeometry", "JointSpec", "Marker", "angle_driver", "ball", "clamp",
           "cylindrical", "hinge", "hinge_angle", "resolve_joints", "slider", "universal"]
