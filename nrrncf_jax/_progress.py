"""Progress lines on stderr for long runs (the ``nrrncf`` command shows them unless ``--no-progress``).

Standard error keeps them apart from a command's results (``--json`` prints its object on
standard output). No JAX here: the command line prints its first line before JAX starts.
"""

import sys


def note(enabled: bool, message: str) -> None:
    """Print ``message`` as one progress line on stderr when ``enabled``."""
    if enabled:
        print(f"  .. {message}", file=sys.stderr, flush=True)
