#!/usr/bin/env bash
# Builds a wheel of the Python package into dist/: the package, its extension module align3d._core
# and the `align3d` command (a console script running the tool inside the extension), for Debian's
# /usr/bin/python3. It installs into any venv of that Python on the same platform without a
# compiler: `python -m pip install --no-index dist/align3d-*.whl` (numpy from the venv or Debian's
# python3-numpy; the shared libraries the module links: docs/cluster.md, "The wheel").
# The extension comes from an existing CMake tree configured with the Python module (BUILD_DIR,
# default build: scripts/build.sh makes it, and is run first when it is missing): only the module
# target is built there, nothing when it is up to date.
# Usage: scripts/wheel.sh     Environment: BUILD_DIR, WHEEL_DIR (default dist), JOBS
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${BUILD_DIR:-build}
wheel_dir=${WHEEL_DIR:-dist}
[ -f "$build_dir/CMakeCache.txt" ] || BUILD_DIR=$build_dir bash scripts/build.sh
grep -q '^ALIGN3D_PYTHON:BOOL=ON$' "$build_dir/CMakeCache.txt" ||
  { echo "wheel.sh: $build_dir was configured without -DALIGN3D_PYTHON=ON" >&2; exit 2; }
version=$(sed -n 's/^project(align3d VERSION \([0-9.]*\).*/\1/p' CMakeLists.txt)
rm -f "$wheel_dir"/align3d-"$version"-*.whl
ALIGN3D_CMAKE_BUILD_DIR=$build_dir JOBS=${JOBS:-2} /usr/bin/python3 -m pip wheel --quiet \
  --no-cache-dir --no-build-isolation --no-index --no-deps --wheel-dir "$wheel_dir" .
ls "$wheel_dir"/align3d-"$version"-*.whl
