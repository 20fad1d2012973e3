#!/usr/bin/env bash
# Installs the thermovis services as systemd units, for a vehicle that runs them without
# thermovis-supervisor: the executables of a build (default build/bin) and the shipped configs
# under /opt/thermovis, the units in /etc/systemd/system, the settings in
# /etc/thermovis/thermovis.env (kept if present). Then: systemctl enable --now thermovis.target
set -euo pipefail
cd "$(dirname "$0")/../.."
bin_dir=${1:-build/bin}
for exe in thermovis-bridge thermovis-rectify-fuse thermovis-detect thermovis-match thermovis-range thermovis-obstacles thermovis; do
  [ -x "$bin_dir/$exe" ] || { echo "install.sh: $bin_dir/$exe is missing (build first)" >&2; exit 1; }
done
install -d /opt/thermovis/bin /opt/thermovis/deploy /etc/thermovis
install -m 0755 "$bin_dir"/thermovis* /opt/thermovis/bin/
# The bridge's files and v4l2 sources, loaded from beside the executable when asked for.
[ -f "$bin_dir/libthermovis_bridge_media.so" ] &&
  install -m 0755 "$bin_dir/libthermovis_bridge_media.so" /opt/thermovis/bin/
cp -r deploy/rigs deploy/dds deploy/scenes deploy/pipeline.yaml /opt/thermovis/deploy/
[ -f /etc/thermovis/thermovis.env ] || install -m 0644 deploy/systemd/thermovis.env /etc/thermovis/
install -m 0644 deploy/systemd/*.service deploy/systemd/thermovis.target /etc/systemd/system/
systemctl daemon-reload
echo "installed; start with: systemctl enable --now thermovis.target"
