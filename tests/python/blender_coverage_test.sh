#!/usr/bin/env bash
# CTest `blender_coverage` (labels slow, blender): the Blender add-on (python/blender) cuts the
# body where an avatar's mesh coverage is low, tests/python/blender_coverage_test.py, on the
# Python package test's fixtures (no training).
#   blender_coverage_test.sh FIXTURE_EXE WORKDIR ADDONS_DIR
# Exits 77 with the reason printed when Blender or its numpy is missing.
set -euo pipefail
fixture="$1"
work="$2"
addons="$3"
here=$(cd "$(dirname "$0")" && pwd)
source "$here/../support/blender_test_setup.sh"
blender_setup blender_coverage "$work"
"$fixture" "$work/fixture"
exec "$blender" -b --factory-startup --python-exit-code 1 --python "$here/blender_coverage_test.py" -- \
  --addons "$addons" --cut "$work/fixture/coverage.glb" --whole "$work/fixture/animated.glb" --work "$work"
