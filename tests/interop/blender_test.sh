#!/usr/bin/env bash
# CTest `blender_import` (labels blender, slow): Blender (Debian's 3.4, no Draco) imports a
# `haha pack --mesh-compression none` avatar: textured mesh, 55-bone armature, skin that deforms
# (tests/interop/blender_import.py). Usage: blender_test.sh HAHA WORKDIR [AVATAR.glb]
# Exits 77 (CTest SKIP_RETURN_CODE) with the reason printed when Blender is not installed (it is
# not part of scripts/install-deps.sh: apt-get install --no-install-recommends blender python3-numpy).
set -euo pipefail
haha="$1"
work="$2"
avatar="${3:-}"
root=$(cd "$(dirname "$0")/../.." && pwd)
blender="${HAHA_BLENDER:-blender}"
skip() { echo "SKIP blender_import: $*"; exit 77; }
command -v "$blender" >/dev/null 2>&1 || skip "Blender is not installed (apt-get install --no-install-recommends blender python3-numpy, or set HAHA_BLENDER)"
rm -rf "$work"
mkdir -p "$work"
export OMP_WAIT_POLICY="${OMP_WAIT_POLICY:-passive}"
if [ -z "$avatar" ]; then
  # A tiny trained avatar, packed without Draco (the settings of the web viewer test).
  "$haha" synth --out "$work/data" --frames 8 --test-frames 2 --size 64 >/dev/null
  "$haha" train --data "$work/data" --out "$work/run" --preset tiny resolution=64 s1.steps=50 s1.densify.from=10 \
    s1.densify.until=40 s1.densify.every=20 s2.steps=30 s2.texture_size=64 s3.steps=30 s3.prune_every=20 \
    log_every=1000 >/dev/null
  "$haha" pack "$work/run" --out "$work/avatar_none.glb" --mesh-compression none >/dev/null
  avatar="$work/avatar_none.glb"
fi
# Blender's glTF importer needs numpy (Debian: python3-numpy, a Recommends of blender).
"$blender" -b --factory-startup --python-exit-code 1 --python-expr "import numpy" >/dev/null 2>&1 \
  || skip "Blender's Python has no numpy (apt-get install python3-numpy)"
exec "$blender" -b --factory-startup --python-exit-code 1 --python "$root/tests/interop/blender_import.py" -- "$avatar"
