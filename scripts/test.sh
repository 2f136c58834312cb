#!/usr/bin/env bash
# SPDX-License-Identifier: GPL-3.0-or-later
# Set everything up, fetch the real test data, build the tests and run the whole suite (with iires-render's
# tests, which need matplotlib).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh -DIIRES_BUILD_TESTS=ON -DIIRES_WITH_MPI=ON
bash scripts/install_packages.sh python3-matplotlib
bash datasets/fetch.sh
ctest --test-dir build --output-on-failure --timeout 900
