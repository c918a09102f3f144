#!/usr/bin/env bash
# Builds the libFuzzer targets of the file readers (fuzz/, clang, ASan + UBSan) into build-fuzz/ and
# runs each for SECONDS (default 60) from a scratch copy of its seed corpus (fuzz/corpus/<format>;
# the repository's corpus is never grown). Exits non-zero when any target reports a crash, a leak,
# a timeout or an out-of-memory; the reproducer is kept in $BUILD_DIR/findings/<target>/.
# Usage: scripts/fuzz.sh [SECONDS] [TARGET...]   (targets: ply pcd xyz matrix; default all)
# Environment: BUILD_DIR (default build-fuzz), JOBS (default 2)
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
shift || true
targets=("$@")
((${#targets[@]})) || targets=(ply pcd xyz matrix)
bash scripts/setup.sh clang libclang-rt-14-dev
bash scripts/setup.sh  # the library's own dependencies (find_package at configure time)

build_dir=${BUILD_DIR:-build-fuzz}
# Debug keeps assertions (Eigen's, and libstdc++'s bounds checks added by fuzz/CMakeLists.txt);
# -O1 is libFuzzer's usual trade between speed and build time.
CC=clang CXX=clang++ cmake -S . -B "$build_dir" -G Ninja -DALIGN3D_BUILD_FUZZ=ON \
  -DALIGN3D_BUILD_TESTS=OFF -DALIGN3D_BUILD_BENCH=OFF -DCMAKE_BUILD_TYPE=Debug \
  -DCMAKE_CXX_FLAGS_DEBUG="-O1 -g" >/dev/null
cmake --build "$build_dir" -j "${JOBS:-2}" --target "${targets[@]/%/_fuzz}"

export ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=0
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
failed=()
for t in "${targets[@]}"; do
  work="$build_dir/fuzz-run/$t"
  findings="$build_dir/findings/$t"
  rm -rf "$work"
  mkdir -p "$work/corpus" "$findings"
  cp fuzz/corpus/"$t"/* "$work/corpus/"
  echo "== $t: ${seconds}s"
  if "$build_dir/fuzz/${t}_fuzz" "$work/corpus" -dict="fuzz/$t.dict" \
      -max_total_time="$seconds" -rss_limit_mb=2048 -timeout=10 -max_len=65536 \
      -artifact_prefix="$findings/" -print_final_stats=1 >"$work/log" 2>&1; then
    grep -E '^stat::(number_of_executed_units|average_exec_per_sec|peak_rss_mb)' "$work/log" || true
  else
    failed+=("$t")
    tail -n 40 "$work/log"
    echo "== $t FAILED (log $work/log, reproducer in $findings/)"
  fi
done
if ((${#failed[@]})); then
  echo "fuzz: findings in: ${failed[*]}" >&2
  exit 1
fi
echo "fuzz: no findings"
