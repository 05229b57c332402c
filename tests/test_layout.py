"""The package's layers: the core (elements, body, models, solvers, reduction, integrator, ...) imports
neither the scenarios, nor the studies, nor the command line; the public names all resolve."""

import json
import pkgutil
import subprocess
import sys

import nrrncf_jax

APPLICATIONS = ("nrrncf_jax.scenarios", "nrrncf_jax.studies", "nrrncf_jax.cli")


def _core_modules() -> list[str]:
    """Every module of the package outside the application subpackages (found, not listed, so that
    a new core module is checked too)."""
    found = pkgutil.walk_packages(nrrncf_jax.__path__, prefix="nrrncf_jax.", onerror=lambda name: None)
    names = ["nrrncf_jax"] + sorted(m.name for m in found)
    return [n for n in names if not any(n == a or n.startswith(a + ".") for a in APPLICATIONS)]


_PROBE = """
import importlib, json, sys
forbidden = {forbidden!r}
pulled = {{}}
for name in {modules!r}:
    importlib.import_module(name)
    for m in sorted(sys.modules):
        if any(m == f or m.startswith(f + ".") for f in forbidden):
            pulled.setdefault(m, name)
print(json.dumps(pulled))
"""


def test_core_does_not_import_scenarios_studies_or_cli():
    """Each core module is imported in turn in one fresh interpreter; none brings in an application
    subpackage (were one to, the first core module whose import did is named)."""
    modules = _core_modules()
    assert {"nrrncf_jax.body", "nrrncf_jax.integrate", "nrrncf_jax.models", "nrrncf_jax.reduction",
            "nrrncf_jax.nr_rncf", "nrrncf_jax.plotting", "nrrncf_jax.profiles"} <= set(modules)
    code = _PROBE.format(forbidden=APPLICATIONS, modules=modules)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-3000:]
    pulled = json.loads(out.stdout.strip().splitlines()[-1])
    assert pulled == {}, f"core modules import applications (application module: first core importer): {pulled}"


def test_public_names_resolve():
    """Every name of ``nrrncf_jax.__all__`` imports from the module the package's table names
    (``nr.identify``, ``nr.spinup_sweep``, ``nr.optimal_spinup``, ``nr.SpinupFamily``, ... live in
    ``studies``), and the function wins over a submodule of the same name."""
    import nrrncf_jax as nr

    for name in nr.__all__:
        assert getattr(nr, name) is not None, name
    assert callable(nr.identify) and nr.identify.__module__ == "nrrncf_jax.studies.identification"
    assert nr.spinup_sweep.__module__ == "nrrncf_jax.studies.sweep"
    assert nr.optimal_spinup.__module__ == "nrrncf_jax.studies.control"
    assert nr.SpinupFamily.__module__ == "nrrncf_jax.studies.families"
    import nrrncf_jax.nr_rncf  # noqa: F401  (the submodule sharing the function's name)

    assert callable(nr.nr_rncf)
