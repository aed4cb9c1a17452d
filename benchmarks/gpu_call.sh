#!/usr/bin/env bash
# One call on a lent GPU machine (the device tool): everything the GPU benchmarks measure, in the
# order of what matters if the call is cut short, each part writing its JSON under $OUT as it goes.
#
#   bash benchmarks/gpu_call.sh            (from the repository root, on the device machine)
#
# Prepare here first (benchmarks/README.md, "GPU"): the wheels the machine's image lacks or has in
# another version, in .whl/ (carried: name it in the call's carry), and, to time an old version
# beside this one, its tree in .old060/ (untracked, so it travels with the working tree):
#
#   mkdir .old060 && git archive 14e7800 | tar -x -C .old060
#
# About 8 minutes on an H100 without the old version (2026-11-26: 471 s with it, before gpu.py ran
# the job too): call with timeout_s 580 and leave the rest of the 15 minutes for one short rerun.
#
# The machine's image has numpy 2.5, which numba-cuda 0.30 cannot compile with (pyproject.toml's
# cuda extra says why): numpy 2.4 comes in the wheels, installed ahead of the image's packages.
set -u
OUT=${OUT:-/tmp/gpu_call}
mkdir -p "$OUT"
if ls .whl/*.whl >/dev/null 2>&1; then
    python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/site \
        .whl/*.whl || exit 1
    export PYTHONPATH=/tmp/site
fi
export PYTHONUNBUFFERED=1
nvidia-smi --query-gpu=name,driver_version,clocks.sm,clocks.max.sm,temperature.gpu,power.draw \
    --format=csv | tee "$OUT/card.txt"
python3 -c "import numpy, numba, numba_cuda; print('numpy', numpy.__version__, 'numba', numba.__version__,
'numba-cuda', numba_cuda.__version__)" | tee -a "$OUT/card.txt"
began=$SECONDS
# 1. The old version on the new version's workload: the default shape only, the GPU only (the CPU
#    is timed below, in gpu.py, on the same machine).
if [ -d .old060/vrsweep ]; then
    python3 benchmarks/gpu_variants.py --variants C --no-cpu --source .old060 --out "$OUT/old" \
        2>&1 | tee "$OUT/old.log"
    echo "old version done at $((SECONDS - began)) s"
fi
# 2. This version: both models and methods on the map against the CPU's 16 cores, agreement, the
#    Lyapunov map, the kernels' resources.
#    GPU_PY_ARGS replaces gpu.py's arguments but --out, for a shorter call (e.g. "--job-only
#    --job-fresh-arrays --divergence 2048": the job with fresh and kept device arrays, and what
#    divergence costs; about 6 minutes on an H100).
python3 benchmarks/gpu.py ${GPU_PY_ARGS:---budget ${GPU_BUDGET:-200}} --out "$OUT/new" 2>&1 | tee "$OUT/new.log"
echo "all done at $((SECONDS - began)) s"
