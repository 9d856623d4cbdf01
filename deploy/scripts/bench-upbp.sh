#!/usr/bin/env bash
# Equal-time comparison of the volumetric methods (issues 21 and 39): volpath, bpt,
# vpm, ppb, vcm, upbp with all techniques, and each upbp volume technique with surface
# photons (a volume technique alone renders only light scattered last in a medium),
# SECONDS each, SEEDS times with seeds 0 .. SEEDS-1, on the scenes given (default:
# fog-cornell, spot-shaft, smoke-room, glass-sphere-fog, dense-cornell, mixed-fog),
# against one reference per scene of REFERENCE seconds, rendered first by REF_ALG
# (default volpath; bpt converges faster on these scenes and is as unbiased) with
# seed REF_SEED (default 1000, shared with no run). Writes OUT/<scene>/reference.exr,
# OUT/<scene>/seed<S>/ (bench.csv, rmse_vs_time.png, the final images) and
# OUT/<scene>/seed<S>.txt, then prints per scene and algorithm the median RMSE over the
# seeds, its min-max spread, and the same without the lamp pixels, with the
# reference's own estimated noise taken out where it has a variance layer (as this
# script renders it)
# (deploy/scripts/equal_time_summary.py, which needs numpy and OpenEXR; PYTHON names
# the interpreter that has them, default python3): OUT/summary.txt and OUT/summary.csv.
#
#   [SEEDS=4] deploy/scripts/bench-upbp.sh [OUT] [SECONDS] [REFERENCE] [SCENE...]
#
# UPBP is appended to every upbp entry (e.g. UPBP=:light_paths=0.25); ALGS replaces
# the list of algorithms; THREADS=N runs every render on N threads (e.g. THREADS=1 under
# `taskset -c 1` to leave a core free); REFS=DIR uses DIR/<scene>/reference.exr where it exists (a
# reference already in OUT/<scene>/ is reused too). The issue's two budgets share
# their references that way:
#
#   deploy/scripts/bench-upbp.sh OUT60 60 600 && REFS=OUT60 deploy/scripts/bench-upbp.sh OUT240 240
set -euo pipefail
cd "$(dirname "$0")/../.."
out=${1:-bench-upbp}
secs=${2:-60}
ref=${3:-600}
shift $(( $# < 3 ? $# : 3 ))
scenes=("$@")
if [ ${#scenes[@]} -eq 0 ]; then
    scenes=(fog-cornell spot-shaft smoke-room glass-sphere-fog dense-cornell mixed-fog)
fi
seeds=${SEEDS:-4}
u=${UPBP:-}
algs="volpath,bpt,vpm,ppb,vcm,upbp$u"
for t in surf+pp3d surf+pb2d surf+bb1d bpt; do
    algs="$algs,upbp:techniques=$t$u"
done
algs=${ALGS:-$algs}
cargo build --release --quiet
c=./target/release/caustic
threads=()
if [ -n "${THREADS:-}" ]; then
    threads=(--threads "$THREADS")
fi
for scene in "${scenes[@]}"; do
    dir=$out/$scene
    mkdir -p "$dir"
    if [ -n "${REFS:-}" ] && [ -f "$REFS/$scene/reference.exr" ]; then
        cp "$REFS/$scene/reference.exr" "$dir/reference.exr"
    elif [ ! -f "$dir/reference.exr" ]; then
        "$c" reference "scenes/media/$scene.json" -a "${REF_ALG:-volpath}" --time "$ref" \
            --seed "${REF_SEED:-1000}" "${threads[@]}" --variance-layer -o "$dir/reference.exr"
    fi
    for seed in $(seq 0 $((seeds - 1))); do
        "$c" bench "scenes/media/$scene.json" --algorithms "$algs" --time "$secs" \
            --seed "$seed" "${threads[@]}" --reference "$dir/reference.exr" -o "$dir/seed$seed" \
            | tee "$dir/seed$seed.txt"
    done
done
"${PYTHON:-python3}" deploy/scripts/equal_time_summary.py "$out" "${scenes[@]}" \
    | tee "$out/summary.txt"
