# Sourced by the Blender tests (tests/interop/blender_test.sh, tests/python/blender_addon_test.sh):
#   blender_setup NAME WORKDIR   skips (exit 77, CTest SKIP_RETURN_CODE) with the reason printed
#                                when Blender or its numpy is missing, then makes an empty WORKDIR
#   tiny_avatar HAHA WORKDIR OUT.glb [haha pack options]
#                                the tiny trained avatar of the interop tests, packed into OUT.glb
#                                (TINY_TRAIN_EXTRA: more `haha train` key=value settings)
#   given_or_tiny_avatar HAHA WORKDIR [AVATAR.glb | --garment]
#                                prints AVATAR.glb, or without one makes WORKDIR/avatar.glb
#                                (tiny_avatar; its run stays in WORKDIR/run) and prints that;
#                                --garment: the tiny avatar trained with a skirt
# Blender is not part of scripts/install-deps.sh (it is large).
blender="${HAHA_BLENDER:-blender}"
export OMP_WAIT_POLICY="${OMP_WAIT_POLICY:-passive}"

blender_setup() {
  local name="$1" work="$2"
  skip() { echo "SKIP $name: $*"; exit 77; }
  command -v "$blender" >/dev/null 2>&1 ||
    skip "Blender is not installed (apt-get install --no-install-recommends blender python3-numpy, or set HAHA_BLENDER)"
  # Blender's glTF importer and the add-on need numpy (Debian: python3-numpy, a Recommends of blender).
  "$blender" -b --factory-startup --python-exit-code 1 --python-expr "import numpy" >/dev/null 2>&1 ||
    skip "Blender's Python has no numpy (apt-get install python3-numpy)"
  rm -rf "$work"
  mkdir -p "$work"
}

tiny_avatar() {
  local haha="$1" work="$2" out="$3"
  shift 3
  "$haha" synth --out "$work/data" --frames 8 --test-frames 2 --size 64 >/dev/null
  "$haha" train --data "$work/data" --out "$work/run" --preset tiny resolution=64 s1.steps=50 s1.densify.from=10 \
    s1.densify.until=40 s1.densify.every=20 s2.steps=30 s2.texture_size=64 s3.steps=30 s3.prune_every=20 \
    log_every=1000 ${TINY_TRAIN_EXTRA:-} >/dev/null
  "$haha" pack "$work/run" --out "$out" "$@" >/dev/null
}

given_or_tiny_avatar() {
  local haha="$1" work="$2" given="${3:-}"
  if [ -n "$given" ] && [ "$given" != --garment ]; then
    echo "$given"
    return
  fi
  [ "$given" = --garment ] && local TINY_TRAIN_EXTRA="s0.garment.mode=skirt"
  tiny_avatar "$haha" "$work" "$work/avatar.glb"
  echo "$work/avatar.glb"
}
