#!/usr/bin/env bash
# One prepared call on a lent 16-core machine (issue 16; docs/performance.md, "Measured on
# 16 cores"), about 5 minutes: whether the cores slow each other down (N copies of a serial
# study at once, no Dask), then the 845-case B3 study on 4 and 16 Dask workers against
# the serial study. Logs go to $OUT (the device tool's folder) or ./cores-session.
#
#   WHEELS=.whl bash benchmarks/cores_session.sh   # + wheels for what the machine lacks
set -uo pipefail
source "$(dirname "$0")/device_env.sh" cores-session
lscpu | grep -E "^(Model name|CPU\(s\)|Thread|Core|Socket|L3)" | tee "$out/cpu.log"
timeout 150 python3 benchmarks/core_contention.py --copies 1 4 16 2>&1 | tee "$out/contention.log"
timeout 300 python3 benchmarks/dask_waves.py --study b3 --no-predict --dask 4 16 2>&1 \
    | grep -v Warning | tee "$out/dask.log"
echo "cores session done"
