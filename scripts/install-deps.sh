#!/usr/bin/env bash
# Installs the Debian 12 packages haha builds against (skips apt when all are present).
set -euo pipefail
pkgs=(build-essential cmake ninja-build pkg-config git
      libtinygltf-dev nlohmann-json3-dev libstb-dev libdraco-dev libopenmesh-dev
      libopenimageio-dev libcli11-dev libzip-dev zlib1g-dev libnanoflann-dev
      libgtest-dev libbenchmark-dev gnuplot-nox ffmpeg)
missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
# Node.js runs the Khronos glTF validator in the tests; any node >= 18 with npm will do.
command -v npm >/dev/null 2>&1 || missing+=(nodejs npm)
if [ ${#missing[@]} -gt 0 ]; then
  echo "haha: installing ${missing[*]}"
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
# The Khronos glTF validator (npm, pinned by tools/validator/package-lock.json) for the format tests.
if [ ! -d "$(dirname "$0")/../tools/validator/node_modules/gltf-validator" ]; then
  npm ci --prefix "$(dirname "$0")/../tools/validator" --no-audit --no-fund --loglevel=error >/dev/null
fi
