"""``forward_mode_only(tree, message)``: the identity on a forward-mode loop's results that turns
``jax.grad`` through it into one line naming the option that avoids it.

``simulate``'s default loop is a ``lax.while_loop``: forward-mode differentiable, vmappable and
fastest, but not transposable. Reverse mode through it fails in JAX's transposition with an error
that names ``lax.while_loop`` and not the ``adjoint`` option, deep inside a user's ``jax.grad``.
This identity sits on the loop's outputs, where transposition meets it first: its tangent is
itself (``jax.jvp``, ``jax.jacfwd`` and ``vmap`` pass through, and it compiles to nothing), and its
transpose raises ``ValueError(message)``. Hand-written as a JAX primitive because JAX has no public
hook for a transpose rule alone (``custom_vjp`` would refuse forward mode, and
``custom_derivatives.linear_call`` has no batching rule).
"""

import jax.numpy as jnp
import jax.tree_util as jtu
from jax.extend.core import Primitive
from jax.interpreters import ad, batching, mlir

_forward_mode_only_p = Primitive("forward_mode_only")


def _identity(x, *, message):
    return x


def _jvp(primals, tangents, *, message):
    (x,), (t,) = primals, tangents
    out = _forward_mode_only_p.bind(x, message=message)
    return out, (t if type(t) is ad.Zero else _forward_mode_only_p.bind(t, message=message))


def _transpose(ct, x, *, message):
    raise ValueError(message)


def _batch(args, dims, *, message):
    return _forward_mode_only_p.bind(args[0], message=message), dims[0]


_forward_mode_only_p.def_impl(_identity)
_forward_mode_only_p.def_abstract_eval(_identity)
ad.primitive_jvps[_forward_mode_only_p] = _jvp
ad.primitive_transposes[_forward_mode_only_p] = _transpose
batching.primitive_batchers[_forward_mode_only_p] = _batch
mlir.register_lowering(_forward_mode_only_p, mlir.lower_fun(_identity, multiple_results=False))


def forward_mode_only(tree, message: str):
    """``tree`` unchanged; reverse-mode differentiation through its floating-point leaves raises
    ``ValueError(message)`` (see the module docstring)."""

    def mark(x):
        if hasattr(x, "dtype") and jnp.issubdtype(x.dtype, jnp.inexact):
            return _forward_mode_only_p.bind(x, message=message)
        return x

    return jtu.tree_map(mark, tree)
