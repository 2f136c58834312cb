#!/usr/bin/env bash
# Install the Debian packages iires needs (only those missing), then configure and build into build/.
# Usage: bash scripts/setup.sh [extra cmake -D options]
#        bash scripts/setup.sh --install-only     (the packages, no build)
set -euo pipefail
cd "$(dirname "$0")/.."

bash scripts/install_packages.sh build-essential cmake libeigen3-dev libnanoflann-dev libcgal-dev libcli11-dev \
  libgtest-dev
[ "${1:-}" = --install-only ] && exit 0

cmake -S . -B build -DCMAKE_BUILD_TYPE=Release "$@"
cmake --build build -j"$(nproc)"
