#!/usr/bin/env bash
# Builds bench/peers/small_gicp_driver.cpp against an external small_gicp tree (koide3/small_gicp,
# MIT; its code is not part of this repository):
#
#   bench/peers/build_small_gicp_driver.sh SMALL_GICP_TREE OUT_BINARY
#   e.g. bench/peers/build_small_gicp_driver.sh /work/peers/small_gicp build-peers/small_gicp_driver
#
# SMALL_GICP_TREE is a source tree (with include/small_gicp/) or an install prefix (same layout).
# The driver only uses small_gicp's header-only API (PointCloud, KdTree + KdTreeBuilderOMP, the
# OpenMP normal/covariance estimators, Registration<Factor, ParallelReductionOMP>), so no small_gicp
# .cpp file or library is compiled or linked. Flags: -O3 -DNDEBUG (as small_gicp's CMake Release
# build), -fopenmp, C++17, no -march=native. Environment: CXX (default g++), EIGEN3_INCLUDE_DIR
# (default /usr/include/eigen3).
set -euo pipefail

if [[ $# -ne 2 ]]; then
  echo "usage: $0 SMALL_GICP_TREE OUT_BINARY" >&2
  exit 2
fi

tree=$1
out=$2
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
eigen=${EIGEN3_INCLUDE_DIR:-/usr/include/eigen3}
cxx=${CXX:-g++}

if [[ ! -f "$tree/include/small_gicp/registration/registration.hpp" ]]; then
  echo "$0: $tree/include/small_gicp/registration/registration.hpp not found (not a small_gicp tree)" >&2
  exit 2
fi
if [[ ! -f "$eigen/Eigen/Core" ]]; then
  echo "$0: Eigen not found in $eigen (set EIGEN3_INCLUDE_DIR)" >&2
  exit 2
fi

mkdir -p "$(dirname "$out")"
set -x
"$cxx" -std=c++17 -O3 -DNDEBUG -fopenmp -Wall -Wno-sign-compare -Wno-unused-parameter \
  -isystem "$tree/include" -isystem "$eigen" \
  "$here/small_gicp_driver.cpp" -o "$out"
