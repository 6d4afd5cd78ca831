#!/usr/bin/env bash
# The test command: installs, builds and runs the CTest suite (labels fast, slow and fuzz;
# the gpu label is left out: `scripts/test.sh -L gpu` on a GPU machine). `scripts/test.sh
# -L fast` runs the fast ones.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh
cd build
# Passive OpenMP waiting: ctest runs several test programs at once on few cores.
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-passive}
if [ $# -gt 0 ]; then
  ctest --output-on-failure -j "$(nproc)" "$@"
else
  ctest --output-on-failure -j "$(nproc)" -LE gpu
fi
