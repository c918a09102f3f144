#!/usr/bin/env bash
# Installs what is missing (scripts/setup.sh), then configures align3d into build/ and builds what
# the main job needs: the `align3d` tool and, with the Python module on (ALIGN3D_PYTHON, default
# ON), the extension module, then installs the Python package into .venv/ (created if missing from
# Debian's /usr/bin/python3, with its site packages: numpy, pytest, dask) from that same tree:
# setup.py builds only the module target there, so no C++ is compiled twice. The tests and benches
# are left to scripts/test.sh (BUILD_TARGETS=all). One line per phase with its time on stderr.
#
# A new tree is a unity build (CMAKE_UNITY_BUILD: 8 sources a unit, each header parsed and Eigen's
# templates instantiated once a unit, not once a file; about half the compile time of a clean
# build); an existing tree keeps what it was configured with. ALIGN3D_UNITY=OFF configures file by
# file, for incremental work (a change recompiles its own file, not its unit of eight).
# Usage: scripts/build.sh [extra cmake args]
# Environment: BUILD_DIR (default build), JOBS (default 2), ALIGN3D_PYTHON (ON or OFF; OFF for
# sanitizer builds, whose extension module would not load into Python), ALIGN3D_OCCT (ON or OFF:
# STEP and IGES through OpenCASCADE, default ON; setup.sh installs it), ALIGN3D_UNITY (ON or OFF:
# unity build, default ON for a new tree), BUILD_TARGETS (the targets to build, space-separated;
# default align3d_cli plus align3d_python; `all` for everything, tests and benches included)
set -euo pipefail
cd "$(dirname "$0")/.."
phase_start=$SECONDS
phase() {  # phase NAME: the time since the previous phase, one line
  printf 'build.sh: %-15s %4d s\n' "$1" $((SECONDS - phase_start)) >&2
  phase_start=$SECONDS
}
bash scripts/setup.sh
phase "setup"
build_dir=${BUILD_DIR:-build}
unity=()
if [ -n "${ALIGN3D_UNITY:-}" ]; then
  unity=(-DCMAKE_UNITY_BUILD="$ALIGN3D_UNITY")
elif [ ! -f "$build_dir/CMakeCache.txt" ]; then
  unity=(-DCMAKE_UNITY_BUILD=ON)
fi
cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DALIGN3D_PYTHON="${ALIGN3D_PYTHON:-ON}" -DALIGN3D_OCCT="${ALIGN3D_OCCT:-ON}" \
  -DPython3_EXECUTABLE=/usr/bin/python3 \
  -DALIGN3D_BATCH_PYTHON="$PWD/.venv/bin/python" "${unity[@]}" "$@" >/dev/null
phase "configure"
python_on=false
if grep -q '^ALIGN3D_PYTHON:BOOL=ON$' "$build_dir/CMakeCache.txt"; then python_on=true; fi
targets=${BUILD_TARGETS:-align3d_cli}
if [ -z "${BUILD_TARGETS:-}" ] && $python_on; then targets+=" align3d_python"; fi
cmake --build "$build_dir" -j "${JOBS:-2}" --target $targets
phase "build ($targets)"
if $python_on; then
  [ -x .venv/bin/python ] || /usr/bin/python3 -m venv --system-site-packages .venv
  ALIGN3D_CMAKE_BUILD_DIR=$build_dir JOBS=${JOBS:-2} \
    .venv/bin/python -m pip install --quiet --no-cache-dir --no-build-isolation --no-index .
  phase "python package"
fi
