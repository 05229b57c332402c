"""A mechanism drawn as lines: each body's position vectors (its nodes) and the edges between
them, for the VTK series and the animation of ``nrrncf run --vtk/--animate``.

The edges come from the bodies' own elements: each element's position vectors in order, joined
in a chain (a beam or bar element: one segment; a plate element: its boundary, closed). A body
without elements (a rigid body, whose nodes are its centre of mass and attachment points) is a
star from its first node; a point mass is one node and no edge.
"""

import numpy as np


def body_outline(kind) -> tuple[np.ndarray, np.ndarray]:
    """``(vectors, edges)``: the body's position vectors (nodal-vector indices) and its edges
    (e × 2, indices into ``vectors``)."""
    g = kind.geometry()
    vectors = np.flatnonzero(np.asarray(g.is_position))
    local = {int(v): i for i, v in enumerate(vectors)}
    edges = set()
    for group in getattr(getattr(kind, "body", None), "groups", ()):
        for element in np.asarray(group.elements):
            nodes = [local[int(v)] for v in element if int(v) in local]
            pairs = list(zip(nodes[:-1], nodes[1:])) + ([(nodes[-1], nodes[0])] if len(nodes) > 2 else [])
            edges |= {tuple(sorted(p)) for p in pairs if p[0] != p[1]}
    if not edges and len(vectors) > 1 and not getattr(getattr(kind, "body", None), "groups", ()):
        edges = {(0, i) for i in range(1, len(vectors))}
    return vectors, np.asarray(sorted(edges), dtype=np.int64).reshape(-1, 2)


def mechanism_outline(system) -> tuple[list[tuple[int, int]], np.ndarray]:
    """``(points, lines)``: the system's nodes as (body, nodal vector) pairs, and the edges of all
    its bodies (l × 2, indices into ``points``)."""
    points, lines = [], []
    for b, kind in enumerate(system.bodies):
        vectors, edges = body_outline(kind)
        lines.append(edges + len(points))
        points += [(b, int(v)) for v in vectors]
    return points, np.concatenate(lines, axis=0) if lines else np.zeros((0, 2), np.int64)


__all__ = ["body_outline", "mechanism_outline"]
