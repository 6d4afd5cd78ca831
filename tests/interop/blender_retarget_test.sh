#!/usr/bin/env bash
# CTest `blender_retarget` (labels blender, slow): haha's BVH out through Blender and back in
# through `haha motion --retarget` (tests/interop/blender_retarget.py). A procedural walk written
# as BVH (`haha motion --in M.npz --out M.bvh`) is imported by Blender's own BVH importer, its
# bones renamed to Mixamo's, copied onto an armature resting in an A-pose (Blender's bone axes),
# given a root path, and written by Blender's FBX and BVH exporters; both files retargeted back
# must give every joint of every frame within 1 degree of the walk, and the root path.
#   blender_retarget_test.sh HAHA WORKDIR
# Exits 77 with the reason printed when Blender or its numpy is missing.
set -euo pipefail
haha="$1"
work="$2"
root=$(cd "$(dirname "$0")/../.." && pwd)
source "$root/tests/support/blender_test_setup.sh"
blender_setup blender_retarget "$work"
script="$root/tests/interop/blender_retarget.py"
"$haha" motion --kind walk --frames 30 --fps 30 --out "$work/walk.npz" >/dev/null
"$haha" motion --in "$work/walk.npz" --out "$work/walk.bvh" >/dev/null
"$blender" -b --factory-startup --python-exit-code 1 --python "$script" -- export "$work/walk.bvh" "$work"
for f in fbx bvh; do
  "$haha" motion --retarget "$work/rig.$f" --out "$work/back_$f.npz" --no-foot-lock
done
exec "$blender" -b --factory-startup --python-exit-code 1 --python "$script" -- compare "$work/walk.npz" \
  "$work/back_fbx.npz" "$work/back_bvh.npz"
