"""The README's examples, as written: every ```python block runs, every command line parses, and
the results table is what ``benchmarks/readme_table.py`` makes of the committed results.

Each Python block runs as a session of its own, in a fresh process without the tests' float64
switch (the README switches it on itself). The blocks run as written, in seconds each (their sizes
are chosen for that); should one grow, the smaller settings of ``SMALL`` replace its mesh, time
spans and iteration counts, and nothing else, each replacement matching the README exactly as often
as stated, so that a change to the README shows here. XLA compiles at its lowest optimisation level
(as in ``test_notebooks.py``): compilation, not the run, is the cost.
"""

import importlib.util
import os
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from nrrncf_jax.cli import SUBCOMMANDS, parse

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
GETTING_STARTED = ROOT / "docs" / "getting-started.md"

SMALL: list[tuple[int, str, str, int]] = []  # (python block, README text, replacement, occurrences)
N_PYTHON_BLOCKS = 1
SYSTEM_BLOCK = 1
"""The getting-started page's python block that builds the pendulum from bodies and joints (the
README's second block before it moved there). The page's first block, the slider-crank, is not run
here."""

_RUN = """
import sys
code = sys.stdin.read()
exec(compile(code, "python block " + sys.argv[1], "exec"), {"__name__": "__readme__"})
print("ran")
"""


def _blocks(lang: str, path: Path = README) -> list[str]:
    """The fenced code blocks of language ``lang`` ('' for a bare fence) of ``path`` (the README),
    in order."""
    blocks, current, current_lang = [], None, None
    for line in path.read_text(encoding="utf-8").splitlines(keepends=True):
        if line.startswith("```"):
            if current is None:
                current, current_lang = [], line[3:].strip()
            else:
                if current_lang == lang:
                    blocks.append("".join(current))
                current = None
        elif current is not None:
            current.append(line)
    assert current is None, f"{path.name}: a code block is not closed"
    return blocks


def small_python_blocks() -> list[str]:
    blocks = _blocks("python")
    for i, old, new, count in SMALL:
        assert blocks[i].count(old) == count, f"README python block {i}: {old!r} found {blocks[i].count(old)} " \
                                              f"times, expected {count} (update SMALL with the README)"
        blocks[i] = blocks[i].replace(old, new)
    return blocks


def _run_block(index: int, path: Path = README) -> None:
    """Python block ``index`` (of the README, or of ``path``) in a fresh process (each block is a
    session of its own)."""
    if path == README:
        blocks = small_python_blocks()
        assert len(blocks) == N_PYTHON_BLOCKS
    else:
        blocks = _blocks("python", path)
    env = {k: v for k, v in os.environ.items() if k != "JAX_ENABLE_X64"}
    env["XLA_FLAGS"] = (env.get("XLA_FLAGS", "") + " --xla_backend_optimization_level=0").strip()
    out = subprocess.run([sys.executable, "-c", _RUN, f"{index} of {path.name}"], input=blocks[index],
                         capture_output=True, text=True, env=env, timeout=600)
    assert out.returncode == 0, out.stdout + out.stderr[-4000:]
    assert out.stdout.splitlines()[-1:] == ["ran"], out.stdout  # what the block printed, then "ran"


# The two blocks are the first and the last test of this file: pytest-xdist hands out consecutive
# tests, so under ``-n 2`` they run on different workers, in parallel.
@pytest.mark.slow
def test_python_block_0_runs_as_written():
    _run_block(0)


def _commands() -> list[list[str]]:
    """The ``nrrncf ...`` commands of the README's ```bash blocks (``a && nrrncf ...`` included)."""
    found = []
    for block in _blocks("bash"):
        for line in block.splitlines():
            for part in line.split("&&"):
                words = shlex.split(part)
                if words and words[0] == "nrrncf":
                    found.append(words[1:])
    return found


def test_bash_commands_parse(tmp_path, monkeypatch):
    """Every ``nrrncf`` command in a ```bash block parses and passes the argument checks (nothing runs)."""
    monkeypatch.chdir(tmp_path)  # the output files they name go to an existing, writable directory
    commands = _commands()
    assert len(commands) >= 2
    for argv in commands:
        args = parse(argv)
        assert args.command in SUBCOMMANDS


def test_every_subcommand_has_an_example():
    """The README shows each subcommand of ``nrrncf`` at least once (its options: ``--help``)."""
    assert {args[0] for args in _commands()} == set(SUBCOMMANDS)


def test_ci_runs_the_readme_test_command():
    """``.ci/run`` runs the README's test command verbatim."""
    command = 'pip install -e ".[test]" && python -m pytest -q -n 2'
    assert any(block.strip() == command for block in _blocks("bash")), "README: the test command changed"
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8").splitlines()
    assert command in ci, ".ci/run no longer runs the README's test command verbatim"


def _readme_table():
    """``benchmarks/readme_table.py`` as a module (benchmarks/ is not a package)."""
    spec = importlib.util.spec_from_file_location("readme_table", ROOT / "benchmarks" / "readme_table.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules["readme_table"] = module  # dataclasses look their module up while it executes
    spec.loader.exec_module(module)
    return module


def test_results_table_is_generated():
    """The README's results table is exactly what ``benchmarks/readme_table.py`` makes of the
    committed ``benchmarks/results/``: it cannot drift from them (rerun the script with
    ``--write`` after a benchmark)."""
    rt = _readme_table()
    assert rt.readme_block(README.read_text(encoding="utf-8")) == rt.table(), \
        "README.md's results table differs from the results: run python benchmarks/readme_table.py --write"


def test_results_table_fails_loudly(tmp_path):
    """A results file without a row the table needs stops the script with the file's name."""
    rt = _readme_table()
    for name in ("table3.md", "table3_converged.md", "membrane.md", "truss.md", "pendulum.md"):
        (tmp_path / name).write_text((rt.RESULTS / name).read_text(encoding="utf-8"), encoding="utf-8")
    pendulum = tmp_path / "pendulum.md"
    pendulum.write_text("\n".join(line for line in pendulum.read_text(encoding="utf-8").splitlines()
                                   if not line.startswith("| 5 VMs + 15 MDs |")), encoding="utf-8")
    with pytest.raises(rt.ResultsError, match="pendulum.md"):
        rt.table(tmp_path)
    (tmp_path / "pendulum.md").write_text((rt.RESULTS / "pendulum.md").read_text(encoding="utf-8"), encoding="utf-8")
    assert rt.table(tmp_path) == rt.table()
    (tmp_path / "truss.md").unlink()
    with pytest.raises(rt.ResultsError, match="truss.md"):
        rt.table(tmp_path)


@pytest.mark.slow
def test_getting_started_system_block_runs_as_written():
    assert "MultibodySystem(bodies, joints" in _blocks("python", GETTING_STARTED)[SYSTEM_BLOCK]
    _run_block(SYSTEM_BLOCK, GETTING_STARTED)
