#!/usr/bin/env bash
# CTest `blender_animation` (labels blender, slow): Blender's own glTF importer (Debian's 3.4)
# plays a plain pack's animation (`haha pack --mesh-compression none --no-pose-correctives
# --animation`, a 40-frame wave at 30 fps) as an Action on the skinned body, vertex for vertex
# where the haha runtime puts it (tests/interop/blender_animation.py).
# The HAHA add-on imports the same file's animation as an Action that plays the same motion.
#   blender_animation_test.sh HAHA WORKDIR PYTHON_DIR ADDONS [RUN]   (PYTHON_DIR: build/python,
#   the `haha` package; ADDONS: build/python/blender/addons; RUN: a trained run to pack instead
#   of training the tiny one)
# Exits 77 with the reason printed when Blender or its numpy is missing.
set -euo pipefail
haha="$1"
work="$2"
python_dir="$3"
addons="$4"
run="${5:-}"
root=$(cd "$(dirname "$0")/../.." && pwd)
source "$root/tests/support/blender_test_setup.sh"
blender_setup blender_animation "$work"
# HAHA_TEST_ANIMATION_MOTION=M.npz: that motion (30 fps, at least 31 frames: a clip retargeted
# from another rig, which cannot be committed) instead of the wave.
motion="${HAHA_TEST_ANIMATION_MOTION:-$work/wave.npz}"
[ -n "${HAHA_TEST_ANIMATION_MOTION:-}" ] || "$haha" motion --kind wave --frames 40 --fps 30 --out "$motion" >/dev/null
pack=(--mesh-compression none --no-pose-correctives --animation "$motion")
if [ -n "$run" ]; then
  "$haha" pack "$run" --out "$work/anim.glb" "${pack[@]}" >/dev/null
else
  tiny_avatar "$haha" "$work" "$work/anim.glb" "${pack[@]}"
fi
exec "$blender" -b --factory-startup --python-exit-code 1 --python "$root/tests/interop/blender_animation.py" -- \
  "$work/anim.glb" "$python_dir" "$addons"
