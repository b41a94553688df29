#!/usr/bin/env bash
# The GPU figures in one command (docs/gpu.md, "Measure it on a GPU").
#
#   benchmarks/gpu_run.sh OUTDIR              on a GPU machine: writes OUTDIR/gpu_run.json
#   benchmarks/gpu_run.sh OUTDIR --rehearse   anywhere: numba-cuda's simulator, tiny sizes
#   benchmarks/gpu_run.sh --fetch-wheels      on a machine with a package index: fills
#                                             benchmarks/gpu_wheels/ (gitignored)
#
# Needs from the machine: python3 with numpy, scipy, numba, numba-cuda, torch and pytest
# (the GPU image has them), plus the package's small pure-Python dependencies where the
# image lacks them.  Sets up nothing else: the working tree is used in place
# (PYTHONPATH=src; no install).  Pure-Python wheels in benchmarks/gpu_wheels/ (JAX-MD
# and what it imports beyond JAX, and the package's small dependencies; ~5 MB) are
# installed with --no-deps into a scratch folder that goes at the END of sys.path, so
# the image's own packages win and ours only fill gaps.  Extra arguments go to
# benchmarks/bench_gpu.py (e.g. --budget 300, --sizes 1e5 1e6).
set -euo pipefail

here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
wheels="$here/gpu_wheels"
PY=${PYTHON:-python3}

if [ "${1:-}" = "--fetch-wheels" ]; then
    mkdir -p "$wheels"
    # JAX-MD 0.2.29 and the modules `import jax_md` loads beyond JAX and NumPy
    "$PY" -m pip download --no-deps --only-binary=:all: -d "$wheels" \
        jax-md==0.2.29 flax==0.12.8 treescope==0.1.10 optax==0.2.8 jraph==0.0.6.dev0 \
        e3nn-jax==0.21.0 ml-collections==1.1.0 einops==0.8.2 frozendict==2.5.1 \
        etils==1.15.0 attrs==26.1.0 rich==15.0.0 Pygments==2.21.0 markdown-it-py==4.3.0 \
        mdurl==0.1.2 \
        tomli_w==1.2.0 platformdirs==4.14.7 xarray==2026.9.0 zarr==3.1.6 donfig==0.8.1.post1 \
        h5netcdf==1.8.2 click==8.5.1 tqdm==4.70.1
    du -sh "$wheels"
    exit 0
fi

out=${1:?usage: benchmarks/gpu_run.sh OUTDIR [--rehearse] [bench_gpu.py options] | --fetch-wheels}
shift
mkdir -p "$out"
out=$(cd "$out" && pwd)
cd "$root"

export PYTHONPATH="$root/src${PYTHONPATH:+:$PYTHONPATH}"
export XLA_PYTHON_CLIENT_PREALLOCATE=false # JAX allocates as it goes, not 75 % at start
export THERMOSWARM_COMMIT="$(git rev-parse HEAD 2>/dev/null || echo unknown)"
extra=()
if compgen -G "$wheels/*.whl" >/dev/null; then
    site="${TMPDIR:-/tmp}/thermoswarm-gpu-site"
    rm -rf "$site"
    "$PY" -m pip install --quiet --no-deps --no-index --target "$site" "$wheels"/*.whl
    extra+=(--extra-site "$site")
fi
IFS=':' read -r -a more <<<"${THERMOSWARM_EXTRA_SITE:-}"
for s in "${more[@]}"; do [ -n "$s" ] && extra+=(--extra-site "$s"); done

"$PY" benchmarks/bench_gpu.py --out "$out/gpu_run.json" "${extra[@]}" "$@" 2>&1 |
    tee "$out/gpu_run.log"
echo "wrote $out/gpu_run.json"
