#!/usr/bin/env bash
# Installs the Debian/Ubuntu packages indoorloc builds against, only those missing (idempotent):
# FFmpeg's libraries for video frame sources and camera devices (crate ffmpeg-next), clang and
# pkg-config for its bindings, g++ for meshoptimizer's C++ (crate meshopt, the scan's mesh
# simplification), and Chromium for the dashboard's browser test.
# Everything else comes from crates.io through cargo.
set -euo pipefail
packages=(pkg-config clang libclang-dev g++ libavcodec-dev libavformat-dev libavutil-dev libswscale-dev libavdevice-dev
    chromium chromium-driver)
missing=()
for p in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ "${#missing[@]}" -eq 0 ] && exit 0
sudo=""
[ "$(id -u)" = 0 ] || sudo="sudo"
echo "install-deps: installing ${missing[*]}"
$sudo apt-get update -qq
DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
