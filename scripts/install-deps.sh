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
      libopenimageio-dev libcli11-dev libzip-dev zlib1g-dev libnanoflann-dev ffmpeg
      libassimp-dev)
# The tests and benchmarks (GoogleTest, Google Benchmark), `haha bench`'s plots (gnuplot) and
# the Python package's test (python3-numpy for Debian's /usr/bin/python3): not for the demo,
# which builds `haha` alone with HAHA_BUILD_TESTS=OFF.
[ "${HAHA_BUILD_ONLY:-0}" = 1 ] || pkgs+=(libgtest-dev libbenchmark-dev gnuplot-nox python3-numpy)
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
# The npm packages of DIR as its package-lock.json pins them: installed when MARKER (a path
# under DIR/node_modules) is missing, or when the lock file is newer than what npm last
# installed there (a checkout that changed a pin).
npm_packages() {
  local dir="$(dirname "$0")/../$1"
  if [ ! -e "$dir/node_modules/$2" ] || [ "$dir/package-lock.json" -nt "$dir/node_modules/.package-lock.json" ]; then
    npm ci --prefix "$dir" --no-audit --no-fund --loglevel=error >/dev/null
  fi
}
# The Khronos glTF validator for the format tests.
npm_packages tools/validator gltf-validator
# The keypoint + mask tool of `haha fit-video` (tools/keypoints: TF.js wasm and the MediaPipe
# models, pinned; ~350 MB). HAHA_NO_KEYPOINTS=1 leaves it out (its test then skips).
if [ "${HAHA_NO_KEYPOINTS:-0}" != 1 ]; then
  bash "$(dirname "$0")/setup-keypoints.sh"
fi
# The web viewer's packages (three, fflate; playwright-core, pngjs for its test) and the
# loader plugins' of format/js (three, babylonjs + babylonjs-loaders; playwright-core, pngjs
# for their browser tests). playwright-core stays at 1.61, the last release that runs on
# Debian 12's Node.js 18.
if [ "${HAHA_NO_BROWSER:-0}" != 1 ]; then
  npm_packages samples/web playwright-core
  npm_packages format/js babylonjs-loaders
fi
# The glTF-Transform extension class of HAHA_gaussian_avatar and its test (format/js/gltf-transform:
# @gltf-transform/core + extensions, draco3dgltf, pngjs).
npm_packages format/js/gltf-transform @gltf-transform/core
