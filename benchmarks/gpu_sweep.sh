#!/usr/bin/env bash
# Every GPU row the benchmarks have, as one command for a machine with an NVIDIA GPU and JAX's
# CUDA plugin (and equinox, diffrax, optax, lineax, jaxtyping, scipy, matplotlib) already
# installed: it runs from the checkout, nothing is installed.
#
#   1. the sweep benchmark (benchmarks/sweep.py): its CPU row on one device first (the ratio
#      "sweep / single run" of every row uses its own platform's single run), then its GPU row;
#   2. batches of 16 and 256 NR-RNCF pendulums released at different angles, and the single pendulum,
#      on the GPU (benchmarks/pendulum_batch.py);
#   3. the single pendulum on this machine's CPU, one core, for the per-member cost against it;
#   4. the reduced cubic force's kernels (benchmarks/kernels.py) and the batched small solves
#      (benchmarks/investigations/batched_lu.py) on the GPU: which form suits which backend.
#
# Each step has its own time limit and a failed step does not stop the next; the exit status
# says whether all passed. Reports go to OUT_DIR (default $OUT, else benchmarks/results):
#
#     [PYTHON=python3] bash benchmarks/gpu_sweep.sh [OUT_DIR]
#       -> sweep_gpu.md, pendulum_batch_gpu.md, pendulum_batch_gpu_host_cpu.md, kernels_gpu.md, batched_lu_gpu.md
set -uo pipefail
cd "$(dirname "$0")/.."
out="${1:-${OUT:-benchmarks/results}}"
py="${PYTHON:-python3}"
export PYTHONPATH="$PWD${PYTHONPATH:+:$PYTHONPATH}" PYTHONUNBUFFERED=1
# The sweep builds its basis in one process and runs its GPU row in another: neither may take
# most of the GPU's memory up front, as JAX does by default.
export XLA_PYTHON_CLIENT_PREALLOCATE=false
"$py" - <<'PY' || exit 1
import jax
gpus = [d for d in jax.devices() if d.platform == "gpu"]
if not gpus:
    raise SystemExit(f"no GPU visible to JAX {jax.__version__}: {jax.devices()}")
import diffrax, equinox, lineax, optax
import nrrncf_jax  # noqa: F401  (the checkout imports with this JAX)
print(f"JAX {jax.__version__}, equinox {equinox.__version__}, diffrax {diffrax.__version__}, "
      f"lineax {lineax.__version__}, optax {optax.__version__}: {gpus}")
PY
failed=0
step() {  # step SECONDS COMMAND...: run with a time limit, note a failure and go on
    local limit=$1; shift
    echo "== $* (limit ${limit} s)"
    local t0=$SECONDS
    timeout "$limit" "$@" || { echo "== FAILED ($?): $*"; failed=1; }
    echo "== $((SECONDS - t0)) s"
}
step 150 "$py" benchmarks/sweep.py --devices 1 --no-interleave --out "$out/sweep_gpu.md"
# XLA's GPU autotuner (JAX 0.11.2, H200) found no Triton configuration for some of the pendulum's
# batched float64 products ("No candidates could be compiled") and the compile failed: cuBLAS then.
step 330 env XLA_FLAGS="${XLA_FLAGS:-} --xla_gpu_enable_triton_gemm=false" \
    "$py" benchmarks/pendulum_batch.py --sizes 1 16 256 --out "$out/pendulum_batch_gpu.md"
step 60 env JAX_PLATFORMS=cpu "$py" benchmarks/pendulum_batch.py --sizes 1 --out "$out/pendulum_batch_gpu_host_cpu.md"
step 50 "$py" benchmarks/kernels.py --sizes 9 20 27 --evals 2000 --batch 256 --out "$out/kernels_gpu.md"
step 50 "$py" benchmarks/investigations/batched_lu.py --sizes 20 99 --batches 1 16 256 --out "$out/batched_lu_gpu.md"
exit $failed
