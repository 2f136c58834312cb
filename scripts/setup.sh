#!/usr/bin/env bash
# SPDX-License-Identifier: GPL-3.0-or-later
# Install the Debian packages iires needs (only those missing), then configure and build into build/ with the
# Python module (-DIIRES_PYTHON=ON, built for Debian's /usr/bin/python3, which has the python3-* packages).
# Usage: bash scripts/setup.sh [extra cmake -D options]
#        bash scripts/setup.sh --install-only     (the packages, no build)
set -euo pipefail
cd "$(dirname "$0")/.."

bash scripts/install_packages.sh build-essential cmake libeigen3-dev libnanoflann-dev libcgal-dev libcli11-dev \
  libgtest-dev python3-dev pybind11-dev python3-numpy python3-pytest libopenmpi-dev openmpi-bin
[ "${1:-}" = --install-only ] && exit 0

cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DIIRES_PYTHON=ON -DPython3_EXECUTABLE=/usr/bin/python3 "$@"
cmake --build build -j"$(nproc)"
