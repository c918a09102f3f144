#!/usr/bin/env bash
# Installs what is missing (scripts/setup.sh), then configures and builds align3d into build/.
# Usage: scripts/build.sh [extra cmake args]     Environment: BUILD_DIR (default build), JOBS (default 2)
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
build_dir=${BUILD_DIR:-build}
cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release "$@" >/dev/null
cmake --build "$build_dir" -j "${JOBS:-2}"
