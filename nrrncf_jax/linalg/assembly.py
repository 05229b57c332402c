"""One entry point for the iteration matrix: assemble element groups, make constrained DOFs
identity, pick a storage format and factor.

- ``block_tridiagonal``: one element group on a chain (``chain_block``); pure JAX, so
  everything works (jit, loops, vmap, jvp, grad, any platform). ``"auto"`` takes it when possible.
- ``dense``: any mesh; pure JAX, everything works; O(n²) memory. ``"auto"`` takes it below
  ``DENSE_MAX_DOFS`` DOFs, and above when the element DOFs are traced and no ``pattern`` is
  given (with a warning).
- ``sparse``: any mesh; SuperLU on the host: jit, loops, jvp and grad; vmap only as a loop; host
  CPU only. ``"auto"`` takes it otherwise.

(``sparse`` module docstring for the details.) Each returns an ``AbstractFactorization`` with
``.solve(b)``.
"""

import warnings
from collections.abc import Sequence

import numpy as np

from .._types import Array, Bool, Float, Int
from .._validate import is_concrete
from .base import Parts
from .block_tridiagonal import BlockTridiagonalLU, assemble_block_tridiagonal, factor_block_tridiagonal
from .dense import DenseLU, assemble_dense
from .sparse import SparseLU, SparsityPattern, factor_sparse

SOLVERS = ("auto", "dense", "block_tridiagonal", "sparse")

DENSE_MAX_DOFS = 1000
"""``"auto"`` factors matrices of fewer DOFs than this dense, larger ones sparse (when the mesh is
not one chain). Measured on the 2-core CPU (``benchmarks/results/sparse.md``, a 2-D mesh with 9
DOFs a node; two runs on a shared machine): dense factor+solve takes 2.6-3 times SuperLU's at 500
DOFs, 3-7 times at 1,000 and 13-15 times at 2,000, and its matrix grows as n² (8 MB at 1,000
DOFs, 3.2 GB at 20,000). Below the
threshold a dense factorisation costs tens of milliseconds and keeps what the sparse one lacks:
batching under ``vmap``, accelerators, no host callbacks. On a GPU, pass ``solver="dense"`` to
keep larger models there."""


def assemble_and_factor(
    parts: Parts, free: Bool[Array, " n"], *legacy, chain_block: int | None = None, solver: str = "auto",
    pattern: SparsityPattern | None = None,
) -> DenseLU | BlockTridiagonalLU | SparseLU:
    """Assemble the element groups ``parts`` (``(Ge, element_dofs)`` pairs: element matrices
    (n_el, nd, nd) and their global DOFs (n_el, nd), all adding into one n × n matrix,
    n = ``free.shape[0]``), make the constrained DOFs (``free`` false) identity rows and columns,
    and factor with ``solver``:

    - ``"block_tridiagonal"``: one group on a chain of nodes with ``chain_block`` DOFs each
      (element e on nodes e and e + 1, DOFs numbered node by node);
    - ``"dense"``: LU of the whole matrix;
    - ``"sparse"``: SuperLU of the matrix in the pattern of the (concrete) element DOFs;
    - ``"auto"``: block-tridiagonal when possible, else dense below ``DENSE_MAX_DOFS``, else sparse.

    The sparse solver builds its pattern on the host from the element DOFs, so they must be
    concrete (NumPy, or a static field): inside ``jit`` even ``jnp.asarray`` of a NumPy array is
    traced. Where they are traced, pass the ``pattern`` built once from the same DOFs outside the
    trace (``SparsityPattern.from_dofs(n, [element_dofs, ...])``, e.g. kept by the body).

    An unknown solver, or one that cannot factor these groups, raises ``ValueError`` before any
    tracing. The old form ``assemble_and_factor(Ge, element_dofs, free, chain_block)`` (one group;
    block-tridiagonal with a ``chain_block``, dense without) still works, for callers not yet
    moved to the groups form.
    """
    if hasattr(parts, "ndim"):  # the old form (Ge, element_dofs, free[, chain_block]): to be removed
        if len(legacy) not in (1, 2) or solver != "auto":
            raise TypeError("assemble_and_factor(Ge, element_dofs, free, chain_block) takes four arguments")
        Ge, element_dofs, free = parts, free, legacy[0]
        chain_block = legacy[1] if len(legacy) == 2 else chain_block
        parts = [(Ge, element_dofs)]
        solver = "dense" if chain_block is None else "block_tridiagonal"
    elif legacy:
        raise TypeError("assemble_and_factor(parts, free, *, chain_block=None, solver='auto'): "
                        f"{len(legacy)} extra positional argument(s)")
    parts = list(parts)
    solver = choose_solver(parts, free.shape[0], chain_block=chain_block, solver=solver, pattern=pattern)
    if solver == "block_tridiagonal":
        ((Ge, _),) = parts
        return factor_block_tridiagonal(*assemble_block_tridiagonal(Ge, free, chain_block))
    if solver == "dense":
        return DenseLU.factor(assemble_dense(parts, free))
    return factor_sparse(parts, free, pattern)


def choose_solver(parts: Parts, n: int, *, chain_block: int | None = None, solver: str = "auto",
                  pattern: SparsityPattern | None = None) -> str:
    """The solver ``assemble_and_factor`` uses for these groups: ``solver`` itself if it can
    factor them (``ValueError`` if not, or if it is unknown), or ``"auto"``'s choice."""
    if solver not in SOLVERS:
        raise ValueError(f"solver must be one of {', '.join(map(repr, SOLVERS))}, got {solver!r}")
    parts = list(parts)
    if not parts:
        raise ValueError("parts must hold at least one (Ge, element_dofs) group")
    for i, (Ge, dofs) in enumerate(parts):
        if len(dofs.shape) != 2 or Ge.shape != (dofs.shape[0], dofs.shape[1], dofs.shape[1]):
            raise ValueError(f"group {i}: Ge must be (n_el, nd, nd) and element_dofs (n_el, nd), got {Ge.shape} "
                             f"and {dofs.shape}")
    for i, (_, dofs) in enumerate(parts):
        d = np.asarray(dofs) if is_concrete(dofs) else None  # NumPy: jnp ops on a constant are traced in a jit
        if d is not None and d.size and (d.min() < 0 or d.max() >= n):
            raise ValueError(f"group {i}: element_dofs must lie in [0, {n}), got [{d.min()}, {d.max()}]")
    if chain_block is not None and (int(chain_block) != chain_block or chain_block <= 0):
        raise ValueError(f"chain_block must be a positive integer or None, got {chain_block!r}")
    chain_problem = _chain_problem(parts, n, chain_block)
    concrete = all(is_concrete(dofs) for _, dofs in parts)
    if pattern is not None:
        pattern.check(parts, n)
        concrete = True
    if solver == "block_tridiagonal" and chain_problem:
        raise ValueError(f"solver='block_tridiagonal' needs {chain_problem}")
    if solver == "sparse" and not concrete:
        raise ValueError("solver='sparse' builds its pattern on the host and needs concrete element_dofs, got a traced "
                         "array: keep the element DOFs out of the jit-compiled function's arguments (NumPy or static)")
    if solver != "auto":
        return solver
    if not chain_problem:
        return "block_tridiagonal"
    if n >= DENSE_MAX_DOFS and not concrete:
        warnings.warn(f"solver='auto' factors this {n}-DOF matrix dense: its element DOFs are traced, so no sparse "
                      "pattern can be built; pass pattern=SparsityPattern.from_dofs(...) built once outside the trace",
                      stacklevel=3)
    return "dense" if n < DENSE_MAX_DOFS or not concrete else "sparse"


def _chain_problem(parts: Sequence[tuple[Float[Array, "n_el nd nd"], Int[Array, "n_el nd"]]], n: int,
                   m: int | None) -> str:
    """Why these groups are not one chain with m DOFs per node ("" if they are)."""
    if m is None:
        return "chain_block (the DOFs per node of a chain mesh)"
    if len(parts) != 1:
        return f"exactly one element group, got {len(parts)}"
    ((Ge, dofs),) = parts
    n_el, nd = dofs.shape
    if n % m or nd != 2 * m or n_el != n // m - 1:
        return (f"a chain: {n} DOFs in nodes of {m}, and elements of {2 * m} DOFs on nodes e, e + 1 "
                f"(n/m − 1 of them); got {n_el} elements of {nd} DOFs")
    if is_concrete(dofs) and not np.array_equal(np.asarray(dofs), m * np.arange(n_el)[:, None] + np.arange(nd)):
        return "a chain: element e's DOFs must be m·e … m·e + 2m − 1 (nodes e and e + 1, numbered node by node)"
    return ""
