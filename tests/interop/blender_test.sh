#!/usr/bin/env bash
# CTest `blender_import` (labels blender, slow): Blender (Debian's 3.4, no Draco) imports a
# `haha pack --mesh-compression none` avatar: textured mesh, 55-bone armature, skin that deforms
# (tests/interop/blender_import.py). Usage: blender_test.sh HAHA WORKDIR [AVATAR.glb | --garment]
# --garment (CTest `blender_import_garment`): the tiny avatar trained with a skirt
# (s0.garment.mode=skirt), its garment the body mesh's second primitive.
# Exits 77 with the reason printed when Blender or its numpy is missing.
set -euo pipefail
haha="$1"
work="$2"
avatar="${3:-}"
root=$(cd "$(dirname "$0")/../.." && pwd)
source "$root/tests/support/blender_test_setup.sh"
blender_setup blender_import "$work"
if [ "$avatar" = --garment ]; then
  avatar="$work/avatar_garment_none.glb"
  TINY_TRAIN_EXTRA="s0.garment.mode=skirt" tiny_avatar "$haha" "$work" "$avatar" --mesh-compression none
elif [ -z "$avatar" ]; then
  # Packed without Draco (the settings of the web viewer test).
  avatar="$work/avatar_none.glb"
  tiny_avatar "$haha" "$work" "$avatar" --mesh-compression none
fi
exec "$blender" -b --factory-startup --python-exit-code 1 --python "$root/tests/interop/blender_import.py" -- "$avatar"
