#!/usr/bin/env bash
# A real Dask cluster of separate processes on this host, as docs/cluster.md sets one up on many:
# a fresh venv with the wheel installed (nothing else from the repository), a `dask scheduler` and
# two `dask worker` processes (one thread each) started from that venv's Python, then
# scripts/cluster_check.py in that venv: `align3d batch --scheduler` and register_pairs(client=)
# on 30 generated pairs, one of them failing, checked against the truth, the failure isolated, and
# the same reports bit for bit as an in-process cluster's. Every process it started is stopped on
# exit, failed or not; their logs are printed when it fails.
# Usage: scripts/cluster_test.sh [WHEEL]   (default: the wheel scripts/wheel.sh makes from build/)
set -euo pipefail
cd "$(dirname "$0")/.."
repo=$PWD
wheel=${1:-}
if [ -z "$wheel" ]; then
  wheel=$(bash scripts/wheel.sh | tail -1)
fi
wheel=$(realpath "$wheel")
tmp=$(mktemp -d /tmp/align3d-cluster.XXXXXX)
pids=()
cleanup() {
  local rc=$?
  # Each process runs in its own session (setsid), so its group id is its pid: the group takes a
  # worker's nanny and the worker process it starts.
  for pid in "${pids[@]}"; do kill -TERM -- "-$pid" 2>/dev/null || true; done
  for pid in "${pids[@]}"; do
    for _ in $(seq 50); do kill -0 -- "-$pid" 2>/dev/null || break; sleep 0.1; done
    kill -KILL -- "-$pid" 2>/dev/null || true
  done
  if [ $rc -ne 0 ]; then
    for log in "$tmp"/*.log; do [ -f "$log" ] && { echo "--- $log"; tail -20 "$log"; }; done
  fi
  rm -rf "$tmp"
  exit $rc
}
trap cleanup EXIT
trap 'exit 130' INT TERM

start=$SECONDS
# 1. The environment every host would have: Debian's Python (numpy, dask from its packages) and the
# wheel, installed offline. The check runs from $tmp, so nothing is imported from the checkout.
/usr/bin/python3 -m venv --system-site-packages "$tmp/venv"
py=$tmp/venv/bin/python
"$py" -m pip install --quiet --no-cache-dir --no-index "$wheel"
echo "cluster_test: venv with $(basename "$wheel"): $((SECONDS - start)) s"

# 2. A scheduler on a free port and two workers, each its own process, with the venv's Python.
port=$("$py" -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
address=tcp://127.0.0.1:$port
cd "$tmp"
setsid "$py" -m dask scheduler --host 127.0.0.1 --port "$port" --no-dashboard \
  >"$tmp/scheduler.log" 2>&1 &
pids+=($!)
for name in worker-1 worker-2; do
  setsid "$py" -m dask worker "$address" --name "$name" --nthreads 1 --nworkers 1 \
    --no-dashboard --local-directory "$tmp/$name" >"$tmp/$name.log" 2>&1 &
  pids+=($!)
done

# 3. The batch through the CLI and through Python, checked (in its own session too, waited for in
# the background so that a signal stops it and the cluster at once).
setsid "$py" "$repo/scripts/cluster_check.py" --scheduler "$address" --workers 2 \
  --data "$tmp/data" --cli "$tmp/venv/bin/align3d" &
pids+=($!)
wait $!
echo "cluster_test: passed in $((SECONDS - start)) s"
