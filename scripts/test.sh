#!/usr/bin/env bash
# The test command: installs, builds and runs the CTest suite (labels fast, slow and fuzz,
# and gpu where an NVIDIA GPU is present and the build has the CUDA backend).
# `scripts/test.sh -L fast` runs the fast ones, `scripts/test.sh -L gpu` the GPU ones.
set -euo pipefail
cd "$(dirname "$0")/.."
# The CUDA backend is compiled wherever nvcc is (its gpu tests run only where a GPU is);
# ON explicitly, since a demo build without a GPU may have turned it off in the cache.
bash scripts/build.sh -DHAHA_WITH_CUDA=ON -DHAHA_BUILD_TESTS=ON  # the demo may have left them off
cd build
# Passive OpenMP waiting: ctest runs several test programs at once on few cores.
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-passive}
if [ $# -gt 0 ]; then
  ctest --output-on-failure -j "$(nproc)" "$@"
elif nvidia-smi -L 2>/dev/null | grep -q '^GPU' && ctest -N -L gpu | grep -q 'Total Tests: [1-9]'; then
  echo "haha: NVIDIA GPU found, running the gpu-labelled tests too"
  ctest --output-on-failure -j "$(nproc)"
else
  echo "haha: no NVIDIA GPU (nvidia-smi) or no CUDA build: leaving out the gpu-labelled tests"
  ctest --output-on-failure -j "$(nproc)" -LE gpu
fi
