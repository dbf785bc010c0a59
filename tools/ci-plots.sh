#!/usr/bin/env bash
# CI: render the debug plots of a short crowd run, a checkpoint and several
# scenario presets into ci-plots/, then fail if any expected PNG is missing
# or blank (`slothsim plot-check`: decodes each PNG, wants >= 8 colours and no
# colour covering more than 99 % of it).
#
#   tools/ci-plots.sh [OUT_DIR]        # default ci-plots
#   SLOTHSIM=path/to/slothsim tools/ci-plots.sh
#
# Uses the release binary (build it first: cargo build --release).
set -euo pipefail
cd "$(dirname "$0")/.."

bin="${SLOTHSIM:-target/release/slothsim}"
out="${1:-ci-plots}"
if [[ ! -x "$bin" ]]; then
    echo "ci-plots: $bin not found; run cargo build --release first" >&2
    exit 2
fi
rm -rf "$out"
mkdir -p "$out"
expected=()

# A short crowd run (and its checkpoint re-drawn by `slothsim plot`).
"$bin" run --sloths 200 --seconds 10 --out "$out/run" --save-state "$out/run/state.bin"
expected+=("$out/run/topdown.png" "$out/run/gait.png" "$out/run/frame_times.png")
"$bin" plot --state "$out/run/state.bin" --out "$out/plot"
expected+=("$out/plot/topdown.png")

# Scenario presets from the matrix. Exit 1 (judged a fail) still plots; 2 is an error.
scenario() {
    local dir="$1"
    shift
    local rc=0
    "$bin" scenario "$@" --out "$out/scenario/$dir" || rc=$?
    if ((rc > 1)); then
        echo "ci-plots: slothsim scenario $* failed with exit $rc" >&2
        exit "$rc"
    fi
    for p in topdown side gait frame_times; do
        expected+=("$out/scenario/$dir/$p.png")
    done
}
scenario turn-135 turn --angle 135
scenario height_change-180 height_change --angle 180
scenario branch_trunk-150 branch_trunk --angle 150
scenario parallel parallel
scenario trunk-up trunk --variant up
scenario trunk-down trunk --variant down
scenario pole pole
scenario branch_end-10 branch_end --angle 10

"$bin" plot-check "${expected[@]}"
echo "ci-plots: ${#expected[@]} plots in $out"
