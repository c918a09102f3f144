#!/usr/bin/env bash
# Runs a GoogleTest binary as SHARDS processes (GTEST_TOTAL_SHARDS / GTEST_SHARD_INDEX), JOBS at a
# time, each under a time limit; exits non-zero when any shard fails, prints each shard's summary
# and the log of every failed shard. CI's sanitizer stage runs the suite this way: ctest starts one
# process per test, and under ASan that start (~0.35 s: the instrumented binary's load and static
# set-up) was a quarter of the stage's test time (696 ctest tests: 206 s through ctest, 151 s in two
# shards, on 2 cores). More shards than jobs cost more than they even out: six took 175 s, as a
# suite that prepares its scene once per process (SetUpTestSuite) prepares it in every shard.
# With COST_FILE (ctest's CTestCostData.txt from a run of the same suite), the shards are cut by
# those times instead (scripts/shard_plan.py: whole test suites, longest first, each to the
# shard with the least so far), not by position.
# Usage: scripts/gtest_shards.sh BINARY SHARDS [gtest arguments...]
# Environment: JOBS (default 2), SHARD_TIMEOUT (seconds per shard, default 1800), LOG_DIR (default
# a temporary directory), COST_FILE (optional)
set -euo pipefail
binary=$(realpath "$1")
shards=$2
shift 2
log_dir=${LOG_DIR:-$(mktemp -d)}
mkdir -p "$log_dir"
log_dir=$(realpath "$log_dir")
export binary shards log_dir SHARD_TIMEOUT=${SHARD_TIMEOUT:-1800}
planned=0
if [[ -n ${COST_FILE:-} && -f ${COST_FILE:-} ]]; then
  # One filter a shard, a line each (up to ~30 KB of test names); the last --gtest_filter given
  # is the one GoogleTest takes, and the plan already leaves out what the caller's filter does.
  "$binary" --gtest_list_tests "$@" | /usr/bin/python3 "$(dirname "$0")/shard_plan.py" \
    "$COST_FILE" "$shards" >"$log_dir/plan"
  planned=1
elif [[ -n ${COST_FILE:-} ]]; then
  echo "gtest_shards.sh: no $COST_FILE; sharding by position" >&2
fi
export planned
run_shard() {
  local k=$1 log="$log_dir/shard$1.log" filter
  if ((planned)); then
    filter=$(sed -n "$((k + 1))p" "$log_dir/plan")
    if [[ -z $filter ]]; then echo "shard $k/$shards: no tests"; return 0; fi
    set -- "$@" "--gtest_filter=$filter"
  else
    export GTEST_TOTAL_SHARDS=$shards GTEST_SHARD_INDEX=$k
  fi
  if timeout "$SHARD_TIMEOUT" "$binary" "${@:2}" >"$log" 2>&1; then
    echo "shard $k/$shards: $(grep -E '^\[==========\] .* ran' "$log" | tail -1)"
  else
    echo "shard $k/$shards FAILED (exit $?): $log"
    return 1
  fi
}
export -f run_shard
status=0
# The test binary writes files relative to its folder (as ctest runs it there).
cd "$(dirname "$binary")"
seq 0 $((shards - 1)) | xargs -P "${JOBS:-2}" -I{} bash -c 'run_shard "$@"' _ {} "$@" || status=1
if ((status)); then
  for log in "$log_dir"/shard*.log; do
    grep -q '^\[  PASSED  \]' "$log" && ! grep -q '^\[  FAILED  \]' "$log" && continue
    echo "== $log"
    cat "$log"
  done
fi
exit $status
