"""What a simulation records: the displacement of a beam's tip, as a small ``observe`` function.

Observing three numbers per output (not the whole state) keeps the integrator's output buffers,
and the reverse pass's checkpoints, small. Shared by the sweeps, the control design and the
identification demonstration.
"""

import equinox as eqx
import jax
import jax.numpy as jnp

from .._types import Array, Float
from ..elements.beam import NODAL_VECTORS_PER_NODE


class TipObserver(eqx.Module):
    """Displacement of one nodal vector, ``offset + rows @ x``: the observe function for ``simulate``."""

    rows: Float[Array, "3 n"]
    offset: Float[Array, " 3"]

    def __call__(self, t, x, v):
        return self.offset + self.rows @ x


def tip_index(body) -> int:
    """Index of the beam tip's position vector: the first vector of the last node."""
    return body.n_vectors - body.vectors_per_node


def beam_tip(model) -> int:
    """``tip_index`` of the beam a model (full or reduced, with or without its body) is built on."""
    return model.q_hat.shape[0] - NODAL_VECTORS_PER_NODE


def tip_observer(model, tip: int | None = None) -> TipObserver:
    """The ``TipObserver`` of nodal vector ``tip`` of a rotating-frame model (full RNCF or
    reduced), whose displacements ``model.displacements(t, x)`` are affine in x and do not depend
    on t. ``tip=None`` takes the beam tip of ``model.body`` (a reduced model built with
    ``force='tensor'`` keeps no body: pass ``tip=tip_index(body)``)."""
    if type(model).__name__ == "InertialFrameModel":
        raise ValueError("tip_observer needs a rotating-frame model (RNCF or reduced): inertial-frame "
                         "displacements depend on the rotation angle")
    if tip is None:
        body = getattr(model, "body", None)
        if body is None:
            raise ValueError("this model keeps no body: pass tip=tip_index(body), the tip's nodal vector index")
        tip = tip_index(body)
    f = lambda x: model.displacements(0.0, x)[tip]  # noqa: E731
    z = jnp.zeros(model.n_dof)
    return TipObserver(rows=jax.jacfwd(f)(z), offset=f(z))
