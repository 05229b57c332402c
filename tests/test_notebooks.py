"""Every notebook in notebooks/ runs top to bottom (small settings: NRRNCF_NOTEBOOK_SMALL=1).

The notebooks check themselves with assertions in their cells; this test fails if any cell
raises. The kernel is a fresh ``python3`` ipykernel of the interpreter running pytest: its spec is
written to a temporary directory put first on JUPYTER_PATH, so a stale ``python3`` kernelspec
elsewhere on the machine (pointing at another environment) cannot be picked up.
"""

import os
import pathlib
import sys
import time

import nbclient
import nbformat
import pytest
from conftest import FAST_COMPILE_FLAGS
from ipykernel import kernelspec

NOTEBOOKS = sorted((pathlib.Path(__file__).resolve().parent.parent / "notebooks").glob("*.ipynb"))
CELL_TIMEOUT_S = 300


@pytest.fixture
def python3_kernel(tmp_path, monkeypatch):
    """A ``python3`` kernelspec whose argv is this interpreter (``sys.executable``)."""
    kernelspec.write_kernel_spec(tmp_path / "kernels" / "python3")
    monkeypatch.setenv("JUPYTER_PATH", str(tmp_path), prepend=os.pathsep)
    monkeypatch.setenv("NRRNCF_NOTEBOOK_SMALL", "1")
    return "python3"


RUN_BOUND = {"06_truss.ipynb"}
"""Notebooks whose small run is dominated by the run itself, not by XLA compilation. The others
compile with the suite's compile-speed flags (``conftest.FAST_COMPILE_FLAGS``), which cut their
CPU time by about a quarter (same float64 results, slower loops); the truss's full run (1,278 DOFs,
680 steps) takes 70 s instead of 27 s at LLVM's optimisation level 0 alone, more than the 5 s of
compilation it saves."""


def test_notebooks_exist():
    assert NOTEBOOKS, "no notebooks found in notebooks/"


@pytest.mark.slow
@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.name for p in NOTEBOOKS])
def test_notebook_runs(path, python3_kernel, monkeypatch):
    flags = os.environ.get("XLA_FLAGS", "")
    if path.name in RUN_BOUND:  # conftest's compile-speed flags off for this kernel
        for flag in FAST_COMPILE_FLAGS:
            flags = flags.replace(flag, "")
    monkeypatch.setenv("XLA_FLAGS", flags.strip())
    nb = nbformat.read(path, as_version=4)
    for cell in nb.cells:  # the file is kept with outputs stripped
        if cell.cell_type == "code":
            assert not cell.outputs and cell.execution_count is None, f"{path.name}: stored outputs; strip them"
    client = nbclient.NotebookClient(
        nb,
        kernel_name=python3_kernel,
        timeout=CELL_TIMEOUT_S,
        resources={"metadata": {"path": str(path.parent)}},
    )
    t0 = time.perf_counter()
    client.execute()  # raises CellExecutionError naming the cell and its traceback
    print(f"{path.name}: {time.perf_counter() - t0:.1f} s with {sys.executable}")
