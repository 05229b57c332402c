"""``nrrncf static``: a mechanism's static equilibrium, from a model file or a bundled example
(``scenarios.mechanism_file``; ``integrate.constrained_equilibrium``).

    nrrncf static MODEL [--param KEY=VALUE ...] [--t T] [--load-steps N] [--json] [--no-progress]

``MODEL`` as for ``nrrncf run``: a Python file defining ``mechanism(**params) -> MechanismSetup``
or a bundled example's name (``princeton_beam``). The equilibrium is solved at time ``--t``
(default: the model's end time) along ``--load-steps`` increments s = k/N of gravity s·g and
time s·t, so that drivers and force laws that grow with t are applied gradually. Prints each
sensor at the equilibrium (a vector sensor as ``name_0, name_1, ...``) and ``dofs``,
``newton_iters`` (each increment's corrections) and ``solve_s``; ``--json`` as one JSON object on
the last line.
"""

from . import _common
from .run import _parse_params


def _static(args) -> int:
    import time

    import jax
    import numpy as np

    from ..integrate import constrained_equilibrium
    from ..multibody.sensors import observe
    from ..scenarios.mechanism_file import load_setup

    params = _parse_params(args.param)
    setup = load_setup(args.model, params)
    t = setup.t_end if args.t is None else float(args.t)
    _common.say(args, f"{args.model}: static equilibrium at t = {t:g}, {setup.system.n_dof} coordinates, "
                      f"{args.load_steps} load increments ...")
    t0 = time.perf_counter()
    eq = jax.block_until_ready(constrained_equilibrium(setup.system, t=t, load_steps=args.load_steps))
    seconds = time.perf_counter() - t0
    values = observe(setup.system, setup.sensors)(t, eq.z, 0.0 * eq.z)
    out = {"model": args.model, "params": params, "t": t, "dofs": setup.system.n_dof,
           "newton_iters": np.asarray(eq.iterations).tolist(), "solve_s": seconds}
    for name in setup.sensors:
        value = np.asarray(values[name]).reshape(-1)
        out |= {name: float(value[0])} if value.size == 1 else {f"{name}_{i}": float(x) for i, x in enumerate(value)}
    return _common.emit(args, out)


def _check(args) -> None:
    _parse_params(args.param)
    _common.at_least("--load-steps", args.load_steps, 1)


def register(sub) -> None:
    t = _common.model_parser(sub, "static", "a mechanism's static equilibrium (model file or bundled example)",
                             "Solve the static equilibrium of a mechanism defined in a Python file "
                             "(mechanism(**params) returning a scenarios.MechanismSetup) or a bundled example by "
                             "name (princeton_beam), and print its sensors there.")
    t.add_argument("--t", type=float, default=None, help="the time (load factor) solved at (default: the model's "
                                                          "end time)")
    t.add_argument("--load-steps", type=int, default=10, help="load increments from the reference")
    t.add_argument("--json", action="store_true", help="print one JSON object as the last line")
    t.add_argument("--no-progress", action="store_true", help="no progress messages on stderr")
    t.set_defaults(func=_static, check=_check)
