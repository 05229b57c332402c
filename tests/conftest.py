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
