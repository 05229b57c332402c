"""The README's examples, as written: every ```python block runs, and every command line parses.

Each Python block runs as a session of its own, in a fresh process without the tests' float64
switch (the README switches it on itself). To run in about a minute each on 2 CPU cores (the two
blocks in parallel under ``pytest -n 2``), the smaller settings of ``SMALL`` replace the README's
mesh, time spans, grid and iteration counts, and nothing else; each replacement must match the
README exactly as often as stated, so that a change to the README shows here. XLA compiles at its
lowest optimisation level (as in ``test_notebooks.py``): compilation, not the run, is the cost.
"""

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from nrrncf_jax.cli import SUBCOMMANDS, build_parser, parse

README = Path(__file__).resolve().parents[1] / "README.md"

SMALL = [  # (python block, README text, replacement, occurrences)
    (0, "n_elements=10", "n_elements=3", 1),
    (0, "jnp.arange(0, 30.01, 0.01)", "jnp.arange(0, 3.01, 0.01)", 2),
    (0, "jnp.linspace(0, 20, 201)", "jnp.linspace(0, 2, 21)", 1),
    (1, "n_elements=10", "n_elements=3", 1),
    (1, "jnp.arange(0, 30.01, 0.01)", "jnp.arange(0, 3.01, 0.01)", 1),
    (1, "np.arange(0, 30.01, 0.05)", "np.arange(0, 3.01, 0.05)", 1),
    (1, '{"E": 60e9, "zeta": 0.03})', '{"E": 60e9, "zeta": 0.03}, adam_steps=1, lbfgs_steps=1)', 1),
    (1, "np.linspace(2, 40, 64)", "np.linspace(2, 6, 2)", 1),
    (1, 'sweep_reduction("paper", grid, t_end=30)',
     'sweep_reduction("paper", grid, t_end=3, elements=3, n_modes=8)', 1),
    (1, "grid, t_end=30, devices=None)", "grid, t_end=3, devices=None)", 1),
    (1, "nr.optimal_spinup(red.model, 10.0, 15.0, 30.0, tip=tip)",
     "nr.optimal_spinup(red.model, 10.0, 1.5, 3.0, tip=tip, steps=1, lbfgs_steps=0)", 1),
]
N_PYTHON_BLOCKS = 2

_RUN = """
import sys
code = sys.stdin.read()
exec(compile(code, "README.md, python block " + sys.argv[1], "exec"), {"__name__": "__readme__"})
print("ran")
"""


def _blocks(lang: str) -> list[str]:
    """The README's fenced code blocks of language ``lang`` ('' for a bare fence), in order."""
    blocks, current, current_lang = [], None, None
    for line in README.read_text(encoding="utf-8").splitlines(keepends=True):
        if line.startswith("```"):
            if current is None:
                current, current_lang = [], line[3:].strip()
            else:
                if current_lang == lang:
                    blocks.append("".join(current))
                current = None
        elif current is not None:
            current.append(line)
    assert current is None, "README.md: a code block is not closed"
    return blocks


def small_python_blocks() -> list[str]:
    blocks = _blocks("python")
    for i, old, new, count in SMALL:
        assert blocks[i].count(old) == count, f"README python block {i}: {old!r} found {blocks[i].count(old)} " \
                                              f"times, expected {count} (update SMALL with the README)"
        blocks[i] = blocks[i].replace(old, new)
    return blocks


def _run_block(index: int) -> None:
    """Python block ``index`` in a fresh process (each block is a session of its own)."""
    blocks = small_python_blocks()
    assert len(blocks) == N_PYTHON_BLOCKS
    env = {k: v for k, v in os.environ.items() if k != "JAX_ENABLE_X64"}
    env["XLA_FLAGS"] = (env.get("XLA_FLAGS", "") + " --xla_backend_optimization_level=0").strip()
    out = subprocess.run([sys.executable, "-c", _RUN, str(index)], input=blocks[index], capture_output=True,
                         text=True, env=env, timeout=600)
    assert out.returncode == 0, out.stdout + out.stderr[-4000:]
    assert out.stdout.split() == ["ran"]


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


def test_synopsis_options_exist():
    """Each option in the README's command-line synopsis is an option of its subcommand."""
    synopsis = next(b for b in _blocks("") if b.startswith("nrrncf spinup"))
    parser = build_parser()
    subs = next(a.choices for a in parser._actions if a.dest == "command")
    seen, command = set(), None
    for line in synopsis.splitlines():
        words = line.split()
        if words[0] == "nrrncf":
            command = words[1]
        known = {o for a in subs[command]._actions for o in a.option_strings}
        for option in re.findall(r"(?<![\w-])--[a-z][a-z0-9-]*", line):
            assert option in known, f"README synopsis: nrrncf {command} has no option {option}"
        seen.add(command)
    assert seen == set(SUBCOMMANDS)


@pytest.mark.slow
def test_python_block_1_runs_as_written():
    _run_block(1)
