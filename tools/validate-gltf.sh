#!/usr/bin/env bash
# Validate .glb files with the Khronos glTF validator: 0 errors and 0 warnings, or exit 1.
# Installs the npm package `gltf-validator` into $GLTF_VALIDATOR_DIR (default
# target/gltf-validator) on first use. Needs node and npm.
#   tools/validate-gltf.sh FILE.glb [FILE.glb …]
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
dir="${GLTF_VALIDATOR_DIR:-$here/../target/gltf-validator}"
if [ ! -d "$dir/node_modules/gltf-validator" ]; then
  mkdir -p "$dir"
  npm install --prefix "$dir" --no-audit --no-fund --silent gltf-validator@2.0.0-dev.3.10 >&2
fi
GLTF_VALIDATOR_DIR="$dir/node_modules" node "$here/view/validate.mjs" "$@"
