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
    return (f"{cpu}; {os.cpu_count()} cores visible; JAX {jax.__version__} on {dev.platform.upper()} "
            f"({dev.device_kind}); Python {platform.python_version()}")


def report(text: str, path: str) -> None:
    """Print a benchmark's Markdown report and write it to ``path`` (folders made as needed)."""
    print(text)
    os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
    with open(path, "w") as f:
        f.write(text)
