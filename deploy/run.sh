#!/usr/bin/env bash
# Sets everything up (Debian packages, configure, build) and runs the main job on the shipped
# paper rig. Extra arguments go to the main job.
set -euo pipefail
cd "$(dirname "$0")/.."
deploy/install-deps.sh
build_dir=${THERMOVIS_BUILD_DIR:-build}
cmake -S . -B "$build_dir" -DCMAKE_BUILD_TYPE=Release
cmake --build "$build_dir" -j"$(nproc)"
exec "$build_dir/bin/thermovis" rig info "$@"
