#!/usr/bin/env bash
# Installs the Debian 12 packages haha builds against (skips apt when all are present), and
# the pinned npm packages and Chromium the tests use. HAHA_BUILD_ONLY=1 (the demo) installs
# only what building and running `haha` needs: no test libraries, gnuplot, node, npm
# packages or browser.
set -euo pipefail
if [ "${HAHA_BUILD_ONLY:-0}" = 1 ]; then
  export HAHA_NO_BROWSER=1 HAHA_NO_KEYPOINTS=1
fi
pkgs=(build-essential cmake ninja-build pkg-config git
      libtinygltf-dev nlohmann-json3-dev libstb-dev libdraco-dev libopenmesh-dev
      libopenimageio-dev libcli11-dev libzip-dev zlib1g-dev libnanoflann-dev ffmpeg)
# The tests and benchmarks (GoogleTest, Google Benchmark) and `haha bench`'s plots (gnuplot):
# not for the demo, which builds `haha` alone with HAHA_BUILD_TESTS=OFF.
[ "${HAHA_BUILD_ONLY:-0}" = 1 ] || pkgs+=(libgtest-dev libbenchmark-dev gnuplot-nox)
missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
# Node.js runs the Khronos glTF validator in the tests; any node >= 18 with npm will do.
[ "${HAHA_BUILD_ONLY:-0}" = 1 ] || command -v npm >/dev/null 2>&1 || missing+=(nodejs npm)
# Debian's Chromium drives the web viewer's browser test (CTest web_viewer, samples/web;
# measured: 34 s to install on the 2-core VM). HAHA_NO_BROWSER=1 leaves it out; the test
# then reports itself skipped.
if [ "${HAHA_NO_BROWSER:-0}" != 1 ]; then
  dpkg-query -W -f='${Status}' chromium 2>/dev/null | grep -q "install ok installed" || missing+=(chromium)
fi
# Slurm and munge for `haha batch`'s one-node cluster test (CTest batch_slurm, docs/scale-out.md):
# only with HAHA_WITH_SLURM=1, so the default install does not grow; the test skips without them.
if [ "${HAHA_WITH_SLURM:-0}" = 1 ]; then
  for p in slurm-wlm munge; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
fi
if [ ${#missing[@]} -gt 0 ]; then
  echo "haha: installing ${missing[*]}"
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
[ "${HAHA_BUILD_ONLY:-0}" = 1 ] && exit 0
# The Khronos glTF validator (npm, pinned by tools/validator/package-lock.json) for the format tests.
if [ ! -d "$(dirname "$0")/../tools/validator/node_modules/gltf-validator" ]; then
  npm ci --prefix "$(dirname "$0")/../tools/validator" --no-audit --no-fund --loglevel=error >/dev/null
fi
# The keypoint + mask tool of `haha fit-video` (tools/keypoints: TF.js wasm and the MediaPipe
# models, pinned; ~350 MB). HAHA_NO_KEYPOINTS=1 leaves it out (its test then skips).
if [ "${HAHA_NO_KEYPOINTS:-0}" != 1 ]; then
  bash "$(dirname "$0")/setup-keypoints.sh"
fi
# The web viewer's pinned npm packages (three, fflate; playwright-core, pngjs for its test).
if [ "${HAHA_NO_BROWSER:-0}" != 1 ] && [ ! -d "$(dirname "$0")/../samples/web/node_modules/playwright-core" ]; then
  npm ci --prefix "$(dirname "$0")/../samples/web" --no-audit --no-fund --loglevel=error >/dev/null
fi
# The loader plugins of format/js (three, babylonjs + babylonjs-loaders; playwright-core,
# pngjs for their browser tests; pinned by format/js/package-lock.json).
if [ "${HAHA_NO_BROWSER:-0}" != 1 ] && [ ! -d "$(dirname "$0")/../format/js/node_modules/babylonjs-loaders" ]; then
  npm ci --prefix "$(dirname "$0")/../format/js" --no-audit --no-fund --loglevel=error >/dev/null
fi
# The glTF-Transform extension class of HAHA_gaussian_avatar and its test (format/js/gltf-transform:
# @gltf-transform/core + extensions, draco3dgltf, pngjs; pinned by its package-lock.json).
if [ ! -d "$(dirname "$0")/../format/js/gltf-transform/node_modules/@gltf-transform/core" ]; then
  npm ci --prefix "$(dirname "$0")/../format/js/gltf-transform" --no-audit --no-fund --loglevel=error >/dev/null
fi
