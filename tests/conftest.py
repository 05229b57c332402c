"""Tests run in float64 (switched on here, never by the library)."""

import functools
import os

# XLA compiles the suite's programs for speed of compilation, not of running: the suite's time is
# mostly XLA compiling small programs that then run for a fraction of a second. Set before JAX
# starts its backend; an XLA_FLAGS that names an option already wins. The same float64
# arithmetic either way (no fast-math: LLVM's passes only contract a·b + c into FMAs, and the two
# fusion emitters round alike up to such contractions and summation orders, which the
# tolerances allow). The notebooks' run-bound truss keeps the defaults (tests/test_notebooks.py).
FAST_COMPILE_FLAGS = (
    # LLVM's optimisation passes skipped (the default is level 2): about a sixth of the suite's time.
    "--xla_backend_optimization_level=0",
    # The older LLVM IR emitter for fused element-wise kernels instead of the MLIR one: compiles
    # 20-45 % faster; reduced models run as fast, full-order ones about a quarter slower
    # (benchmarks/results/xla_options.md).
    "--xla_cpu_use_fusion_emitters=false",
)
for _flag in FAST_COMPILE_FLAGS:
    if _flag.split("=")[0] not in os.environ.get("XLA_FLAGS", ""):
        os.environ["XLA_FLAGS"] = f"{os.environ.get('XLA_FLAGS', '')} {_flag}".strip()

import jax  # noqa: E402
import numpy as np  # noqa: E402

# The CLI's persistent compilation cache stays off in the (in-process) CLI tests.
os.environ["NRRNCF_JAX_CACHE"] = "off"

jax.config.update("jax_enable_x64", True)

import pytest  # noqa: E402

from nrrncf_jax.scenarios import beam_preset  # noqa: E402

# Tolerances, in one place (float64). Each is what round-off or the method's own error allows, not
# what happens to pass on one machine.
EPS = float(np.finfo(np.float64).eps)
"""float64's machine epsilon: bounds that grow with a condition number or an operation count scale it."""

RTOL_ROUNDOFF = 1e-10
"""One quantity by two operation orders (jit against eager, batched against single, closed form
against automatic differentiation) on a problem of condition below ~1e5: ε·cond ≲ 2e-11, ×5 spare."""

RTOL_RESIDUAL = 1e-12
"""A residual or force vector (an assembled row: a few hundred terms, each a short chain of
operations on O(1) numbers) by two operation orders, relative to its largest entry: ~4500 ε."""

FD_STEP = 1e-5
"""Relative step of a central difference: truncation O(h²) ~ 1e-10 relative, round-off ε/h ~ 2e-11
times the run's amplification of a perturbation."""

RTOL_FD = 1e-5
"""A derivative against its central difference at ``FD_STEP``: the quotient's round-off, ε|f|/h
amplified by the simulation (measured up to 1e-7 relative), with a factor ~100 to spare."""

STEP_COUNT_RTOL = 0.02
"""Step or Newton counts of two runs of the same problem by different operation orders (batched and
single, sparse and dense LU, two CPUs' arithmetics): a decision (accept or reject, one Newton
correction more or less) whose test lies within round-off of its threshold can flip; a few of a
run's ~100 decisions at most."""


def counts_close(a, b) -> bool:
    """Two runs' step (or Newton) counts within ``STEP_COUNT_RTOL``, and at least the 2 that one
    flipped decision can change them by (a rejected step retried in two)."""
    a, b = int(a), int(b)
    return abs(a - b) <= max(2.0, STEP_COUNT_RTOL * max(a, b))


def roundoff_tol(A) -> float:
    """Two backward-stable solves of A x = b agree to about cond(A)·ε relative; a factor 100 for the
    growth constants of the factorisations. The 1-norm condition number (an inverse, not an SVD)."""
    return float(100 * np.linalg.cond(A, 1) * EPS)


def step_flip_bound(rtol, atol, y) -> float:
    """How far two adaptive runs of the same problem may lie apart where round-off flipped one
    step decision (``STEP_COUNT_RTOL``): about one step's error tolerance, atol + rtol·max|y|. Runs
    that must agree to round-off take fixed steps instead."""
    return float(atol + rtol * np.abs(np.asarray(y)).max())


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

    return run_pendulum(PendulumSpec(elements=2), **pendulum_run_options(PENDULUM_RUN))


def pendulum_run_options(options: dict) -> dict:
    """``PENDULUM_RUN``'s settings as ``run_pendulum``'s keywords: the output times, the solver
    (ρ∞) and the step-size controller (rtol, atol)."""
    from nrrncf_jax.integrate import AdaptiveStepSize, GeneralizedAlphaIndex3

    return dict(t_end=options["t_end"], dt_out=options["dt_out"], solver=GeneralizedAlphaIndex3(options["rho_inf"]),
                controller=AdaptiveStepSize(options["rtol"], options["atol"]))


def pytest_collection_modifyitems(config, items):
    """The longest tests first: the notebooks, then the rest of the slow tier, then the fast one
    (a stable sort: each file's order within a rank is kept). pytest-xdist hands work to its
    workers in this order, so a notebook of two minutes started last would leave the other
    worker idle until it ends."""
    def rank(item):
        if item.path.name == "test_notebooks.py":
            return 0
        return 1 if item.get_closest_marker("slow") else 2

    items.sort(key=rank)
