#!/usr/bin/env bash
# CTest `blender_avatar` (labels slow, blender): the Blender add-on (python/blender) on a tiny
# trained avatar packed with the defaults (Draco mesh), tests/python/blender_addon_test.py.
#   blender_addon_test.sh HAHA WORKDIR ADDONS_DIR [AVATAR.glb | --garment]
# (--garment: the tiny avatar trained with a skirt, which CTest `blender_avatar` uses.)
# Exits 77 with the reason printed when Blender or its numpy is missing.
set -euo pipefail
haha="$1"
work="$2"
addons="$3"
avatar="${4:-}"
here=$(cd "$(dirname "$0")" && pwd)
source "$here/../support/blender_test_setup.sh"
blender_setup blender_avatar "$work"
avatar=$(given_or_tiny_avatar "$haha" "$work" "$avatar")
lod=()
if [ -d "$work/run" ]; then  # the tiny run made here: packed again with importance tiers
  "$haha" pack "$work/run" --out "$work/avatar_lod.glb" --lod 3 >/dev/null
  lod=(--lod-avatar "$work/avatar_lod.glb")
fi
exec "$blender" -b --factory-startup --python-exit-code 1 --python "$here/blender_addon_test.py" -- \
  --addons "$addons" --avatar "$avatar" --haha "$haha" --work "$work" "${lod[@]}"
