"""Factorisation of the integrator's iteration matrix, in one interface with three storage formats:

- ``dense``: any mesh; LU of the whole matrix (small models).
- ``block_tridiagonal``: a chain of nodes (beams); block LU by ``lax.scan`` over the nodes.
- ``sparse``: any mesh, large models; SciPy's SuperLU on the host through a host callback.

``assemble_and_factor(parts, free, chain_block=..., solver=...)`` assembles element groups into
one of them and factors (``assembly``); every result has ``.solve(b)``
(``base.AbstractFactorization``). ``assemble_sparse`` and ``sparse_modes`` are the host-side
(SciPy) assembly and shift-invert eigensolver of large models for the offline stage.
"""

from .assembly import DENSE_MAX_DOFS, SOLVERS, assemble_and_factor, choose_solver
from .base import AbstractFactorization, Parts
from .block_tridiagonal import BlockTridiagonalLU, assemble_block_tridiagonal, factor_block_tridiagonal
from .dense import DenseLU, _solve_augmented, _solve_factored, assemble_dense, solve_once
from .sparse import CACHE_SIZE, ScaledSuperLU, SparseLU, SparsityPattern, assemble_sparse, factor_sparse, sparse_modes

__all__ = [
    "CACHE_SIZE",
    "DENSE_MAX_DOFS",
    "SOLVERS",
    "ScaledSuperLU",
    "AbstractFactorization",
    "BlockTridiagonalLU",
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
