"""Small tensor contractions as products and sums, which XLA fuses, instead of ``dot`` kernels.

A floating frame's kinematics is a web of tiny contractions: 3 × 3 rotation matrices, their four
derivatives with respect to the Euler parameters, a reduced body's handful of modal coordinates
against its nodal vectors. Written as ``jnp.einsum`` or ``@``, each becomes a ``dot_general``,
and XLA's CPU backend compiles every ``dot`` that survives its simplifier as a kernel of its own
(an LLVM module: about ten milliseconds of compile time each, and a call at run time), where the
same contraction written as a broadcast product and a sum is fused into the kernels around it.
A mechanism's run traces these contractions hundreds of times (the residual, the iteration
matrix, the constraint Jacobian and their forward-mode derivatives), so on a reduced mechanism
the ``dot`` kernels took a third of its compile time (``benchmarks/investigations/compile_breakdown.py``).

``contract(spec, *operands)`` is ``jnp.einsum(spec, *operands)`` written that way when the
broadcast product is small (at most ``MAX_FUSED`` elements: its arithmetic is then negligible
and a kernel's cost is its existence); a larger one (a full-order body's products) stays an
``einsum``, which a matrix-multiply library runs faster than a fused loop.

A batch of runs traced under ``vmap`` (``integrate.simulate_batch``) widens every product by its
lanes, which ``contract`` cannot see (it is traced per member): there, on a CPU, the batched
matrix products ran faster than the fused loops (about a tenth on a batch of pendulums), so the
batch traces its program inside ``as_einsum()``, which keeps every contraction an ``einsum``.
"""

import contextlib
import contextvars
import math

import jax.numpy as jnp

MAX_FUSED = 4096
"""The largest broadcast product (elements) that ``contract`` writes as a product and a sum."""

_AS_EINSUM = contextvars.ContextVar("nrrncf_jax_contract_as_einsum", default=False)


@contextlib.contextmanager
def as_einsum(on: bool = True):
    """Within the block (with ``on``), ``contract`` traces every contraction as ``jnp.einsum``
    (module docstring: a batched program on a CPU)."""
    token = _AS_EINSUM.set(bool(on))
    try:
        yield
    finally:
        _AS_EINSUM.reset(token)


def contract(spec: str, *operands):
    """``jnp.einsum(spec, *operands)``, as a broadcast product summed over the contracted
    indices where that product has at most ``MAX_FUSED`` elements (module docstring). ``spec``:
    explicit einsum notation (``"ij,jk->ik"``); an index repeated within one operand (a trace)
    goes to ``einsum``."""
    inputs, arrow, output = spec.replace(" ", "").partition("->")
    terms = inputs.split(",")
    if not arrow or len(terms) != len(operands):
        raise ValueError(f"contract takes explicit einsum notation with one term an operand, got {spec!r} for "
                         f"{len(operands)} operands")
    operands = [jnp.asarray(x) for x in operands]
    sizes = {}
    for term, x in zip(terms, operands):
        if len(term) != x.ndim:
            raise ValueError(f"contract {spec!r}: term {term!r} for an operand of shape {x.shape}")
        sizes.update(zip(term, x.shape))
    order = list(output) + [c for c in dict.fromkeys(inputs.replace(",", "")) if c not in output]
    repeated = any(len(set(term)) != len(term) for term in terms)
    if repeated or _AS_EINSUM.get() or math.prod(sizes[c] for c in order) > MAX_FUSED:
        return jnp.einsum(spec, *operands)
    product = None
    for term, x in zip(terms, operands):
        ranked = sorted(range(len(term)), key=lambda i: order.index(term[i]))
        x = jnp.transpose(x, ranked) if ranked != list(range(len(term))) else x
        x = x.reshape([sizes[c] if c in term else 1 for c in order])
        product = x if product is None else product * x
    contracted = tuple(range(len(output), len(order)))
    return jnp.sum(product, axis=contracted) if contracted else jnp.broadcast_to(product, [sizes[c] for c in output])
