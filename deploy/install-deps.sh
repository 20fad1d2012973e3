#!/usr/bin/env bash
# Installs the Debian 12 packages thermovis needs to build, test and run. Idempotent: does
# nothing when every package is already installed. Needs root (or sudo) only when installing.
set -euo pipefail

packages=(
  build-essential cmake pkg-config git
  libopencv-dev libopencv-contrib-dev opencv-data
  libeigen3-dev libyaml-cpp-dev nlohmann-json3-dev libcli11-dev libceres-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libhwy-dev
  libfastrtps-dev fastddsgen fastdds-tools
  cyclonedds-dev cyclonedds-tools
  clang-format iproute2 procps
  clang libclang-rt-14-dev
  libcpp-httplib-dev chromium chromium-driver
  libzstd-dev zlib1g-dev
  openssl
)
# foxglove_client_test: Foxglove's own decoders (npm packages) read a recording. A machine whose
# Node.js already brings npm (another distribution's nodejs package includes it, and conflicts
# with Debian's npm) keeps its own.
if ! command -v node >/dev/null || ! command -v npm >/dev/null; then
  packages+=(nodejs npm)
fi

missing=()
for pkg in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$pkg")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

echo "install-deps: installing ${missing[*]}"
sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -q
"${sudo_cmd[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
