#!/usr/bin/env bash
# Equal-time comparison of the volumetric methods (issue 21): volpath, bpt, vpm, ppb,
# vcm, upbp with all techniques, and each upbp volume technique with surface photons
# (a volume technique alone renders only light scattered last in a medium), SECONDS
# each, on the scenes given (default: fog-cornell, spot-shaft, smoke-room,
# glass-sphere-fog, dense-cornell), against a volpath reference of REFERENCE seconds
# rendered first with another seed. Writes OUT/<scene>/bench.csv, rmse_vs_time.png and
# the final images.
#
#   deploy/scripts/bench-upbp.sh [OUT] [SECONDS] [REFERENCE] [SCENE...]
#
# UPBP is appended to every upbp entry (e.g. UPBP=:light_paths=0.25); ALGS replaces
# the list of algorithms; REFS=DIR reuses DIR/<scene>/reference.exr where it exists.
set -euo pipefail
cd "$(dirname "$0")/../.."
out=${1:-bench-upbp}
secs=${2:-60}
ref=${3:-600}
shift $(( $# < 3 ? $# : 3 ))
scenes=("$@")
if [ ${#scenes[@]} -eq 0 ]; then
    scenes=(fog-cornell spot-shaft smoke-room glass-sphere-fog dense-cornell)
fi
u=${UPBP:-}
algs="volpath,bpt,vpm,ppb,vcm,upbp$u"
for t in surf+pp3d surf+pb2d surf+bb1d bpt; do
    algs="$algs,upbp:techniques=$t$u"
done
algs=${ALGS:-$algs}
cargo build --release --quiet
mkdir -p "$out"
for scene in "${scenes[@]}"; do
    reference=(--reference-from "volpath:$ref")
    if [ -n "${REFS:-}" ] && [ -f "$REFS/$scene/reference.exr" ]; then
        reference=(--reference "$REFS/$scene/reference.exr")
    fi
    ./target/release/caustic bench "scenes/media/$scene.json" --algorithms "$algs" \
        --time "$secs" "${reference[@]}" -o "$out/$scene" \
        | tee "$out/$scene.txt"
done
