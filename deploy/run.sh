#!/usr/bin/env bash
# Sets everything up (Debian packages, configure, build) and runs the main job: the whole
# multi-process pipeline (bridge, rectify-fuse, detect, match, range under the supervisor) on the
# built-in simulated rig, printing live ranges with their simulated truth and, at the end, the
# latency summary. Extra arguments go to `thermovis run` (e.g. --seconds 60, --scene
# deploy/scenes/night.yaml, --json); Ctrl-C stops it cleanly.
set -euo pipefail
cd "$(dirname "$0")/.."
deploy/install-deps.sh
build_dir=${THERMOVIS_BUILD_DIR:-build}
cmake -S . -B "$build_dir" -DCMAKE_BUILD_TYPE=Release
cmake --build "$build_dir" -j"$(nproc)"
exec "$build_dir/bin/thermovis" run --seconds 30 "$@"
