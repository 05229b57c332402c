#!/usr/bin/env bash
# The sweep benchmark with its GPU row, and the batch of 256 NR-RNCF pendulums released at different
# angles (issue 17's GPU row, benchmarks/pendulum_batch.py), as one command for a machine with an NVIDIA GPU and JAX's
# CUDA plugin (and equinox, diffrax, optax, jaxtyping, scipy, matplotlib) already installed: it
# runs from the checkout, nothing is installed. The CPU row on one device comes first (the ratio
# "sweep / single run" of every row uses its own platform's single run).
#
#     [PYTHON=python3] bash benchmarks/gpu_sweep.sh [OUT_DIR]   # writes OUT_DIR/sweep_gpu.md, pendulum_batch_gpu.md
set -euo pipefail
cd "$(dirname "$0")/.."
out="${1:-${OUT:-benchmarks/results}}"
py="${PYTHON:-python3}"
export PYTHONPATH="$PWD${PYTHONPATH:+:$PYTHONPATH}" PYTHONUNBUFFERED=1
"$py" - <<'PY'
import jax
gpus = [d for d in jax.devices() if d.platform == "gpu"]
if not gpus:
    raise SystemExit(f"no GPU visible to JAX {jax.__version__}: {jax.devices()}")
print(f"JAX {jax.__version__}: {gpus}")
PY
"$py" benchmarks/sweep.py --devices 1 --no-interleave --out "$out/sweep_gpu.md"
"$py" benchmarks/pendulum_batch.py --sizes 1 256 --out "$out/pendulum_batch_gpu.md"
