#!/usr/bin/env bash
# Installs align3d's build and test dependencies from Debian's packages, only those missing.
# Usage: scripts/setup.sh [PACKAGE...]   (needs root or sudo; does nothing when all are present)
# With packages named, installs those instead of the build's own list (scripts/setup-peers.sh;
# .ci/run: clang-format, the format check's, which neither the build nor the tests need: with
# LLVM's libraries it is the largest download after OpenCASCADE).
set -euo pipefail
default_pkgs=(build-essential cmake ninja-build pkg-config ca-certificates
      libeigen3-dev libnanoflann-dev libcli11-dev nlohmann-json3-dev libfast-float-dev
      liblzf-dev libceres-dev libcairo2-dev fonts-dejavu-core libgtest-dev libgmock-dev libbenchmark-dev
      python3 python3-dev python3-venv python3-pip python3-numpy python3-setuptools python3-wheel
      python3-pybind11 pybind11-dev python3-pytest python3-distributed
      libocct-foundation-dev libocct-modeling-data-dev libocct-modeling-algorithms-dev
      libocct-data-exchange-dev)
[ $# -gt 0 ] && pkgs=("$@") || pkgs=("${default_pkgs[@]}")
missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  sudo_cmd=""
  [ "$(id -u)" -eq 0 ] || sudo_cmd="sudo"
  echo "setup: installing ${missing[*]}" >&2
  $sudo_cmd apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
