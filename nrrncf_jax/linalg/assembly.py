"""The linear solver of an iteration matrix assembled from element groups, as one object passed
down (lineax's style): ``Dense``, ``BlockTridiagonal`` (a chain of nodes) or ``Sparse`` (SuperLU),
each an ``AbstractLinearSolver`` with ``factor(parts, free)``. ``linear_solver`` turns the user's
choice (an object, or ``"auto"``, ``"dense"``, ``"block_tridiagonal"``, ``"sparse"``) into one of
them once, from static data (the element DOFs as NumPy), before anything is traced:

- ``block_tridiagonal``: one element group on a chain (``chain_block``); pure JAX, so
  everything works (jit, loops, vmap, jvp, grad, any platform). ``"auto"`` takes it when possible.
- ``dense``: any mesh; pure JAX, everything works; O(n²) memory. ``"auto"`` takes it below
  ``DENSE_MAX_DOFS`` DOFs, and above when the element DOFs are traced and no pattern is known
  (with a warning).
- ``sparse``: any mesh; SuperLU on the host: jit, loops, jvp and grad; vmap only as a loop; host
  CPU only. ``"auto"`` takes it otherwise, with its sparsity pattern built once.

(``sparse`` module docstring for the details.) Each ``factor`` returns an
``AbstractFactorization`` with ``.solve(b)``.
"""

import abc
import warnings
from collections.abc import Sequence
from typing import ClassVar

import equinox as eqx
import numpy as np

from .._types import Array, Bool, Float, Int
from .._validate import is_concrete
from .base import AbstractFactorization, Parts
from .block_tridiagonal import BlockTridiagonalLU, assemble_block_tridiagonal, factor_block_tridiagonal
from .dense import DenseLU, assemble_dense
from .sparse import SparseLU, SparsityPattern, factor_sparse

SOLVERS = ("auto", "dense", "block_tridiagonal", "sparse")

DENSE_MAX_DOFS = 1000
"""``"auto"`` factors matrices of fewer DOFs than this dense, larger ones sparse (when the mesh is
not one chain): below it a dense factorisation is cheap and keeps what the sparse one lacks
(batching under ``vmap``, accelerators, no host callbacks); above it the dense cost and its n²
memory grow past SuperLU's. On a GPU, pass ``solver="dense"`` to keep larger models there."""


class AbstractLinearSolver(eqx.Module):
    """How a matrix assembled from element groups is factored (see the module docstring). A
    solver holds only static data, so a model that carries one can be built inside ``jit``."""

    batches_factors: ClassVar[bool] = False
    """Whether several of its factorisations are worth making together under ``vmap`` (the error
    estimates' samples and outputs, ``reduction.error_estimate.FACTOR_BATCH``): true where a
    factorisation is many small operations whose fixed cost a batch shares. False by default: a
    dense LU is one large LAPACK call, which a batch does not make cheaper and which, batched, can
    hang on the CPU; a sparse one is host callbacks, one after another under ``vmap`` anyway."""

    @abc.abstractmethod
    def factor(self, parts: Parts, free: Bool[Array, " n"]) -> AbstractFactorization:
        """Assemble the groups ``parts`` into the n × n matrix (n = ``free.shape[0]``), make the
        constrained DOFs (``free`` false) identity rows and columns, and factor."""


class Dense(AbstractLinearSolver):
    """LU of the whole matrix (``dense.DenseLU``)."""

    def factor(self, parts, free) -> DenseLU:
        return DenseLU.factor(assemble_dense(list(parts), free))


class BlockTridiagonal(AbstractLinearSolver):
    """Block LU of one element group on a chain of nodes with ``block`` DOFs each (element e on
    nodes e and e + 1, DOFs numbered node by node)."""

    block: int = eqx.field(static=True)
    batches_factors: ClassVar[bool] = True  # a scan of small block LUs over the nodes

    def factor(self, parts, free) -> BlockTridiagonalLU:
        ((Ge, _),) = parts
        return factor_block_tridiagonal(*assemble_block_tridiagonal(Ge, free, self.block))


class Sparse(AbstractLinearSolver):
    """SuperLU of the matrix in ``pattern`` (built from the element DOFs when None, which needs
    them concrete)."""

    pattern: SparsityPattern | None = eqx.field(static=True, default=None)

    def factor(self, parts, free) -> SparseLU:
        return factor_sparse(list(parts), free, self.pattern)


def linear_solver(solver, parts: Parts, n: int, *, chain_block: int | None = None,
                  pattern: SparsityPattern | None = None) -> AbstractLinearSolver:
    """The ``AbstractLinearSolver`` for these element groups: ``solver`` itself if it is one (or
    names one, ``"dense"``, ``"block_tridiagonal"``, ``"sparse"``) and can factor them
    (``ValueError`` if not), or ``"auto"``'s choice. The element matrices are looked at for their
    shapes only (zeros do); the element DOFs should be NumPy (static), which also builds the
    sparse solver's pattern once here."""
    if isinstance(solver, AbstractLinearSolver):
        name = {Dense: "dense", BlockTridiagonal: "block_tridiagonal", Sparse: "sparse"}[type(solver)]
        if isinstance(solver, BlockTridiagonal):
            chain_block = solver.block
        if isinstance(solver, Sparse) and solver.pattern is not None:
            pattern = solver.pattern
    else:
        name = solver
    kind = choose_solver(parts, n, chain_block=chain_block, solver=name, pattern=pattern)
    if kind == "block_tridiagonal":
        return BlockTridiagonal(int(chain_block))
    if kind == "dense":
        return Dense()
    if pattern is None:
        pattern = SparsityPattern.from_dofs(n, [np.asarray(d) for _, d in parts])
    return Sparse(pattern)


def uses_sparse(solver, n: int) -> bool:
    """Whether ``solver`` (an ``AbstractLinearSolver`` or a name) means the sparse (SuperLU) path
    for a problem of ``n`` unknowns, as the offline stage's eigen and static solves ask:
    ``Sparse``/``"sparse"``, or ``"auto"`` from ``DENSE_MAX_DOFS`` unknowns on; ``Dense``,
    ``BlockTridiagonal`` and ``"dense"`` mean the dense path."""
    if isinstance(solver, AbstractLinearSolver):
        return isinstance(solver, Sparse)
    if solver not in ("auto", "dense", "sparse"):
        raise ValueError(f"solver must be 'auto', 'dense', 'sparse' or a linalg solver, got {solver!r}")
    return solver == "sparse" or (solver == "auto" and n >= DENSE_MAX_DOFS)


def assemble_and_factor(
    parts: Parts, free: Bool[Array, " n"], *, chain_block: int | None = None, solver="auto",
    pattern: SparsityPattern | None = None,
) -> DenseLU | BlockTridiagonalLU | SparseLU:
    """Assemble the element groups ``parts`` (``(Ge, element_dofs)`` pairs: element matrices
    (n_el, nd, nd) and their global DOFs (n_el, nd), all adding into one n × n matrix,
    n = ``free.shape[0]``), make the constrained DOFs (``free`` false) identity rows and columns,
    and factor with ``solver`` (an ``AbstractLinearSolver``, or a name resolved here by
    ``linear_solver``; a model resolves its solver once and passes the object).

    The sparse solver builds its pattern on the host from the element DOFs, so they must be
    concrete (NumPy, or a static field): inside ``jit`` even ``jnp.asarray`` of a NumPy array is
    traced. Where they are traced, pass the ``pattern`` built once from the same DOFs outside the
    trace (``SparsityPattern.from_dofs(n, [element_dofs, ...])``). An unknown solver, or one that
    cannot factor these groups, raises ``ValueError`` before any tracing.
    """
    parts = list(parts)
    if not isinstance(solver, AbstractLinearSolver) or pattern is not None:
        solver = linear_solver(solver, parts, free.shape[0], chain_block=chain_block, pattern=pattern)
    return solver.factor(parts, free)


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
