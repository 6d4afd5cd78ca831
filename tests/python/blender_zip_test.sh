#!/usr/bin/env bash
# CTest `blender_addon_zip` (labels slow, blender): the self-contained add-on zip
# (scripts/blender-addon-zip.sh) installed into a fresh Blender profile with no HAHA_*
# variable imports a tiny trained avatar, tests/python/blender_zip_test.py.
#   blender_zip_test.sh HAHA RUNTIME_LIBRARY WORKDIR [AVATAR.glb]
# Exits 77 with the reason printed when Blender or its numpy is missing.
set -euo pipefail
haha="$1"
runtime="$2"
work="$3"
avatar="${4:-}"
here=$(cd "$(dirname "$0")" && pwd)
source "$here/../support/blender_test_setup.sh"
blender_setup blender_addon_zip "$work"
avatar=$(given_or_tiny_avatar "$haha" "$work" "$avatar")
bash "$here/../../scripts/blender-addon-zip.sh" "$runtime" "$work/haha-blender-addon.zip" "$blender"
mkdir -p "$work/profile/config" "$work/profile/scripts"
exec env $(env | awk -F= '/^HAHA_/ {printf "-u %s ", $1}') \
  BLENDER_USER_CONFIG="$work/profile/config" BLENDER_USER_SCRIPTS="$work/profile/scripts" \
  "$blender" -b --factory-startup --python-exit-code 1 --python "$here/blender_zip_test.py" -- \
  "$work/haha-blender-addon.zip" "$avatar"
