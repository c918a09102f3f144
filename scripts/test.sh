#!/usr/bin/env bash
# Builds every target of align3d (scripts/build.sh with BUILD_TARGETS=all: the tests too, and the
# benches when configured), runs the whole C++ test suite under ctest, then, when the Python module
# is built, the Python tests (python/tests, pytest from Debian's python3-pytest) with the package
# installed in .venv/; ALIGN3D_CLI tells them the `align3d` executable to compare with.
# Usage: scripts/test.sh [extra cmake args]      Environment: BUILD_DIR, JOBS, ALIGN3D_PYTHON,
# ALIGN3D_UNITY as for build.sh
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_TARGETS=${BUILD_TARGETS:-all} bash scripts/build.sh "$@"
build_dir=${BUILD_DIR:-build}
ctest --test-dir "$build_dir" -j "${JOBS:-2}" --output-on-failure --timeout 900
if grep -q '^ALIGN3D_PYTHON:BOOL=ON$' "$build_dir/CMakeCache.txt"; then
  ALIGN3D_CLI=$(realpath "$build_dir/align3d") .venv/bin/python -m pytest -q python/tests
fi
