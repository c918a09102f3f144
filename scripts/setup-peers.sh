#!/usr/bin/env bash
# Installs the peer libraries used only by the side-by-side comparisons in bench/ (not by the build
# or the tests): Debian's Open3D for Python.
set -euo pipefail
exec bash "$(dirname "$0")/setup.sh" python3-open3d python3-numpy
