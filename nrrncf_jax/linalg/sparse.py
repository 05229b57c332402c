"""Sparse direct LU of the iteration matrix, for large models (tens of thousands of DOFs).

SciPy's SuperLU (``scipy.sparse.linalg.splu``) on the host through a host callback (``_host_call``:
``jax.experimental.buffer_callback`` on the CPU, ``jax.pure_callback`` elsewhere), with the
derivative from ``lax.custom_linear_solve``. Neither JAX nor lineax has a sparse direct
factorisation on the CPU (``jax.experimental.sparse.linalg.spsolve`` calls SciPy's ``spsolve``,
which refactors on every solve; lineax's sparse path is iterative), so the parts written here are
the ones they lack:

- ``SparsityPattern``: the CSC pattern of the assembled matrix and the index maps from element
  entries to its slots, built once on the host with NumPy from the concrete element DOFs, so that
  a factorisation only scatters values (``jnp.zeros(nnz).at[slots].add(Ge)``).
- ``SparseLU``: the values, the pattern (static) and an integer handle to the SuperLU factors,
  which stay on the host: the factor callback stores them in a small cache (``CACHE_SIZE``
  factorisations, least recently used dropped first) and returns the handle; each solve looks the
  factors up by handle. The values travel with the handle, so a solve whose factors have been
  dropped (a reverse pass long after the forward one, a batch larger than the cache) factors them
  again: the cache is a speed-up, never a source of results. A matrix SuperLU finds singular gives
  NaNs, as the dense LU's infinities do, so that the integrator rejects the step.
- the derivative of ``x = A⁻¹ b``: ``lax.custom_linear_solve`` with the sparse product as the
  matrix and SuperLU's solve and transposed solve (``trans="T"``, the same factors) as its solves,
  so forward mode gives ``dx = A⁻¹ (db − dA x)`` and reverse mode the transposed solve, with dA
  through the values of the pattern's slots.

Supported: ``jit``, use inside ``lax.while_loop``/``scan`` bodies, ``jvp``/``grad`` with respect
to the element matrices and the right-hand side, several solves per factorisation.
Not supported, or not fast:

- ``vmap``: falls back to a loop (the callback's ``vmap_method="sequential"`` and a
  ``lax.map`` over the members): the members are factored and solved one after another on the
  host; with more members than ``CACHE_SIZE``, the oldest are factored again at their first
  solve. Correct, but no faster than a Python loop.
- accelerators: the factorisation runs on the host CPU; on a GPU every factor and solve copies
  the values and the vector between device and host.
- traced element DOFs: the pattern is built on the host, so the element DOFs must be concrete
  (NumPy arrays or a static field; inside ``jit`` even ``jnp.asarray`` of a NumPy array is
  traced), or the ``SparsityPattern`` built from them beforehand must be passed along.
- derivatives through ``sparse_modes`` and ``assemble_sparse`` (host-side NumPy/SciPy).
"""

import hashlib
import itertools
import threading
from collections import OrderedDict
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from jax import lax

from .._types import Array, Bool, Float, Int
from .._validate import is_concrete
from .base import AbstractFactorization, Parts

try:  # JAX >= 0.6.1
    from jax.experimental.buffer_callback import buffer_callback as _buffer_callback
except ImportError:  # pragma: no cover - older JAX: pure_callback everywhere
    _buffer_callback = None

CACHE_SIZE = 8
"""SuperLU factorisations kept on the host for later solves (least recently used dropped first)."""

CACHE_BYTES = 1 << 30
"""...and at most this much memory in their factors (the newest is always kept). A plate mesh's
factors are large (a 2-D mesh fills far more than a chain): ``CACHE_SIZE`` factorisations of the
rotating membrane alone would take several GB."""

PERMC_SPEC = "MMD_AT_PLUS_A"
"""SuperLU's fill-reducing column ordering. The iteration matrix is structurally symmetric and
nearly symmetric in value, so a minimum-degree ordering of Aᵀ + A with a preference for diagonal
pivots (``DIAG_PIVOT_THRESH``, symmetric mode) keeps the fill of a symmetric factorisation: on a
2-D mesh it fills less and factors faster than SciPy's default COLAMD, and on a chain it does as
well."""

DIAG_PIVOT_THRESH = 0.1
"""SuperLU takes the diagonal entry as pivot unless it is smaller than this fraction of its
column's largest (threshold partial pivoting): stable, and the ordering's fill is kept."""


class SparsityPattern:
    """The CSC pattern of an n × n matrix assembled from element groups, always with its whole
    diagonal (constrained DOFs become identity rows), and the map from element entries to slots.

    Host-side NumPy, built once (``from_dofs``) and hashed by content, so that it can be a static
    field: two patterns of the same mesh compare equal and do not retrace.

    ``indptr``, ``indices``: CSC (``indices`` the row of each slot, column by column, rows sorted);
    ``rows``, ``cols``: the same slots as COO; ``diag``: the slot of each diagonal entry;
    ``slots``: per group, an (n_el, nd, nd) array of the slot of each element entry (entries of
    several elements at one place share a slot and are added).
    """

    def __init__(self, n: int, element_dofs: Sequence[np.ndarray]):
        n = int(n)
        dofs = [np.asarray(d).astype(np.int64, copy=False) for d in element_dofs]
        for d in dofs:
            if d.ndim != 2:
                raise ValueError(f"element_dofs must be (n_el, nd), got shape {d.shape}")
            if d.size and (d.min() < 0 or d.max() >= n):
                raise ValueError(f"element_dofs must lie in [0, {n}), got [{d.min()}, {d.max()}]")
        # Keys col·n + row sort entries into CSC order (int64: n² passes 2³¹ at 46,341 DOFs).
        keys = [(d[:, None, :] * n + d[:, :, None]).reshape(-1) for d in dofs]
        keys.append(np.arange(n, dtype=np.int64) * (n + 1))
        unique, inverse = np.unique(np.concatenate(keys), return_inverse=True)
        index = np.int32 if unique.size < 2**31 else np.int64
        self.n = n
        self.nnz = int(unique.size)
        self.rows = (unique % n).astype(index)
        self.cols = (unique // n).astype(index)
        self.indices = self.rows
        self.indptr = np.searchsorted(self.cols, np.arange(n + 1)).astype(index)
        bounds = np.cumsum([0] + [k.size for k in keys])
        self.slots = tuple(inverse[a:b].astype(index).reshape(d.shape[0], d.shape[1], d.shape[1])
                           for a, b, d in zip(bounds[:-1], bounds[1:], dofs))
        self.diag = inverse[bounds[-2]:].astype(index)
        self.digest = _digest(n, dofs)

    _cache: "OrderedDict[str, SparsityPattern]" = OrderedDict()

    @classmethod
    def from_dofs(cls, n: int, element_dofs: Sequence) -> "SparsityPattern":
        """The pattern of these groups' element DOFs (concrete arrays), cached by content."""
        dofs = []
        for d in element_dofs:
            if not is_concrete(d):
                raise ValueError(
                    "the sparse solver builds its sparsity pattern on the host from concrete element_dofs, "
                    "got a traced array: keep the element DOFs out of the jit-compiled function's arguments "
                    "(a NumPy array or a static field)")
            dofs.append(np.asarray(d))
        key = _digest(n, dofs)
        if key in cls._cache:
            cls._cache.move_to_end(key)
            return cls._cache[key]
        pattern = cls(n, dofs)
        cls._cache[key] = pattern
        while len(cls._cache) > 8:
            cls._cache.popitem(last=False)
        return pattern

    def check(self, parts: Parts, n: int) -> None:
        """``ValueError`` unless these groups (and n) are the ones the pattern was built from; traced
        element DOFs are checked by shape only."""
        shapes = [tuple(d.shape) for _, d in parts]
        if n != self.n or shapes != [s.shape[:2] for s in self.slots]:
            raise ValueError(f"the sparsity pattern was built for {self.n} DOFs and element groups of shapes "
                             f"{[s.shape[:2] for s in self.slots]}, got {n} DOFs and {shapes}")
        if all(is_concrete(d) for _, d in parts) and _digest(n, [np.asarray(d) for _, d in parts]) != self.digest:
            raise ValueError("the sparsity pattern was built from other element DOFs than these")

    def __hash__(self):
        return hash(self.digest)

    def __eq__(self, other):
        return isinstance(other, SparsityPattern) and self.digest == other.digest

    def __repr__(self):
        return f"SparsityPattern(n={self.n}, nnz={self.nnz})"

    def values(self, parts: Parts, free: Bool[Array, " n"]) -> Float[Array, " nnz"]:
        """The matrix's values in the pattern's slots, constrained rows and columns identity."""
        dtype = jnp.result_type(*(Ge for Ge, _ in parts))
        f = jnp.asarray(free).astype(dtype)
        data = jnp.zeros(self.nnz, dtype)
        for (Ge, dofs), slots in zip(parts, self.slots):
            # Masked per element, not per slot: f[rows]·f[cols] over all nnz slots, with ``free``
            # a constant, is a large gather that XLA constant-folds at compile time, slowly for
            # large meshes.
            fe = f[jnp.asarray(dofs)]
            data = data.at[slots].add(Ge * fe[:, :, None] * fe[:, None, :])
        return data.at[self.diag].add(1.0 - f)

    def matvec(self, data: Float[Array, " nnz"], x: Float[Array, " n"]) -> Float[Array, " n"]:
        """A x, A the pattern's matrix with these values."""
        return jax.ops.segment_sum(data * x[self.cols], self.rows, num_segments=self.n)

    def csc(self, data) -> sp.csc_matrix:
        """The SciPy matrix with these (concrete) values."""
        return sp.csc_matrix((np.asarray(data), self.indices, self.indptr), shape=(self.n, self.n))


def _digest(n: int, dofs: Sequence[np.ndarray]) -> str:
    h = hashlib.sha1(np.int64(n).tobytes())
    for d in dofs:
        h.update(np.asarray(d.shape, np.int64).tobytes())
        h.update(np.ascontiguousarray(d.astype(np.int64, copy=False)).tobytes())
    return h.hexdigest()


# ---- host side: SuperLU factors kept between the factor and solve callbacks ------------------------

_factors: "OrderedDict[int, object]" = OrderedDict()
_lock = threading.Lock()
_handles = itertools.count(1)

# Every SuperLU object is made, used and freed on this one thread. SciPy's SuperLU wrapper keeps
# the memory SuperLU allocates in a per-thread registry and frees only what the freeing thread's
# registry holds, so factors made on one thread and dropped on another are never freed
# (scipy/scipy#15921). XLA runs host callbacks on threads of its own, so factoring on one and
# evicting from the cache on another would leak one factorisation a step. Solves go through it
# too: a solve may hold the last reference to factors another callback has just evicted.
_superlu_thread = ThreadPoolExecutor(max_workers=1, thread_name_prefix="nrrncf-superlu")


def _on_superlu_thread(fn, *args):
    return _superlu_thread.submit(fn, *args).result()


def _splu(pattern: SparsityPattern, data: np.ndarray):
    """SuperLU factors of the pattern's matrix with these values, or None if it is singular or
    not finite."""
    if not np.all(np.isfinite(data)):
        return None
    try:
        return ScaledSuperLU(pattern.csc(data))
    except RuntimeError:  # "Factor is exactly singular"
        return None


class ScaledSuperLU:
    """SuperLU factors of ``D A D``, D = diag(|A_ii|^-½) (1 where A_ii = 0), and the solves
    ``A⁻¹ b = D (DAD)⁻¹ D b`` (and with Aᵀ alike).

    Why the symmetric scaling: SuperLU's threshold test (``DIAG_PIVOT_THRESH``) compares a
    diagonal entry with its column's largest, which is not invariant to the units of the
    coordinates. A body whose nodal vectors have very different stiffnesses (a frame's joint
    gradients against a beam's curvature vectors, as on the truss of ``scenarios.truss``) fails
    the test on many columns; the pivots then leave the diagonal and the fill-reducing ordering is
    lost, which multiplies the factors' size and the factorisation time. With a unit diagonal the
    test measures how diagonally dominant a column is, whatever the units."""

    def __init__(self, A: sp.spmatrix):
        A = sp.csc_matrix(A)
        diag = np.abs(A.diagonal())
        self.d = np.where(diag > 0.0, 1.0 / np.sqrt(np.where(diag > 0.0, diag, 1.0)), 1.0)
        D = sp.diags(self.d)
        self.lu = spla.splu((D @ A @ D).tocsc(), permc_spec=PERMC_SPEC, diag_pivot_thresh=DIAG_PIVOT_THRESH,
                            options=dict(SymmetricMode=True))
        # the factors' memory: values and row indices of L and U, and the permutations
        self.nbytes = 12 * self.lu.nnz + 16 * A.shape[0]
        self.thread = threading.get_ident()  # SciPy frees SuperLU's memory only on this thread

    @property
    def shape(self):
        return self.lu.shape

    def solve(self, b: np.ndarray, trans: str = "N") -> np.ndarray:
        d = self.d.reshape((-1,) + (1,) * (np.ndim(b) - 1))
        return d * self.lu.solve(d * b, trans=trans)


def _nbytes(lu) -> int:
    return 0 if lu is None else lu.nbytes


def _store(handle: int, lu, limit: int) -> None:
    with _lock:
        _factors[handle] = lu
        _factors.move_to_end(handle)
        while len(_factors) > 1 and (len(_factors) > limit or
                                     sum(_nbytes(f) for f in _factors.values()) > CACHE_BYTES):
            _factors.popitem(last=False)


def _host_factor(pattern: SparsityPattern, data: np.ndarray) -> np.ndarray:
    handle = next(_handles) % (2**31 - 1) + 1
    _on_superlu_thread(lambda: _store(handle, _splu(pattern, np.asarray(data)), CACHE_SIZE))
    return np.asarray(handle, np.int32)


def _lookup(handle: int):
    """(found, factors) for this handle."""
    with _lock:
        if handle not in _factors:
            return False, None
        _factors.move_to_end(handle)
        return True, _factors[handle]


def _apply(lu, trans: str, b: np.ndarray) -> np.ndarray:
    if lu is None:
        return np.full(b.shape, np.nan, b.dtype)
    return lu.solve(b, trans=trans).astype(b.dtype, copy=False)


def _host_solve(trans: str, handle: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The solve with the cached factors, and whether they were there (zeros if not)."""
    b = np.asarray(b)

    def solve():
        found, lu = _lookup(int(handle))
        return (_apply(lu, trans, b) if found else np.zeros_like(b)), np.asarray(found)

    return _on_superlu_thread(solve)


def _host_refactor_solve(pattern: SparsityPattern, trans: str, data: np.ndarray, handle: np.ndarray,
                         b: np.ndarray) -> np.ndarray:
    """The solve after factoring again from the values (the factors were dropped from the cache)."""
    handle = int(handle)

    def refactor_solve():
        found, lu = _lookup(handle)
        if not found:
            # Kept without pushing out the CACHE_SIZE newest (up to twice as many in all): members of a
            # batch solved in turn after all were factored would otherwise push each other out.
            lu = _splu(pattern, np.asarray(data))
            _store(handle, lu, 2 * CACHE_SIZE)
        return _apply(lu, trans, np.asarray(b))

    return _on_superlu_thread(refactor_solve)


def _host_call(fn, result_shape_dtypes, *args, vmap_method: str | None = None):
    """``fn(*args)`` on the host, with NumPy arrays in and out (``result_shape_dtypes``: a tuple of
    ``jax.ShapeDtypeStruct``, ``fn`` returns a tuple of arrays of those shapes and dtypes).

    Why not ``jax.pure_callback`` alone: it hands the callback its arguments as ``jax.Array``s,
    placed with ``device_put`` from the running computation's buffers, and reading one
    (``np.asarray``) waits for that copy. On a machine where XLA's CPU client has one thread (one
    core: ``taskset -c 0``, a one-CPU container), the copy can be queued behind the very
    computation that waits for it, a deadlock (jax-ml/jax#24255).
    ``buffer_callback`` hands over XLA's own buffers (valid during the call; copied here before
    anything keeps them), with no transfer to wait for. It reads buffers as NumPy arrays on the
    CPU only, so other platforms keep ``pure_callback`` (``lax.platform_dependent`` lowers just
    the branch of the platform)."""
    def with_pure_callback(*a):
        return jax.pure_callback(fn, result_shape_dtypes, *a, vmap_method=vmap_method)

    if _buffer_callback is None:
        return with_pure_callback(*args)

    def fill(ctx, outs, *buffers):
        del ctx
        results = fn(*(np.asarray(b).copy() for b in buffers))
        for out, result in zip(outs, results):
            np.asarray(out)[...] = result

    def with_buffers(*a):
        return tuple(_buffer_callback(fill, tuple(result_shape_dtypes), vmap_method=vmap_method)(*a))

    return lax.platform_dependent(*args, cpu=with_buffers, default=with_pure_callback)


def _solve(pattern: SparsityPattern, trans: str, data, handle, b):
    """``A⁻¹ b`` (``trans="N"``) or ``A⁻ᵀ b`` (``"T"``) with the factors under ``handle``. The
    values go to the host only when the factors have been dropped (``lax.cond``): passing the
    nnz values to every callback would copy them each time, which on a large mesh takes most of
    a solve's time."""

    @jax.custom_batching.custom_vmap
    def solve(data, handle, b):
        x, found = _host_call(lambda h, v: _host_solve(trans, h, v),
                              (jax.ShapeDtypeStruct(b.shape, b.dtype), jax.ShapeDtypeStruct((), jnp.bool_)), handle, b)
        return lax.cond(found, lambda: x, lambda: _host_call(
            lambda d, h, v: (_host_refactor_solve(pattern, trans, d, h, v),),
            (jax.ShapeDtypeStruct(b.shape, b.dtype),), data, handle, b)[0])

    @solve.def_vmap
    def _solve_batched(axis_size, in_batched, data, handle, b):
        # One member after another, each with its own cond (a batched cond would run the
        # refactoring branch for every member).
        args = tuple(x if batched else jnp.broadcast_to(x, (axis_size,) + jnp.shape(x))
                     for x, batched in zip((data, handle, b), in_batched))
        return lax.map(lambda a: solve(*a), args), True

    return solve(lax.stop_gradient(data), handle, b)


class SparseLU(AbstractFactorization):
    """SuperLU factors of a sparse matrix (the values ``data`` in ``pattern``'s slots), held on
    the host under ``handle``. See the module docstring for what it supports."""

    data: Float[Array, " nnz"]
    handle: Int[Array, ""]
    pattern: SparsityPattern = eqx.field(static=True)

    @classmethod
    def factor(cls, data: Float[Array, " nnz"], pattern: SparsityPattern) -> "SparseLU":
        data = jnp.asarray(data)
        handle, = _host_call(lambda d: (_host_factor(pattern, d),), (jax.ShapeDtypeStruct((), jnp.int32),),
                             lax.stop_gradient(data), vmap_method="sequential")
        return cls(data=data, handle=handle, pattern=pattern)

    def solve(self, b: Float[Array, " n"]) -> Float[Array, " n"]:
        pattern, data, handle = self.pattern, self.data, self.handle

        b = jnp.asarray(b, jnp.result_type(data, b))
        return lax.custom_linear_solve(lambda x: pattern.matvec(data, x), b,
                                       solve=lambda _, r: _solve(pattern, "N", data, handle, r),
                                       transpose_solve=lambda _, r: _solve(pattern, "T", data, handle, r))


def factor_sparse(parts: Parts, free: Bool[Array, " n"], pattern: SparsityPattern | None = None) -> SparseLU:
    """Assemble the groups' element matrices into the sparse pattern of their (concrete) element
    DOFs (or ``pattern``, built from them before), make constrained DOFs identity, and factor."""
    if pattern is None:
        pattern = SparsityPattern.from_dofs(free.shape[0], [d for _, d in parts])
    return SparseLU.factor(pattern.values(parts, free), pattern)


def assemble_sparse(parts: Parts, n: int, free: Bool[np.ndarray, " n"] | None = None) -> sp.csc_matrix:
    """The n × n matrix of the groups' element matrices as a SciPy CSC matrix (host-side NumPy;
    for the offline stage). With ``free``, constrained rows and columns become identity."""
    pattern = SparsityPattern.from_dofs(n, [np.asarray(d) for _, d in parts])
    data = np.zeros(pattern.nnz, dtype=np.result_type(*(np.asarray(Ge).dtype for Ge, _ in parts)))
    for (Ge, _), slots in zip(parts, pattern.slots):
        np.add.at(data, slots.reshape(-1), np.asarray(Ge).reshape(-1))
    if free is not None:
        f = np.asarray(free).astype(data.dtype)
        data = data * f[pattern.rows] * f[pattern.cols]
        data[pattern.diag] += 1.0 - f
    return pattern.csc(data)


def sparse_modes(K: sp.spmatrix, M: sp.spmatrix, k: int, sigma: float = 0.0,
                 free: Bool[np.ndarray, " n"] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The ``k`` vibration modes of ``(K − ω² M) φ = 0`` nearest ω² = ``sigma`` (the lowest for
    sigma = 0 and K positive definite) by shift-invert Lanczos (``scipy.sparse.linalg.eigsh``,
    one sparse LU of K − σM). Host-side NumPy/SciPy for the offline stage; not differentiable.

    ``K`` and ``M`` are symmetric sparse n × n matrices; with ``free``, only the free rows and
    columns enter and the modes are zero on the constrained DOFs. Returns ``omega`` (k,)
    [rad/s, ascending] and mass-normalised ``phi`` (n × k), as ``reduction.vibration_modes``.
    A singular K − σM (a free body at σ = 0) raises: pick σ below the lowest eigenvalue.
    """
    K, M = sp.csc_matrix(K), sp.csc_matrix(M)
    n = K.shape[0]
    idx = np.arange(n) if free is None else np.flatnonzero(np.asarray(free))
    Kf, Mf = K[idx][:, idx].tocsc(), M[idx][:, idx].tocsc()
    if not 0 < k < idx.size:
        raise ValueError(f"k must be between 1 and {idx.size - 1} (the free DOFs less one), got {k}")
    shifted = (Kf - sigma * Mf).tocsc()
    lu = ScaledSuperLU(shifted)
    OPinv = spla.LinearOperator(shifted.shape, matvec=lu.solve, dtype=shifted.dtype)
    w2, V = spla.eigsh(Kf, k=k, M=Mf, sigma=sigma, which="LM", OPinv=OPinv)
    order = np.argsort(w2)
    w2, V = w2[order], V[:, order]
    V = V / np.sqrt(np.einsum("ik,ik->k", V, Mf @ V))
    phi = np.zeros((n, k), V.dtype)
    phi[idx] = V
    return np.sqrt(np.maximum(w2, 0.0)), phi
