"""The package's layers: data flows one way (elements → bodies → motion → linear algebra → models →
integrator → reduction → multibody systems → post-processing → studies → scenarios → cli), so every
import, at module level or inside a function, goes to the same layer or a lower one; and the
public names all resolve."""

import ast
import pathlib

import nrrncf_jax

LAYERS = (
    ("_types", "_validate", "_progress", "_static"),
    ("elements",),
    ("bodies",),
    ("motion",),
    ("linalg",),
    ("models",),
    ("integrate",),
    ("reduction",),
    ("multibody",),
    ("post",),
    ("studies",),
    ("scenarios",),
    ("examples",),
    ("cli",),
)
"""The package's units (its private modules and subpackages), lowest first."""

RANK = {unit: i for i, units in enumerate(LAYERS) for unit in units}
ROOT = pathlib.Path(nrrncf_jax.__file__).parent


def _imports(path: pathlib.Path, module: str, is_package: bool):
    """Every module of this package that ``path`` imports (relative or absolute, at any depth of
    the code), as ``(line, target)``; imports under ``if TYPE_CHECKING:`` are annotations only."""
    package = module if is_package else module.rsplit(".", 1)[0]
    tree = ast.parse(path.read_text())
    skip = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            skip |= {id(n) for stmt in node.body for n in ast.walk(stmt)}
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            names = [target + "." + a.name for a in node.names] if node.module is None else [target]
            yield from ((node.lineno, t) for t in names if t.startswith("nrrncf_jax."))
        elif isinstance(node, ast.Import):
            yield from ((node.lineno, a.name) for a in node.names if a.name.startswith("nrrncf_jax."))


def _modules():
    for path in sorted(ROOT.rglob("*.py")):
        parts = path.relative_to(ROOT.parent).with_suffix("").parts
        is_package = parts[-1] == "__init__"
        yield path, ".".join(parts[:-1] if is_package else parts), is_package


def test_every_unit_has_a_layer():
    """A new subpackage or loose module must be given its place in ``LAYERS``."""
    units = {m.split(".")[1] for _, m, _ in _modules() if m != "nrrncf_jax"}
    assert units == set(RANK), f"units without a layer: {sorted(units - set(RANK))}; gone: {sorted(set(RANK) - units)}"


def test_imports_only_go_down():
    """No module imports from a higher layer, at module level or inside a function."""
    upward = []
    for path, module, is_package in _modules():
        if module == "nrrncf_jax":
            continue
        own = RANK[module.split(".")[1]]
        for line, target in _imports(path, module, is_package):
            unit = target.split(".")[1]
            if RANK[unit] > own:
                upward.append(f"{path.relative_to(ROOT.parent)}:{line} imports {target}")
    assert not upward, "imports that go up a layer:\n" + "\n".join(upward)


def test_only_private_modules_are_loose():
    """Every public module lives in the subpackage of its layer."""
    loose = sorted(p.name for p in ROOT.glob("*.py") if not p.name.startswith("_"))
    assert loose == [], loose


def test_public_names_resolve():
    """Every name of ``nrrncf_jax.__all__`` imports from the subpackage the package's table names,
    and the names that share a submodule's name in older versions are the functions."""
    import nrrncf_jax as nr

    for name in nr.__all__:
        assert getattr(nr, name) is not None, name
    assert callable(nr.identify) and nr.identify.__module__ == "nrrncf_jax.studies.identification"
    assert nr.spinup_sweep.__module__ == "nrrncf_jax.studies.sweep"
    assert nr.nr_rncf.__module__ == "nrrncf_jax.reduction.pipeline"
    assert callable(nr.compilation_cache) and callable(nr.nr_rncf)
