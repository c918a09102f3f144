#!/usr/bin/env bash
# Builds the libFuzzer targets of the file readers (fuzz/, clang, ASan + UBSan) into build-fuzz/ and
# runs each for SECONDS (default 60), JOBS targets at a time, from a scratch copy of its seed corpus
# (fuzz/corpus/<format>; the repository's corpus is never grown). Exits non-zero when any target
# reports a crash, a leak, a timeout or an out-of-memory; the reproducer is kept in
# $BUILD_DIR/findings/<target>/.
# Usage: scripts/fuzz.sh [SECONDS] [TARGET...]   (targets: ply pcd xyz matrix stl obj off ply_mesh;
# default all)
# Environment: BUILD_DIR (default build-fuzz), JOBS (default 2)
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
shift || true
targets=("$@")
((${#targets[@]})) || targets=(ply pcd xyz matrix stl obj off ply_mesh)
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
# One target per core at a time (JOBS, default 2): each fuzzer is single-threaded.
run_target() {
  local t=$1 work="$build_dir/fuzz-run/$1" findings="$build_dir/findings/$1"
  rm -rf "$work"
  mkdir -p "$work/corpus" "$findings"
  cp fuzz/corpus/"$t"/* "$work/corpus/"
  "$build_dir/fuzz/${t}_fuzz" "$work/corpus" -dict="fuzz/$t.dict" \
    -max_total_time="$seconds" -rss_limit_mb=2048 -timeout=10 -max_len=65536 \
    -artifact_prefix="$findings/" -print_final_stats=1 >"$work/log" 2>&1
}
failed=()
for ((first = 0; first < ${#targets[@]}; first += ${JOBS:-2})); do
  batch=("${targets[@]:first:${JOBS:-2}}")
  echo "== ${batch[*]}: ${seconds}s"
  pids=()
  for t in "${batch[@]}"; do
    run_target "$t" &
    pids+=($!)
  done
  for k in "${!batch[@]}"; do
    t=${batch[$k]}
    if wait "${pids[$k]}"; then
      echo "-- $t"
      grep -E '^stat::(number_of_executed_units|average_exec_per_sec|peak_rss_mb)' \
        "$build_dir/fuzz-run/$t/log" || true
    else
      failed+=("$t")
      tail -n 40 "$build_dir/fuzz-run/$t/log"
      echo "== $t FAILED (log $build_dir/fuzz-run/$t/log, reproducer in $build_dir/findings/$t/)"
    fi
  done
done
if ((${#failed[@]})); then
  echo "fuzz: findings in: ${failed[*]}" >&2
  exit 1
fi
echo "fuzz: no findings"
