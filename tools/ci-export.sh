#!/usr/bin/env bash
# CI: the recorded glTF of a 200-sloth 10 s run (every sloth recorded) and of a
# scenario (`--skinning clusters`, the default, and `--skinning lbs`) must pass the
# Khronos glTF validator with 0 errors and 0 warnings
# (tools/validate-gltf.sh), and Blender must render a frame of the scenario's
# glb that shows the sloth (tools/view/render_glb.py: exit 1 when the sloth's
# pixels do not differ from the background). Installs Blender (Debian
# `blender`, + python3-numpy for its glTF importer) when missing.
#
#   tools/ci-export.sh [OUT_DIR]        # default ci-export
#   SLOTHSIM=path/to/slothsim tools/ci-export.sh
#
# Uses the release binary (build it first: cargo build --release).
set -euo pipefail
cd "$(dirname "$0")/.."

bin="${SLOTHSIM:-target/release/slothsim}"
out="${1:-ci-export}"
if [[ ! -x "$bin" ]]; then
    echo "ci-export: $bin not found; run cargo build --release first" >&2
    exit 2
fi
rm -rf "$out"
mkdir -p "$out"

"$bin" run --sloths 200 --seconds 10 --record all --no-plots --out "$out/run"
# Exit 1 (judged a fail) still records; 2 is an error.
"$bin" scenario turn --angle 90 --seconds 20 --no-plots --out "$out/turn" || [[ $? -eq 1 ]]
# Both skinning modes: the runs above use the default (clusters: corrective morph targets).
"$bin" scenario turn --angle 90 --seconds 20 --no-plots --skinning lbs --out "$out/turn-lbs" || [[ $? -eq 1 ]]
tools/validate-gltf.sh "$out/run/crowd.glb" "$out/turn/crowd.glb" "$out/turn-lbs/crowd.glb"

if ! command -v blender >/dev/null || ! python3 -c "import numpy" 2>/dev/null; then
    sudo=""
    [[ $(id -u) -eq 0 ]] || sudo="sudo"
    $sudo apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq blender python3-numpy >/dev/null
fi
status=0
blender -b --python-exit-code 1 --python tools/view/render_glb.py -- \
    "$out/turn/crowd.glb" "$out/turn/frame.png" 12 >"$out/turn/blender.log" 2>&1 || status=$?
grep -E "^(rendered|FAIL)|Traceback|Error:" "$out/turn/blender.log" || true
if [[ $status -ne 0 ]]; then
    echo "ci-export: the Blender render check failed (exit $status, log $out/turn/blender.log)" >&2
    exit 1
fi
echo "ci-export: ok ($out/turn/frame.png)"
