#!/usr/bin/env bash
# CTest `gltf_transform_roundtrip` (label slow): HAHA avatars through glTF-Transform with the
# HAHA_gaussian_avatar extension class (format/js/gltf-transform), rendered by `haha render`
# against the input (tests/interop/gltf_transform_test.mjs). Usage: gltf_transform_test.sh HAHA WORKDIR
# Exits 77 (CTest SKIP_RETURN_CODE) with the reason printed when node or the npm packages are
# missing (scripts/install-deps.sh installs them: npm ci --prefix format/js/gltf-transform).
set -euo pipefail
haha="$1"
work="$2"
root=$(cd "$(dirname "$0")/../.." && pwd)
skip() { echo "SKIP gltf_transform_roundtrip: $*"; exit 77; }
command -v node >/dev/null 2>&1 || skip "node is not installed"
[ -d "$root/format/js/gltf-transform/node_modules/@gltf-transform/core" ] \
  || skip "format/js/gltf-transform/node_modules is missing: npm ci --prefix format/js/gltf-transform"
rm -rf "$work"
mkdir -p "$work"
export OMP_WAIT_POLICY="${OMP_WAIT_POLICY:-passive}"
exec node "$root/tests/interop/gltf_transform_test.mjs" --haha "$haha" --work "$work"
