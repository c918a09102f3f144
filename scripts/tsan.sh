#!/usr/bin/env bash
# ThreadSanitizer run of the tests that exercise align3d's parallel code (src/detail/parallel.hpp:
# kd-tree queries in ICP, normals, FPFH, RANSAC, PPF, and the determinism tests).
# GCC's libgomp is not instrumented, so TSan would see no synchronisation in OpenMP barriers and
# report false races; this build uses clang with LLVM's libomp, whose OMPT tool Archer
# (libarcher.so) tells TSan about OpenMP's happens-before edges. The TsanSelfCheck tests check the
# setup both ways: silent on race-free parallel_for/parallel_reduce, a report for an injected race.
# Exits non-zero on any TSan report (halt_on_error) or test failure.
# Usage: scripts/tsan.sh [extra cmake args]      Environment: BUILD_DIR (default build-tsan), JOBS
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh clang-14 libclang-rt-14-dev libomp-14-dev
build_dir=${BUILD_DIR:-build-tsan}
# -O1 -g with assertions: cheap to build, readable stacks; benchmarks are not needed here.
BUILD_DIR=$build_dir bash scripts/build.sh -DCMAKE_CXX_COMPILER=clang++-14 \
  -DALIGN3D_SANITIZE_THREAD=ON -DALIGN3D_BUILD_TESTS=ON -DALIGN3D_BUILD_BENCH=OFF \
  -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG="-O1 -g" "$@"

export OMP_TOOL_LIBRARIES=/usr/lib/llvm-14/lib/libarcher.so  # explicit, not libomp's fallback
export TSAN_OPTIONS="halt_on_error=1 ignore_noninstrumented_modules=1 second_deadlock_stack=1"
export OMP_DYNAMIC=false
unset OMP_THREAD_LIMIT
# Tests with threads = 0 use OMP_NUM_THREADS; 3 is more than CI's 2 cores and splits static
# schedules unevenly. The determinism tests set 1 and 2 threads themselves.
export OMP_NUM_THREADS=${OMP_NUM_THREADS:-3}
parallel_tests='^(TsanSelfCheck|KdTree|SpatialOrder|Normals|NormalCache|IcpScene|IcpNormalCache|Degeneracy|Variants/ConveyorVariant|Refine|Align|Shapes/ObjectView|Fpfh|FpfhRansac|Ppf)\.'
# Left out: three accuracy tests whose thresholds hold with GCC but not with clang (they fail under
# clang with 1 thread too, without a TSan report: floating-point differences, not races).
clang_sensitive='^(Refine\.DefaultFindsTheBasinWhereTheMedianRuleLocksOntoThePlane|Variants/ConveyorVariant\.DefaultRegistrationRecoversThePose/\("wide-plane", [12]\))$'
ctest --test-dir "$build_dir" -j "${JOBS:-2}" --output-on-failure --timeout 900 \
  -R "$parallel_tests" -E "$clang_sensitive"
