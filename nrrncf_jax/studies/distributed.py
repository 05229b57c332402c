"""Sweeps on several processes and hosts: JAX's multi-process runtime, a local launcher, and
shards for independent processes.

**The runtime.** ``initialize`` joins ``jax.distributed``: every process sees every process's
devices as one global device list, and ``studies.sweep.spinup_sweep`` runs unchanged on them
(its cases split over all devices by ``shard_map``, each device running its own batched loop
with no cross-device operation, the per-case results gathered to every process at the end).
On CPUs the gather runs over gloo, JAX's CPU collectives. Its arguments come from the
launcher's environment (``NRRNCF_COORDINATOR``, ``NRRNCF_NUM_PROCESSES``,
``NRRNCF_PROCESS_ID``) or, without them, from JAX's own detection of a cluster (Slurm, Open MPI:
``srun nrrncf sweep ... --distributed``).

**The launcher.** ``launch_local`` starts N worker processes of one command on this machine
with a coordinator on a free loopback port: ``nrrncf sweep ... --processes N``. Process 0 keeps
the terminal (its progress and output are the command's); the others' output goes to files. A
worker that fails ends the launch: the others are stopped, and the error names the process and
shows the end of its error output, instead of leaving the rest waiting in a collective. A launch
that outlasts its timeout is stopped the same way.

**Shards.** Without collectives (a cluster array job), ``shard_indices(cost, k, n)`` gives shard
k its share of the cases, dealt round-robin from the costliest down so that every shard gets
the same mix; each shard runs as a sweep of its own and writes its part, and ``merge_parts``
joins the parts, checking that every case is there exactly once.

Each case is its own run, so one process, N processes and N shards give the same per-case
results up to the round-off of different batch shapes (``spinup_sweep``'s docstring).
"""

import csv
import os
import socket
import subprocess
import sys
import tempfile
import time

import numpy as np

ENV_COORDINATOR, ENV_PROCESSES, ENV_PROCESS_ID = "NRRNCF_COORDINATOR", "NRRNCF_NUM_PROCESSES", "NRRNCF_PROCESS_ID"


def launched() -> bool:
    """Whether this process is a worker of ``launch_local`` (its environment names a coordinator)."""
    return ENV_COORDINATOR in os.environ


def initialize(coordinator: str | None = None, num_processes: int | None = None, process_id: int | None = None,
               timeout_s: int = 120) -> None:
    """Join JAX's multi-process runtime (module docstring) before anything else uses JAX: with
    the arguments given, else those of ``launch_local``'s environment, else JAX's detection of
    the cluster. The CPU collectives are gloo's. Waits at most ``timeout_s`` for the other
    processes. Does nothing when the runtime is already up."""
    import jax

    if jax.distributed.is_initialized():
        return
    if coordinator is None and launched():
        coordinator = os.environ[ENV_COORDINATOR]
        num_processes = int(os.environ[ENV_PROCESSES])
        process_id = int(os.environ[ENV_PROCESS_ID])
    jax.config.update("jax_cpu_collectives_implementation", "gloo")
    jax.distributed.initialize(coordinator_address=coordinator, num_processes=num_processes, process_id=process_id,
                               initialization_timeout=int(timeout_s))


def free_port() -> int:
    """A TCP port free on the loopback interface now (the coordinator's)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class LaunchError(RuntimeError):
    """A worker of ``launch_local`` failed, or the launch timed out."""


def launch_local(args: list[str], processes: int, timeout_s: float = 3600.0, env: dict | None = None,
                 code: str = "import sys; from nrrncf_jax.cli import main; sys.exit(main(sys.argv[1:]))") -> None:
    """Run ``python -c code *args`` as ``processes`` workers of one multi-process runtime on this
    machine (module docstring). Returns when all have exited with status 0; raises
    ``LaunchError`` naming the first that failed (with the end of its stderr), or on timeout,
    after stopping the others. ``env``: extra environment variables for the workers."""
    if isinstance(processes, bool) or not isinstance(processes, (int, np.integer)) or processes < 1:
        raise ValueError(f"processes must be a positive integer, got {processes!r}")
    base = dict(os.environ, **(env or {}))
    base.update({ENV_COORDINATOR: f"127.0.0.1:{free_port()}", ENV_PROCESSES: str(processes)})
    logs, workers = [], []
    with tempfile.TemporaryDirectory(prefix="nrrncf_workers_") as folder:
        try:
            for i in range(processes):
                log = None if i == 0 else open(os.path.join(folder, f"worker_{i}.txt"), "w+")
                logs.append(log)
                workers.append(subprocess.Popen([sys.executable, "-c", code, *args],
                                                env=base | {ENV_PROCESS_ID: str(i)}, stdout=log, stderr=log))
            _wait(workers, logs, timeout_s)
        finally:
            for w in workers:
                if w.poll() is None:
                    w.kill()
                    w.wait()
            for log in logs:
                if log is not None:
                    log.close()


def _wait(workers, logs, timeout_s: float) -> None:
    start = time.monotonic()
    while True:
        codes = [w.poll() for w in workers]
        failed = [i for i, c in enumerate(codes) if c not in (None, 0)]
        if failed:
            # name every process that has failed by now; show the output of the first one with a log
            # (process 0's output is the terminal's)
            names = ", ".join(f"{i} (exit status {codes[i]})" for i in failed)
            i = next((j for j in failed if logs[j] is not None), None)
            tail = ""
            if i is not None:
                logs[i].flush()
                logs[i].seek(0)
                tail = "".join(logs[i].read().splitlines(keepends=True)[-20:])
            raise LaunchError(f"worker process {names} of {len(workers)} failed; the others were stopped"
                              + (f". The last output of process {i}:\n{tail}" if tail else ""))
        if all(c == 0 for c in codes):
            return
        if time.monotonic() - start > timeout_s:
            raise LaunchError(f"the {len(workers)} worker processes did not finish within {timeout_s:g} s; stopped")
        time.sleep(0.05)


def shard_indices(cost, k: int, n: int) -> np.ndarray:
    """The cases of shard ``k`` of ``n`` (indices, ascending): the cases sorted costliest first by
    ``cost`` and dealt round-robin, so that every shard gets the same mix of cheap and costly."""
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1 or not 0 <= k < n:
        raise ValueError(f"a shard is K/N with 0 <= K < N, got {k}/{n}")
    order = np.argsort(-np.asarray(cost, dtype=float), kind="stable")
    return np.sort(order[k::n])


def merge_parts(paths, out: str) -> int:
    """Join the CSV parts of a sharded sweep (each with the columns ``case`` and ``cases``, the
    case's index in the whole grid and the grid's size) into one CSV at ``out``, in case order.
    Raises ``ValueError`` if the parts disagree on their columns or on the grid's size, or if a
    case is missing or repeated. Returns the number of cases."""
    header, rows, total = None, {}, None
    for path in paths:
        with open(path, newline="") as f:
            reader = csv.reader(f)
            h = next(reader, None)
            if h is None or h[:2] != ["case", "cases"]:
                raise ValueError(f"{path}: not a part of a sharded sweep (its first columns must be case, cases)")
            if header is not None and h != header:
                raise ValueError(f"{path}: its columns differ from the first part's")
            header = h
            for row in reader:
                i, n = int(row[0]), int(row[1])
                if total is not None and n != total:
                    raise ValueError(f"{path}: case {i} belongs to a sweep of {n} cases, the others to {total}")
                total = n
                if i in rows:
                    raise ValueError(f"case {i} appears in more than one part ({path})")
                rows[i] = row
    if header is None or total is None:
        raise ValueError("no parts, or parts without cases")
    missing = sorted(set(range(total)) - set(rows))
    if missing:
        more = " (and more)" if len(missing) > 10 else ""
        raise ValueError(f"cases {missing[:10]} of {total} are in no part{more}")
    with open(out, "w", newline="") as f:
        wr = csv.writer(f)
        wr.writerow(header)
        wr.writerows(rows[i] for i in range(total))
    return total


__all__ = ["LaunchError", "free_port", "initialize", "launch_local", "launched", "merge_parts", "shard_indices"]
