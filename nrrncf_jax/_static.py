"""Integer index arrays kept as static (compile-time) data of a module.

A body's connectivity, and what is derived from it (the iteration matrix's DOFs, its solver and
sparsity pattern), is structure, not a value: it must stay a NumPy array when a model is built
inside a user's ``jit``, ``grad`` or ``vmap`` and when the model is passed through the
integrator's ``filter_jit``, where every array leaf is traced. ``StaticIndices`` holds it as a
static field: hashable and compared by value, so equal bodies share one compilation.
"""

import numpy as np


class StaticIndices:
    """A read-only integer NumPy array that is hashable and compares by value (``.array``)."""

    __slots__ = ("array", "_hash")

    def __init__(self, array):
        if isinstance(array, StaticIndices):
            array = array.array
        try:
            a = np.array(array)
        except Exception as e:  # a traced array: structure must be known before tracing
            raise ValueError("index arrays (connectivity, DOFs) must be concrete NumPy data, known before any "
                             f"tracing; got {type(array).__name__}") from e
        if a.size and not np.issubdtype(a.dtype, np.integer):
            raise ValueError(f"index arrays must hold integers, got dtype {a.dtype}")
        a = a.astype(np.int64)
        a.flags.writeable = False
        self.array = a
        self._hash = hash((a.shape, a.tobytes()))

    def __hash__(self) -> int:
        return self._hash

    def __eq__(self, other) -> bool:
        return (isinstance(other, StaticIndices) and self._hash == other._hash
                and np.array_equal(self.array, other.array))

    def __repr__(self) -> str:
        return f"StaticIndices(shape={self.array.shape})"
