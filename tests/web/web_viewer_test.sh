#!/usr/bin/env bash
# CTest `web_viewer` (label slow): the three.js viewer of samples/web in headless Chromium
# against `haha render` (samples/web/test/viewer_test.mjs). Usage: web_viewer_test.sh HAHA WORKDIR [AVATAR]
# (AVATAR: a .glb to show instead of the tiny avatar the test trains)
# Exits 77 (CTest SKIP_RETURN_CODE) with the reason printed when node, Chromium or the
# viewer's node_modules are missing (scripts/install-deps.sh installs them).
set -euo pipefail
haha="$1"
work="$2"
avatar=("${@:3:1}")
root=$(cd "$(dirname "$0")/../.." && pwd)
web="$root/samples/web"
chromium="${HAHA_CHROMIUM:-/usr/bin/chromium}"
skip() { echo "SKIP web_viewer: $*"; exit 77; }
command -v node >/dev/null 2>&1 || skip "node is not installed"
[ -x "$chromium" ] || skip "no Chromium at $chromium (apt-get install chromium, or set HAHA_CHROMIUM)"
[ -d "$web/node_modules/playwright-core" ] && [ -d "$web/node_modules/three" ] && [ -d "$web/node_modules/pngjs" ] \
  || skip "samples/web/node_modules is missing: npm ci --prefix samples/web"
rm -rf "$work"
mkdir -p "$work"
export OMP_WAIT_POLICY="${OMP_WAIT_POLICY:-passive}"
exec node "$web/test/viewer_test.mjs" --haha "$haha" --work "$work" --chromium "$chromium" ${avatar[@]+--avatar "${avatar[0]}"}
