# Sourced by the device-session scripts (gpu_session.sh, cores_session.sh): the repository
# root as working directory, logs in $out ($OUT, the device tool's folder, or the script's
# own folder name), the checkout's sources on PYTHONPATH, and with WHEELS set the wheels the
# machine lacks installed into /tmp/site (meshio, dask: docs/gpu.md).
cd "$(dirname "${BASH_SOURCE[0]}")/.."
out=${OUT:-$1}
mkdir -p "$out"
export PYTHONUNBUFFERED=1 PYTHONPATH="$PWD/src:/tmp/site${PYTHONPATH:+:$PYTHONPATH}"
if [ -n "${WHEELS:-}" ]; then
    python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade \
        --target /tmp/site "$WHEELS"/*.whl > "$out/pip.log" 2>&1 || { cat "$out/pip.log"; exit 1; }
fi
