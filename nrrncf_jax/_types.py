"""jaxtyping aliases used on public signatures (shapes in the annotation, not in prose)."""

from jaxtyping import Array, ArrayLike, Bool, Float, Int

Scalar = Float[Array, ""]
ScalarLike = float | Float[ArrayLike, ""]
NodalVectors = Float[Array, "n 3"]
"""The nodal vectors q_α of a body (positions and gradients), one 3-vector per row."""
Coordinates = Float[Array, " ndof"]
"""The same coordinates flattened, ``q.reshape(-1)``."""
ElementKappa = Float[Array, "ne ne ne ne"]
ElementMatrix = Float[Array, "ne ne"]

__all__ = [
    "Array",
    "ArrayLike",
    "Bool",
    "Coordinates",
    "ElementKappa",
    "ElementMatrix",
    "Float",
    "Int",
    "NodalVectors",
    "Scalar",
    "ScalarLike",
]
