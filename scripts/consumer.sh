#!/usr/bin/env bash
# Installs the build (BUILD_DIR, default build; built first if needed) into a temporary prefix and
# builds and runs the consumer project tests/consumer/ against it: find_package(align3d) and the
# exported targets, as a program outside this build sees them. Exits non-zero on any failure.
# Usage: scripts/consumer.sh      Environment: BUILD_DIR, JOBS (default 2), KEEP=1 keeps the prefix
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${BUILD_DIR:-build}
[ -f "$build_dir/CMakeCache.txt" ] || { echo "consumer: configure $build_dir first (scripts/build.sh)" >&2; exit 1; }
tmp=$(mktemp -d)
[ "${KEEP:-0}" = 1 ] && echo "consumer: keeping $tmp" || trap 'rm -rf "$tmp"' EXIT

# The installed targets only: the libraries and the executable.
cmake --build "$build_dir" -j "${JOBS:-2}" --target align3d align3d_report align3d_cli_lib align3d_cli
cmake --install "$build_dir" --prefix "$tmp/prefix" >/dev/null
# The build's compiler and type; the prefix is the only place align3d can come from.
compiler=$(sed -n 's/^CMAKE_CXX_COMPILER:[A-Z]*=//p' "$build_dir/CMakeCache.txt")
build_type=$(sed -n 's/^CMAKE_BUILD_TYPE:[A-Z]*=//p' "$build_dir/CMakeCache.txt")
cmake -S tests/consumer -B "$tmp/build" -G Ninja -DCMAKE_PREFIX_PATH="$tmp/prefix" \
  -DCMAKE_CXX_COMPILER="$compiler" -DCMAKE_BUILD_TYPE="${build_type:-Release}" >/dev/null
cmake --build "$tmp/build" -j "${JOBS:-2}"
"$tmp/build/register_scene"
"$tmp/build/report/plot_scene" "$tmp"
"$tmp/build/report/cli_version"
# The installed tool reads STEP through the installed OpenCASCADE module (lib/align3d/), found from
# its own place (the prefix here is not the one it was configured for): the file has no shape, an
# error only the module's OpenCASCADE can give.
if grep -q '^ALIGN3D_OCCT:BOOL=ON$' "$build_dir/CMakeCache.txt"; then
  set +e
  LD_DEBUG=files "$tmp/prefix/bin/align3d" convert tests/data/hostile/step_only_a_point.step \
    "$tmp/x.ply" > "$tmp/step.log" 2>&1
  code=$?
  set -e
  grep -q "contains no shape OpenCASCADE can transfer" "$tmp/step.log" && [ $code = 3 ] &&
    grep -q "file=$tmp/prefix/bin/../lib[^ ]*/align3d/libalign3d_occt.so" "$tmp/step.log" ||
    { echo "consumer: the installed align3d did not read STEP through its installed module:" >&2
      grep -v "^ *[0-9]*:" "$tmp/step.log" >&2; grep "occt" "$tmp/step.log" >&2; exit 1; }
  echo "STEP through $(grep -o "file=[^ ]*libalign3d_occt.so" "$tmp/step.log" | head -1)"
fi
echo "consumer: passed"
