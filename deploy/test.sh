#!/usr/bin/env bash
# Sets everything up (Debian packages, configure, build) and runs the whole test suite.
# Usage: deploy/test.sh [extra ctest arguments, e.g. -L unit]
set -euo pipefail
cd "$(dirname "$0")/.."
deploy/install-deps.sh
build_dir=${THERMOVIS_BUILD_DIR:-build}
werror=OFF
if [ "${CI:-}" = "true" ]; then werror=ON; fi
cmake -S . -B "$build_dir" -DCMAKE_BUILD_TYPE=Release -DTHERMOVIS_WERROR="$werror"
cmake --build "$build_dir" -j"$(nproc)"
ctest --test-dir "$build_dir" --output-on-failure --timeout 900 -j"$(nproc)" "$@"
