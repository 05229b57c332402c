"""Factorisation of the integrator's iteration matrix, in one interface with three storage formats:

- ``dense``: any mesh; LU of the whole matrix (small models).
- ``block_tridiagonal``: a chain of nodes (beams); block LU by ``lax.scan`` over the nodes.
- ``sparse``: any mesh, large models; SciPy's SuperLU on the host through a host callback.

A jointed system's constrained matrix is factored body by body with the joints' Schur
complement (``schur``).

One object says which (``assembly``: ``Dense()``, ``BlockTridiagonal(block)``, ``Sparse(pattern)``,
an ``AbstractLinearSolver``; ``linear_solver`` resolves ``"auto"`` once from the static element
DOFs); ``solver.factor(parts, free)`` assembles element groups and factors, and every result has
``.solve(b)``
(``base.AbstractFactorization``). ``assemble_sparse`` and ``sparse_modes`` are the host-side
(SciPy) assembly and shift-invert eigensolver of large models for the offline stage.

The full-order models choose among the three with ``solver=`` ("auto": by size and pattern).
The sparse factorisation runs inside the jit-compiled integration loop, derivatives included,
which is what lets the membrane and the truss run at full order (tens of thousands of DOFs) as the
NR-RNCF reference.
"""

from .assembly import (
    DENSE_MAX_DOFS,
    SOLVERS,
    AbstractLinearSolver,
    BlockTridiagonal,
    Dense,
    Sparse,
    assemble_and_factor,
    choose_solver,
    linear_solver,
    uses_sparse,
)
from .base import AbstractFactorization, Parts
from .block_tridiagonal import BlockTridiagonalLU, assemble_block_tridiagonal, factor_block_tridiagonal
from .dense import DenseInverse, DenseLU, _solve_augmented, _solve_factored, assemble_dense, solve_once
from .schur import AugmentedFactor, dense_augmented, factor_block, schur_factor, solve_blocks
from .sparse import CACHE_SIZE, ScaledSuperLU, SparseLU, SparsityPattern, assemble_sparse, factor_sparse, sparse_modes

__all__ = [
    "AbstractLinearSolver",
    "BlockTridiagonal",
    "Dense",
    "Sparse",
    "linear_solver",
    "uses_sparse",
    "AugmentedFactor",
    "dense_augmented",
    "factor_block",
    "schur_factor",
    "solve_blocks",
    "CACHE_SIZE",
    "DENSE_MAX_DOFS",
    "SOLVERS",
    "ScaledSuperLU",
    "AbstractFactorization",
    "BlockTridiagonalLU",
    "DenseInverse",
    "DenseLU",
    "Parts",
    "SparseLU",
    "SparsityPattern",
    "_solve_augmented",
    "_solve_factored",
    "assemble_and_factor",
    "assemble_block_tridiagonal",
    "assemble_dense",
    "assemble_sparse",
    "choose_solver",
    "factor_block_tridiagonal",
    "factor_sparse",
    "solve_once",
    "sparse_modes",
]
