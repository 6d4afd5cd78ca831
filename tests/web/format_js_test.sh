#!/usr/bin/env bash
# CTest `js_three_plugin` / `js_babylon_extension` / `js_reader` (label slow): the three.js
# GLTFLoader plugin and the Babylon.js glTF loader extension of format/js in headless Chromium
# against `haha render` (format/js/test/{three_plugin,babylon_extension}_test.mjs), and the
# engine-free reader on rewritten copies of the avatar in Node (format/js/test/reader_test.mjs).
# `js_garment_reader`: the reader on an avatar with a garment, version 3 and 4 layouts
# (format/js/test/garment_reader_test.mjs; no training, no Chromium).
# `js_spark_skinning`: a --khr-gaussian-splatting pack's skinned splats in Spark's SplatSkinning
# against linear blend skinning and the exact reposing (format/js/test/spark_skinning_test.mjs).
# `js_coverage`: the mesh coverage (COLOR_0 alpha, alphaMode MASK) of the fuzz corpus' seeds in
# the reader, and the mesh cut with the Gaussians showing through in three.js and Babylon.js
# (format/js/test/coverage_test.mjs; no training).
# Usage: format_js_test.sh three|babylon|reader|garment|spark|coverage HAHA WORKDIR [RUN_FROM]
#        format_js_test.sh fixture HAHA RUN_FROM   (CTest fixture js_avatar: trains the tiny
#        avatar run once into RUN_FROM/run; the tests given RUN_FROM use it instead of training)
# Exits 77 (CTest SKIP_RETURN_CODE) with the reason printed when node, Chromium or
# format/js/node_modules are missing (scripts/install-deps.sh installs them).
set -euo pipefail
engine="$1"
haha="$2"
work="$3"
run_from="${4:-}"
root=$(cd "$(dirname "$0")/../.." && pwd)
js="$root/format/js"
case "$engine" in
  three) script="$js/test/three_plugin_test.mjs"; name=js_three_plugin; need=(three playwright-core pngjs fflate) ;;
  babylon) script="$js/test/babylon_extension_test.mjs"; name=js_babylon_extension; need=(babylonjs babylonjs-loaders three playwright-core pngjs fflate) ;;
  reader) script="$js/test/reader_test.mjs"; name=js_reader; need=(three fflate) ;;
  garment) script="$js/test/garment_reader_test.mjs"; name=js_garment_reader; need=(three fflate) ;;
  spark) script="$js/test/spark_skinning_test.mjs"; name=js_spark_skinning; need=(@sparkjsdev/spark three playwright-core pngjs fflate) ;;
  coverage) script="$js/test/coverage_test.mjs"; name=js_coverage; need=(three babylonjs babylonjs-loaders playwright-core pngjs fflate) ;;
  fixture) script="$js/test/make_run.mjs"; name=js_avatar; need=() ;;
  *) echo "format_js_test.sh: unknown engine '$engine' (three, babylon, reader, garment, spark or coverage)"; exit 2 ;;
esac
chromium="${HAHA_CHROMIUM:-/usr/bin/chromium}"
skip() { echo "SKIP $name: $*"; exit 77; }
command -v node >/dev/null 2>&1 || skip "node is not installed"
[ "$engine" = reader ] || [ "$engine" = garment ] || [ "$engine" = fixture ] || [ -x "$chromium" ] || skip "no Chromium at $chromium (apt-get install chromium, or set HAHA_CHROMIUM)"
for p in "${need[@]+"${need[@]}"}"; do
  [ -d "$js/node_modules/$p" ] || skip "format/js/node_modules/$p is missing: npm ci --prefix format/js"
done
export OMP_WAIT_POLICY="${OMP_WAIT_POLICY:-passive}"
[ "$engine" = fixture ] && exec node "$script" --haha "$haha" --work "$work"
rm -rf "$work"
mkdir -p "$work"
exec node "$script" --haha "$haha" --work "$work" --chromium "$chromium" ${run_from:+--run-from "$run_from"}
