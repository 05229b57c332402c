"""How a simulation ended: ``SimulationResult`` (an ``equinox.Enumeration``, as ``NewtonResult``
and diffrax's ``RESULTS``) and the error a stopped run raises."""

import equinox as eqx


class SimulationResult(eqx.Enumeration):
    """How ``simulate`` ended; ``Solution.result`` holds one (batched: one a member)."""

    successful = ""
    max_steps_reached = "max_steps reached before t_end"
    dt_min_reached = "step size fell below dt_min: Newton failed to converge or the error could not be controlled"
    nonfinite = "the state became non-finite (NaN/Inf) and no smaller step recovered it"


ENDINGS = (SimulationResult.successful, SimulationResult.max_steps_reached, SimulationResult.dt_min_reached,
           SimulationResult.nonfinite)
"""The endings in the order of their integer codes (``result_code``)."""


def result_code(result: SimulationResult):
    """The integer code of a result (its index in ``ENDINGS``; 0 for success), an array of the
    result's shape: what batched and sharded programs carry (equinox keeps it as ``_value``)."""
    return result._value


def result_message(code: int) -> str:
    """The message of an integer result code ('' for success)."""
    return SimulationResult[ENDINGS[int(code)]]


class SimulationError(RuntimeError):
    """A simulation stopped before its end time; the message names the time reached and why."""


__all__ = ["ENDINGS", "SimulationError", "SimulationResult", "result_code", "result_message"]
