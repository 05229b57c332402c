"""One line describing the machine a benchmark ran on."""

import os
import platform

import jax


def machine() -> str:
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    dev = jax.devices()[0]
    line = (f"{cpu}; {os.cpu_count()} cores visible; JAX {jax.__version__} on {dev.platform.upper()} "
            f"({dev.device_kind}); Python {platform.python_version()}")
    allowed = os.sched_getaffinity(0) if hasattr(os, "sched_getaffinity") else None
    if allowed is not None and len(allowed) < (os.cpu_count() or 0):
        # taskset: one XLA thread and no neighbour on its core; these models time differently so
        line += f"; the process pinned to {'one core' if len(allowed) == 1 else f'{len(allowed)} cores'}"
    return line


def pin_to_one_core() -> None:
    """Pin this process to its lowest allowed core (``machine()`` then says so). The pendulum's
    models are too small to gain from a second core, and XLA's hand-offs of their small operations
    between two made their times vary twofold. Only on a CPU: a GPU run keeps its host cores."""
    if hasattr(os, "sched_setaffinity") and jax.devices()[0].platform == "cpu":
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})


def report(text: str, path: str, keep_notes: str | None = None) -> None:
    """Print a benchmark's Markdown report and write it to ``path`` (folders made as needed).
    ``keep_notes``: a heading (e.g. ``"## Notes"``) of the old report from which its hand-written
    notes, read from the figures, are kept after the new text."""
    if keep_notes is not None and os.path.exists(path):
        with open(path) as f:
            old = f.read()
        at = old.find("\n" + keep_notes)
        text = text + (old[at:] if at >= 0 else "")
    print(text)
    os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
    with open(path, "w") as f:
        f.write(text)


def missing(module: str, install: str) -> bool:
    """True, after one line saying how to install it, where the optional ``module`` (a peer code,
    not a dependency of the library) cannot be imported."""
    import importlib.util

    if importlib.util.find_spec(module) is None:
        print(f"{module} is not installed: {install}")
        return True
    return False
