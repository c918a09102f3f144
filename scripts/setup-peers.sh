#!/usr/bin/env bash
# Installs the peer libraries used only by the side-by-side comparisons in bench/ (not by the build,
# the tests or CI): Debian's Open3D 0.16 and PCL 1.13 C++ development packages for the runners in
# bench/peers/ (bench/compare.py, bench/compare_find.py), and Open3D for Python for
# bench/compare_global.py and bench/compare_find.py.
# For the deviation step (bench/compare_inspect.py, bench/mesh_bench.cpp): CloudCompare 2.11 (its
# C2M distances, run headless with QT_QPA_PLATFORM=offscreen, or under xvfb-run, hence xvfb and
# xauth), Embree 3 and CGAL 5.5 (align3d_mesh_bench is built only when both are found).
set -euo pipefail
exec bash "$(dirname "$0")/setup.sh" libopen3d-dev libpcl-dev python3-open3d python3-numpy \
  cloudcompare xvfb xauth libembree-dev libcgal-dev
