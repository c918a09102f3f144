#!/usr/bin/env bash
# Installs what is missing (scripts/setup.sh), then configures and builds align3d into build/. With
# the Python module on (ALIGN3D_PYTHON, default ON) it also installs the Python package into .venv/
# (created if missing from Debian's /usr/bin/python3, with its site packages: numpy, pytest) from
# that same tree: setup.py builds only the module target there, so no C++ is compiled twice.
# Usage: scripts/build.sh [extra cmake args]
# Environment: BUILD_DIR (default build), JOBS (default 2), ALIGN3D_PYTHON (ON or OFF; OFF for
# sanitizer builds, whose extension module would not load into Python), ALIGN3D_OCCT (ON or OFF:
# STEP and IGES through OpenCASCADE, default ON; setup.sh installs it), BUILD_TARGETS (the targets
# to build, space-separated; default all)
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
build_dir=${BUILD_DIR:-build}
cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DALIGN3D_PYTHON="${ALIGN3D_PYTHON:-ON}" -DALIGN3D_OCCT="${ALIGN3D_OCCT:-ON}" \
  -DPython3_EXECUTABLE=/usr/bin/python3 \
  -DALIGN3D_BATCH_PYTHON="$PWD/.venv/bin/python" "$@" >/dev/null
cmake --build "$build_dir" -j "${JOBS:-2}" ${BUILD_TARGETS:+--target $BUILD_TARGETS}
if grep -q '^ALIGN3D_PYTHON:BOOL=ON$' "$build_dir/CMakeCache.txt"; then
  [ -x .venv/bin/python ] || /usr/bin/python3 -m venv --system-site-packages .venv
  ALIGN3D_CMAKE_BUILD_DIR=$build_dir JOBS=${JOBS:-2} \
    .venv/bin/python -m pip install --quiet --no-cache-dir --no-build-isolation --no-index .
fi
