#!/usr/bin/env bash
# Sets everything up (Debian packages, configure, build) and runs the main job on the shipped
# paper rig. For now the main job is the geometry demo: the rig's cameras (field of view,
# distortion, baselines), then a synthetic checkerboard rendered through each visible camera's
# Taylor model and rectified through the visible pair's composed maps (written to
# $THERMOVIS_DEMO_DIR, default build/demo). Extra arguments (e.g. --json) go to both commands.
set -euo pipefail
cd "$(dirname "$0")/.."
deploy/install-deps.sh
build_dir=${THERMOVIS_BUILD_DIR:-build}
cmake -S . -B "$build_dir" -DCMAKE_BUILD_TYPE=Release
cmake --build "$build_dir" -j"$(nproc)"
demo_dir=${THERMOVIS_DEMO_DIR:-$build_dir/demo}
mkdir -p "$demo_dir"
"$build_dir/bin/thermovis" rig info "$@"
exec "$build_dir/bin/thermovis" rectify --pair visible --checkerboard \
  --left "$demo_dir/visible-left-raw.png" --right "$demo_dir/visible-right-raw.png" \
  --out-left "$demo_dir/visible-left-rectified.png" \
  --out-right "$demo_dir/visible-right-rectified.png" "$@"
