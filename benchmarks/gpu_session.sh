#!/usr/bin/env bash
# One prepared call on a lent GPU machine (issue 19; docs/gpu.md), about 8 minutes:
# the answers against NumPy with the graphs and kernels on, where an iteration's time goes,
# the benchmark's rows, then the whole 21 125-case B3 study from zero. Logs go to $OUT
# (the device tool's folder) or ./gpu-session.
#
#   bash benchmarks/gpu_session.sh                 # PyTorch, NumPy, SciPy, Numba there
#   WHEELS=.whl bash benchmarks/gpu_session.sh     # + wheels for what the machine lacks
#                                                  #   (meshio, dask: docs/gpu.md)
set -uo pipefail
source "$(dirname "$0")/device_env.sh" gpu-session
nvidia-smi --query-gpu=name,memory.total --format=csv,noheader | tee "$out/device.log"
timeout 90 python3 benchmarks/gpu_check.py --device cuda 2>&1 | tee "$out/check.log" || exit 2
timeout 60 python3 benchmarks/gpu_profile.py --device cuda --iterations 40 --b3-positions 5 \
    2>&1 | grep -v "^---\|^ *Name\|elementwise\|^void\|Self C" | tee "$out/profile.log"
timeout 100 python3 benchmarks/gpu.py --device cuda --no-tight --only "B1,B3 5" 2>&1 \
    | tee "$out/rows.log"
timeout 240 python3 benchmarks/gpu.py --device cuda --no-tight --only none --full \
    --full-start zero 2>&1 | tee "$out/full.log"
echo "gpu session done"
