#!/usr/bin/env bash
# Builds align3d (scripts/build.sh) and runs the whole test suite under ctest.
# Usage: scripts/test.sh [extra cmake args]      Environment: BUILD_DIR, JOBS as for build.sh
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh "$@"
ctest --test-dir "${BUILD_DIR:-build}" -j "${JOBS:-2}" --output-on-failure --timeout 900
