#!/usr/bin/env bash
# Equal-time comparison of the many-light methods against volpath (issue 20):
# every vrl sampler, vpl in each clamp mode, vbl and volpath, SECONDS each, on the
# scenes given (default: the forward-scattering ones), against a volpath reference of
# REFERENCE seconds rendered first with another seed. Writes OUT/<scene>/bench.csv,
# rmse_vs_time.png and the final images.
#
#   deploy/scripts/bench-many-lights.sh [OUT] [SECONDS] [REFERENCE] [SCENE...]
#
# MANY is appended to every many-light entry, e.g. MANY=:light_paths=0.25 for scenes
# lit through small openings, where most light paths never enter.
set -euo pipefail
cd "$(dirname "$0")/../.."
out=${1:-bench-many-lights}
secs=${2:-60}
ref=${3:-600}
shift $(( $# < 3 ? $# : 3 ))
scenes=("$@")
if [ ${#scenes[@]} -eq 0 ]; then
    scenes=(spot-shaft vrl-cornell-g09 vrl-point-g09)
fi
m=${MANY:-}
algs="volpath,vpl$m,vpl:clamp=clamp$m,vpl:clamp=compensate$m"
for s in uniform exponential uniform_equiangular joint_simple joint_advanced; do
    algs="$algs,vrl:sampler=$s$m"
done
algs="$algs,vbl$m"
cargo build --release --quiet
mkdir -p "$out"
for scene in "${scenes[@]}"; do
    ./target/release/caustic bench "scenes/media/$scene.json" --algorithms "$algs" \
        --time "$secs" --reference-from "volpath:$ref" -o "$out/$scene" \
        | tee "$out/$scene.txt"
done
