#!/usr/bin/env bash
# CTest `blender_export` (labels slow, blender): the add-on's avatar with a walk action,
# exported to FBX and glTF and re-imported in a fresh Blender, tests/python/blender_export_test.py.
#   blender_export_test.sh HAHA WORKDIR ADDONS_DIR [AVATAR.glb]
# Exits 77 with the reason printed when Blender or its numpy is missing.
set -euo pipefail
haha="$1"
work="$2"
addons="$3"
avatar="${4:-}"
here=$(cd "$(dirname "$0")" && pwd)
source "$here/../support/blender_test_setup.sh"
blender_setup blender_export "$work"
avatar=$(given_or_tiny_avatar "$haha" "$work" "$avatar")
exec "$blender" -b --factory-startup --python-exit-code 1 --python "$here/blender_export_test.py" -- \
  --addons "$addons" --avatar "$avatar" --haha "$haha" --work "$work"
