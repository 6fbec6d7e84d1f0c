#!/usr/bin/env bash
# One prepared call on a lent GPU machine with 16 cores (issues 19 and 16), about 6 minutes:
# the GPU's answers against NumPy (it stops the call where one differs), the B1 and B3 rows
# side by side, the whole 21 125-case B3 study with the study's default start (from zero
# on one process, geometry waves on several) in this process (sampled by py-spy: where the host's time goes, the waits for the
# GPU included) and on 8 processes sharing the GPU (`--workers 8`, the client sampled); with CORES=1 then the 16 cores (~4 minutes more):
# N copies of a serial study at once (no Dask) and the 845-case B3 study on 16 Dask workers
# against the serial one. Logs go to $OUT (the device tool's folder) or ./device-session.
#
#   WHEELS=.whl bash benchmarks/device_session.sh   # + wheels for what the machine lacks
#                                                   #   (meshio, dask, py-spy: docs/gpu.md)
#   WHEELS=.whl FULL_WORKERS=0,4,8 bash ...         # the whole study on 1, 4 and 8 processes
#   WHEELS=.whl CORES=1 bash ...                    # + the 16 cores
#   WHEELS=.whl REFERENCE=.ref/b3-full-cpu.nc bash ...  # + the whole study's R_stop against
#                                                   #   the CPU path's study.nc (carried)
#   WHEELS=.whl FULL_START=zero,neighbour bash ...  # from zero, then in geometry waves
#   WHEELS=.whl MPS=1 bash ...                      # + the studies again under CUDA's MPS
#   WHEELS=.whl ROWS=0 bash ...                     # without the B1 and B3 rows
#   WHEELS=.whl ROWS=3 bash ...                     # the rows three times (B1's spread)
#   WHEELS=.whl COMPACT="0.5 0.25 0.5 0.25" bash ...  # + torch's rows alone, batches
#                                                   #   compacting at half, a quarter, ...
set -uo pipefail
source "$(dirname "$0")/device_env.sh" device-session
export PATH="/tmp/site/bin:$PATH"
nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader | tee "$out/device.log"
lscpu | grep -E "^(Model name|CPU\(s\)|Thread|Core|Socket|L3)" | tee -a "$out/device.log"
python3 -c "import torch, numpy, numba; print('torch', torch.__version__, 'numpy', \
numpy.__version__, 'numba', numba.__version__)" | tee -a "$out/device.log"
timeout 90 python3 benchmarks/gpu_check.py --device cuda 2>&1 | tee "$out/check.log" || exit 2
for _ in $(seq "${ROWS:-1}"); do  # ROWS=0: straight to the whole study; ROWS=3: 3 times
    timeout 80 python3 benchmarks/gpu.py --device cuda --no-tight --only "B1,B3 5" 2>&1 \
        | tee -a "$out/rows.log"
done
for compact in ${COMPACT:-}; do  # torch's rows alone, batches compacting at each fraction
    timeout 40 python3 benchmarks/gpu.py --device cuda --no-tight --only "B1,B3 5" \
        --torch-only --compact-below "$compact" 2>&1 | tee -a "$out/compact.log"
done
spy=()
if py-spy record -d 1 -o /tmp/spy-test.txt -f raw -- python3 -c "import time; time.sleep(2)" \
    > /dev/null 2>&1; then
    spy=(py-spy record -r 20 --nonblocking -f raw -o "$out/full-spy.txt" --)
fi
workers=${FULL_WORKERS:-0,8}  # the study in this process, then on 8 processes
starts=${FULL_START:-default}  # the study's default start; or zero,neighbour
runs=$(( ($(tr -cd , <<< "$workers" | wc -c) + 1) * ($(tr -cd , <<< "$starts" | wc -c) + 1) ))
timeout $((50 + 100 * runs)) "${spy[@]}" python3 \
    benchmarks/gpu.py --device cuda --no-tight --only none --full \
    --full-start "$starts" \
    --full-workers "$workers" ${REFERENCE:+--full-reference "$REFERENCE"} 2>&1 | grep -v Warning | tee "$out/full.log"
if [ "${MPS:-0}" = 1 ]; then  # the same studies again under CUDA's Multi-Process Service,
    # which lets the processes' kernels share the GPU at once instead of in time slices
    export CUDA_MPS_PIPE_DIRECTORY=/tmp/mps-pipe CUDA_MPS_LOG_DIRECTORY=/tmp/mps-log
    mkdir -p "$CUDA_MPS_PIPE_DIRECTORY" "$CUDA_MPS_LOG_DIRECTORY"
    if nvidia-cuda-mps-control -d; then
        timeout $((50 + 100 * runs)) python3 benchmarks/gpu.py --device cuda --no-tight \
            --only none --full --full-start "$starts" --full-workers "$workers" 2>&1 \
            | grep -v Warning | tee "$out/full-mps.log"
        echo quit | nvidia-cuda-mps-control
    else
        echo "MPS: nvidia-cuda-mps-control did not start" | tee "$out/full-mps.log"
    fi
fi
if [ "${CORES:-0}" = 0 ]; then echo "device session done (GPU part)"; exit 0; fi
timeout 120 python3 benchmarks/core_contention.py --copies 1 16 2>&1 | tee "$out/contention.log"
timeout 150 python3 benchmarks/dask_waves.py --study b3 --no-predict --dask 16 2>&1 \
    | grep -v Warning | tee "$out/dask.log"
echo "device session done"
