#!/usr/bin/env bash
# A self-contained Blender add-on zip: Preferences > Add-ons > Install (or
# bpy.ops.preferences.addon_install(filepath=ZIP)) + enable, and it imports avatars with no
# HAHA_* variable and no install prefix.
#   scripts/blender-addon-zip.sh RUNTIME_LIBRARY OUT.zip [BLENDER]
# Layout: io_import_haha_avatar/ (the add-on), io_import_haha_avatar/haha/ (the Python
# package, libhaha_runtime.so beside it) and io_import_haha_avatar/libs/: the libraries the
# runtime needs that Blender's own dependencies (ldd of BLENDER, default `blender`) do not
# already bring, preloaded by the add-on (runtime_link.py). `cmake --install` is unchanged.
set -euo pipefail
lib="$1"
out="$2"
blender_bin=$(command -v "${3:-blender}" || true)
src=$(cd "$(dirname "$0")/.." && pwd)/python
stage=$(mktemp -d)
trap 'rm -rf "$stage"' EXIT
addon="$stage/io_import_haha_avatar"
mkdir -p "$addon/haha" "$addon/libs"
cp "$src"/blender/io_import_haha_avatar/*.py "$addon/"
cp "$src"/haha/*.py "$addon/haha/"
cp "$(readlink -f "$lib")" "$addon/haha/libhaha_runtime.so"
if [ -n "$blender_bin" ]; then
  ldd "$blender_bin" | awk '/=>/ {print $3}' | xargs -r -n1 readlink -f | sort -u > "$stage/blender_libs"
else
  echo "note: no Blender to compare with; bundling every library outside glibc" >&2
  : > "$stage/blender_libs"
fi
ldd "$lib" | awk '/=>/ {print $1, $3}' | while read -r soname path; do
  case "$soname" in libc.so*|libm.so*|libpthread.so*|libdl.so*|librt.so*|ld-linux*) continue ;; esac
  grep -qx "$(readlink -f "$path")" "$stage/blender_libs" || cp "$(readlink -f "$path")" "$addon/libs/$soname"
done
rm -f "$stage/blender_libs"
out_abs=$(cd "$(dirname "$out")" && pwd)/$(basename "$out")
rm -f "$out_abs"
(cd "$stage" && zip -qr "$out_abs" io_import_haha_avatar -x '*/__pycache__/*')
echo "$out_abs: $(ls "$addon/libs" | tr '\n' ' ')($(du -h "$out_abs" | cut -f1))"
