#!/usr/bin/env bash
# CTest `blender_avatar` (labels slow, blender): the Blender add-on (python/blender) on a tiny
# trained avatar packed with the defaults (Draco mesh), tests/python/blender_addon_test.py.
#   blender_addon_test.sh HAHA WORKDIR ADDONS_DIR [AVATAR.glb]
# Exits 77 (CTest SKIP_RETURN_CODE) with the reason printed when Blender or its numpy is
# missing (not part of scripts/install-deps.sh: apt-get install --no-install-recommends blender python3-numpy).
set -euo pipefail
haha="$1"
work="$2"
addons="$3"
avatar="${4:-}"
here=$(cd "$(dirname "$0")" && pwd)
blender="${HAHA_BLENDER:-blender}"
skip() { echo "SKIP blender_avatar: $*"; exit 77; }
command -v "$blender" >/dev/null 2>&1 || skip "Blender is not installed (apt-get install --no-install-recommends blender python3-numpy, or set HAHA_BLENDER)"
"$blender" -b --factory-startup --python-exit-code 1 --python-expr "import numpy" >/dev/null 2>&1 \
  || skip "Blender's Python has no numpy (apt-get install python3-numpy)"
rm -rf "$work"
mkdir -p "$work"
export OMP_WAIT_POLICY="${OMP_WAIT_POLICY:-passive}"
if [ -z "$avatar" ]; then
  # The tiny trained avatar of the other interop tests, packed with the defaults (Draco).
  "$haha" synth --out "$work/data" --frames 8 --test-frames 2 --size 64 >/dev/null
  "$haha" train --data "$work/data" --out "$work/run" --preset tiny resolution=64 s1.steps=50 s1.densify.from=10 \
    s1.densify.until=40 s1.densify.every=20 s2.steps=30 s2.texture_size=64 s3.steps=30 s3.prune_every=20 \
    log_every=1000 >/dev/null
  "$haha" pack "$work/run" --out "$work/avatar.glb" >/dev/null
  avatar="$work/avatar.glb"
fi
exec "$blender" -b --factory-startup --python-exit-code 1 --python "$here/blender_addon_test.py" -- \
  --addons "$addons" --avatar "$avatar" --haha "$haha" --work "$work"
