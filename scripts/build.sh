#!/usr/bin/env bash
# Configures and builds haha into build/ (Release).
# Usage: scripts/build.sh [--target T] [cmake configure arguments...]
#   --target T   build only T (the demo builds `haha`, not the tests and benchmarks)
set -euo pipefail
cd "$(dirname "$0")/.."
target=()
if [ "${1:-}" = "--target" ]; then
  target=(--target "$2")
  shift 2
fi
bash scripts/install-deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release "$@" >/dev/null
cmake --build build --parallel "$(nproc)" "${target[@]}"
