"""How fast modified Newton converges in the pendulum's index-3 step, with and without the inertia
terms' p columns in its iteration matrix (``multibody.floating.FloatingBody.deformation_tangent``).

    python benchmarks/investigations/newton_contraction.py [--elements 10] [--times 1.0 1.5] [--h 2e-4]
                                            [--out benchmarks/results/newton_contraction.md]

For each model (the full-order RNCF pendulum in the frame of its left ends' tangents,
``LEFT_END_FRAME``, and in their section vectors', ``LEFT_SECTION_FRAME``; the NR-RNCF pendulum,
5 VMs + 15 MDs a beam) the run at rtol 1e-4 gives the states at ``--times``; from each, with its
consistent (a, λ), one step of ``--h`` is solved by modified Newton on the matrix factored at the
predictor (as ``integrate.GeneralizedAlphaIndex3`` does), eight corrections, no stopping test.
The table gives each correction's size ‖c_K Δa‖ (2-norm over the coordinates z, which is what the
step's unknowns move) and the ratio of consecutive ones, the contraction an iteration, until the
corrections reach round-off. The module docstring of ``multibody.floating`` quotes these figures.
"""

import argparse
import functools
import os
import sys

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

from nrrncf_jax.integrate import AdaptiveStepSize, GeneralizedAlphaIndex3, Newton  # noqa: E402
from nrrncf_jax.integrate.base import GeneralizedAlphaState  # noqa: E402
from nrrncf_jax.integrate.simulate import simulate  # noqa: E402
from nrrncf_jax.scenarios.pendulum import (  # noqa: E402
    LEFT_END_FRAME,
    LEFT_SECTION_FRAME,
    PendulumBasis,
    PendulumSpec,
    build_reduced_pendulum,
    build_rncf_pendulum,
)

sys.path[:0] = [os.path.dirname(__file__), os.path.dirname(os.path.dirname(os.path.abspath(__file__)))]
from _machine import machine, report  # noqa: E402

CORRECTIONS = 8
FLOOR = 1e-11  # corrections below this are round-off (|z| ~ 1, a few hundred coordinates)


def corrections(system, solver, t, x, v, h):
    """The sizes ‖c_K Δa_k‖ of modified Newton's first corrections of the step t → t + h from the
    state (x, v), with and without the p columns of the inertia terms' derivatives."""
    a, lam = system.consistent_accelerations(t, x, v)
    state = GeneralizedAlphaState(x, v, a, a, lam)
    c_C, c_K = solver.derivatives(h)
    stage = solver._stage(system, t + h, h, state)
    n = x.shape[0]

    def equations(z):
        q1, v1, a1, _ = stage(z[:n])
        r = system.residual(t + h, q1, v1, a1) + system.constraint_force(q1, z[n:])
        return jnp.concatenate([r, system.constraints(q1) / c_K]), q1, v1, a1

    @functools.partial(jax.jit, static_argnums=0)
    def run(p_columns):
        z0 = jnp.concatenate([state.a, state.lam])
        _, q1, v1, a1 = equations(z0)
        fac = system.factor_augmented(t + h, q1, v1, state.lam, c_C, c_K, a=a1 if p_columns else None)

        def body(z, _):
            d = fac.solve(equations(z)[0])
            return z - d, jnp.linalg.norm(c_K * d[:n])

        return jax.lax.scan(body, z0, None, length=CORRECTIONS)[1]

    return {p: np.asarray(run(p)) for p in (True, False)}


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--elements", type=int, default=10)
    ap.add_argument("--times", type=float, nargs="+", default=[1.0, 1.5])
    ap.add_argument("--h", type=float, default=2e-4)
    ap.add_argument("--out", default="benchmarks/results/newton_contraction.md")
    a = ap.parse_args(argv)
    spec = PendulumSpec(elements=a.elements)
    solver = GeneralizedAlphaIndex3(0.9)
    models = [("full RNCF, left ends' tangents (LEFT_END_FRAME)", build_rncf_pendulum(spec, LEFT_END_FRAME)),
              ("full RNCF, left ends' section vectors (LEFT_SECTION_FRAME)",
               build_rncf_pendulum(spec, LEFT_SECTION_FRAME)),
              ("NR-RNCF, 5 VMs + 15 MDs a beam", build_reduced_pendulum(spec, PendulumBasis(5))[0])]
    times = sorted(a.times)
    lines = ["# Modified Newton's contraction in the pendulum's index-3 step", "",
             f"Produced by `benchmarks/investigations/newton_contraction.py --elements {a.elements} --times "
             f"{' '.join(f'{t:g}' for t in times)} --h {a.h:g}`. Machine: {machine()}.", "",
             f"{a.elements} elements a beam; states from each model's run (rtol 1e-4, ρ∞ = 0.9); one step of "
             f"h = {a.h:g} s from each, modified Newton on the matrix factored at the predictor. Corrections "
             f"‖c_K Δa‖ (2-norm over z) and their ratios until they fall below {FLOOR:g} (round-off).", "",
             "| model | DOFs | t [s] | p columns | corrections | contraction an iteration |",
             "|---|---:|---:|---|---|---|"]
    for name, system in models:
        sol = simulate(system, solver, AdaptiveStepSize(1e-4, 1e-5), jnp.asarray([0.0] + times),
                       observe=lambda t, x, v: (x, v), newton=Newton(1e-2))
        for k, t in enumerate(times):
            x, v = sol.ys[0][k + 1], sol.ys[1][k + 1]
            for p_columns, norms in corrections(system, solver, t, x, v, a.h).items():
                live = norms[:max(1, int(np.argmax(norms < FLOOR)) if (norms < FLOOR).any() else len(norms))]
                ratios = live[1:] / live[:-1]
                lines.append(f"| {name} | {system.n_dof} | {t:g} | {'with' if p_columns else 'without'} | "
                             f"{', '.join(f'{y:.1e}' for y in live)} | {', '.join(f'{r:.1e}' for r in ratios)} |")
            print(lines[-2], lines[-1], sep="\n", flush=True)
    report("\n".join(lines) + "\n", a.out)


if __name__ == "__main__":
    main()
