"""Tests run in float64 (switched on here, never by the library)."""

import functools
import os

import jax

# The CLI's persistent compilation cache stays off in the (in-process) CLI tests.
os.environ["NRRNCF_JAX_CACHE"] = "off"

jax.config.update("jax_enable_x64", True)

import pytest  # noqa: E402

from nrrncf_jax.scenarios import beam_preset  # noqa: E402

# Tolerances, in one place (float64).
RTOL_ROUNDOFF = 1e-10


@functools.cache
def paper_body(n_el: int, beam: str = "paper"):
    return beam_preset(beam).body(n_el)


@pytest.fixture(scope="session")
def paper4():
    return paper_body(4)


PENDULUM_RUN = dict(t_end=0.4, dt_out=0.01, rho_inf=1.0, rtol=1e-5, atol=1e-6)
"""The coarse three-beam pendulum's run settings, shared by the full and the reduced runs."""


@pytest.fixture(scope="session")
def pendulum_run():
    """The paper's three-beam pendulum at full order (ANCF), 2 elements a beam, 0-0.4 s, ρ∞ = 1.
    Its tests share an xdist group, so that one worker runs it once. (xdist_group needs pytest
    < 9.2, pinned in pyproject.toml: pytest-xdist 3.8 tags the group through ``item._nodeid``,
    which pytest 9.2's ``nodeid`` no longer reads, and grouped tests landed on both workers.)"""
    from nrrncf_jax.scenarios.pendulum import PendulumSpec, run_pendulum

    return run_pendulum(PendulumSpec(elements=2), **PENDULUM_RUN)
