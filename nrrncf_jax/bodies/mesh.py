"""Reference (stress-free) geometry of beams: straight, circular arcs, or any framed curve.

A beam's reference is its centreline ``c(s)`` with a cross-section frame ``(n1(s), n2(s))``
along the arc length s. The nodal vectors of node i are ``[c, c', n1, n1', n2, n2']`` at
``s_i``, the derivatives taken by ``jax.jacfwd`` so any smooth curve works.
"""

from collections.abc import Callable

import equinox as eqx
import jax
import jax.numpy as jnp

from .. import _validate
from .._types import Array, Float, ScalarLike


class BeamReference(eqx.Module):
    """Nodal vectors of the stress-free beam, ``(n_nodes, 6, 3)``, and element lengths."""

    q_hat: Float[Array, "nodes 6 3"]
    lengths: Float[Array, " elements"]

    @property
    def n_elements(self) -> int:
        return self.lengths.shape[0]


Frame = Callable[[Float[Array, ""]], tuple[Float[Array, " 3"], Float[Array, " 3"], Float[Array, " 3"]]]


def centerline_reference(frame: Frame, length: ScalarLike, n_elements: int) -> BeamReference:
    """Beam reference from ``frame(s) -> (c, n1, n2)``, s ∈ [0, length] the arc length.

    ``c'(s)`` should be a unit vector for s to be the arc length; ``n1, n2`` span the section.
    """
    _validate.positive("L (beam length)", length)
    n = _validate.positive_int("number of elements", n_elements)
    s = jnp.linspace(0.0, length, n + 1)

    def nodal(si):
        c, n1, n2 = frame(si)
        dc, dn1, dn2 = jax.jacfwd(frame)(si)
        return jnp.stack([c, dc, n1, dn1, n2, dn2])

    q_hat = jax.vmap(nodal)(s)
    return BeamReference(q_hat=q_hat, lengths=jnp.diff(s))


def straight_reference(length: ScalarLike, n_elements: int) -> BeamReference:
    """A straight beam along +x from the origin, section axes y and z."""

    def frame(s):
        e = jnp.eye(3)
        return s * e[0], e[1], e[2]

    return centerline_reference(frame, length, n_elements)


def arc_reference(length: ScalarLike, radius: ScalarLike, n_elements: int, toward: str = "+y") -> BeamReference:
    """A circular arc leaving the origin along +x and curving toward ``toward``
    (``'+y'``, ``'-y'`` in the x-y plane, ``'+z'``, ``'-z'`` out of it)."""
    _validate.positive("radius (curvature radius)", radius)
    if toward not in ("+y", "-y", "+z", "-z"):
        raise ValueError(f"toward must be one of '+y', '-y', '+z', '-z', got {toward!r}")
    sign = 1.0 if toward[0] == "+" else -1.0
    k = 1 if toward[1] == "y" else 2  # axis the arc bends toward
    o = 3 - k  # the other section axis (z for an in-plane arc, y for out of plane)
    e = jnp.eye(3)

    def frame(s):
        phi = s / radius
        c = radius * jnp.sin(phi) * e[0] + sign * radius * (1.0 - jnp.cos(phi)) * e[k]
        nk = -sign * jnp.sin(phi) * e[0] + jnp.cos(phi) * e[k]  # in-plane normal, = e_k at s=0
        n1, n2 = (nk, e[o]) if k == 1 else (e[o], nk)
        return c, n1, n2

    return centerline_reference(frame, length, n_elements)
