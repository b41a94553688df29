#!/usr/bin/env bash
# The lean core, as a user gets it: build the sdist and the wheel (python -m build),
# install the wheel ALONE (no extras; versions from the lock) into a fresh venv, and,
# from outside the checkout, run every verb's --help, the verbs that need an extra
# (each must say which, in one line, exit 2), `simulate box`, `convert` to CSV and
# `analyze` on the CSV; print the import times of thermoswarm and of the CLI.
#   .ci/lean_core.sh            (PYTHON: the interpreter for the venv, default python3;
#                                BUILD_PY: one that has `build`, default .venv/bin/python)
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
PYTHON=${PYTHON:-python3}
BUILD_PY=${BUILD_PY:-.venv/bin/python}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

echo "== build: sdist and wheel"
if ! "$BUILD_PY" -m build --outdir "$work/dist" . >"$work/build.log" 2>&1; then
  tail -20 "$work/build.log"
  exit 1
fi
ls -l "$work/dist" | awk 'NR > 1 {print "  " $NF, $5, "bytes"}'
wheel=$(ls "$work"/dist/*.whl)
sdist=$(ls "$work"/dist/*.tar.gz)
"$BUILD_PY" .ci/lean_core_checks.py contents "$wheel" "$sdist"

echo "== fresh venv, the wheel alone (no extras)"
"$PYTHON" -m venv "$work/venv"
"$work/venv/bin/python" -m pip install -q -c requirements/lock.txt "$wheel" 2>&1 \
  | grep -v '^WARNING: Location' || true
echo "  $("$work/venv/bin/python" -m pip list --format=freeze 2>/dev/null | wc -l) distributions installed"

mkdir "$work/run"
cd "$work/run"  # not the checkout: nothing of src/ is importable from here
NUMBA_CACHE_DIR="$work/numba" "$work/venv/bin/python" "$root/.ci/lean_core_checks.py" run
