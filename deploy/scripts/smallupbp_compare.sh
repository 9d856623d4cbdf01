#!/usr/bin/env bash
# caustic's upbp against SmallUPBP (Křivánek et al. 2014's reference code) on one of
# SmallUPBP's built-in scenes, rebuilt in caustic's format, 256 x 256, THREADS threads (default 2), path
# length 10:
#   SCENE=1  scenes/media/smallupbp-scene1.json: the Cornell box with a sphere of
#            isotropic medium (sigma_s 0.9), lit from the small ceiling lamp;
#   SCENE=2  scenes/media/smallupbp-scene2.json: a mirror sphere, a glossy floor and a
#            weak isotropic medium (sigma_s 0.1) filling all space, the camera's too.
#
#   [SCENE=1|2] [PBC=0.01] [THREADS=2] deploy/scripts/smallupbp_compare.sh SMALLUPBP_BINARY [OUT] [ROUNDS] [SECONDS] [REFERENCE]
#
# THREADS sets both programs' thread count (e.g. THREADS=1 under `taskset -c 1`).
#
# 1. CPU seconds per iteration (user + sys over a fixed iteration count) of each
#    technique set, bpt, pp3d, pb2d, bb1d and all, for both programs, alternately,
#    ROUNDS times: OUT/timing.csv, and the medians with caustic / SmallUPBP ratios in
#    OUT/timing-summary.txt.
# 2. Equal time (skipped when SECONDS is 0): upbp_all for SECONDS of wall time in each
#    program, plus caustic's upbp at its own defaults (adaptive selection), with
#    `selection: all` at its own defaults otherwise, its bpt and volpath, against a
#    caustic volpath reference of REFERENCE seconds (another seed): OUT/equal-time.txt.
#    SmallUPBP checks its clock between iterations, so it may overrun SECONDS by up to
#    one iteration: its log's "done in" line is the time it took.
#
# Both programs run with the UPBP paper's settings: long query beams, short photon
# beams, and photon beams from the first PBC of each iteration's light paths
# (SmallUPBP's -pbc -PBC, caustic's beam_paths; the paper's runs used 0.6-2 %;
# PBC=1, every path, is SmallUPBP's default and what issue 21's pass 2 measured).
# The radii are SmallUPBP's defaults on these scenes (both have scene radius 2.2171):
# surface 0.0015 x the scene radius with alpha 0.75; point x point, point x beam and
# beam x beam 0.001 x the scene radius, not reduced (alpha 1). Merges in media at
# every camera segment and vertex and every estimator in every pixel, as SmallUPBP
# does by default (caustic's merge_depth=all and selection=all; its own defaults,
# first and adaptive, are the "at its own defaults" run).
#
# SmallUPBP is not part of this repository. Build it outside it from its public
# sources (github.com/PetrVevoda/smallupbp): its bundled Embree 2.0 (CMake, built with
# -flax-vector-conversions -fpermissive, one missing _mm_castsi128_ps in sseb.h, and
# GCC's own __rdtsc/__rdpmc from <x86intrin.h>), Debian's libopenexr-dev (OpenEXR 3),
# and a small Makefile (g++ -O3 -fopenmp -msse4.2) instead of the Visual Studio
# project. Mend the MSVC-isms: backslashes and letter case in #include paths;
# sprintf_s/fscanf_s/sscanf_s/fopen_s and __int8/__int16/__int64 through a header
# passed with -include; __declspec(align(16)); missing typename and template<>;
# windows.h and the QueryPerformanceCounter timer; std::sqrtf; non-const references
# bound to temporaries. Its render loop times itself with clock(), which on Linux sums
# the CPU time of all threads: replace it with a wall clock (omp_get_wtime) so that -t
# is in wall seconds.
set -euo pipefail
sup=${1:?path to the SmallUPBP binary}
scene_id=${SCENE:-1}
pbc=${PBC:-0.01}
out=${2:-smallupbp-compare-scene$scene_id}
rounds=${3:-3}
secs=${4:-60}
ref=${5:-600}
threads=${THREADS:-2}
case $scene_id in
    1 | 2) ;;
    *) echo "SCENE must be 1 or 2, not $scene_id" >&2; exit 2 ;;
esac
cd "$(dirname "$0")/../.."
cargo build --release --quiet
c=$PWD/target/release/caustic
scene=$PWD/scenes/media/smallupbp-scene$scene_id.json
mkdir -p "$out"
cd "$out"
p=(--param radius=0.003326 --param alpha=0.75
   --param medium_radius=0.002217 --param medium_alpha=1
   --param pb2d_radius=0.002217 --param pb2d_alpha=1
   --param bb1d_radius=0.002217 --param bb1d_alpha=1
   --param beam_paths="$pbc" --param query_beams=long --param max_depth=10
   --param merge_depth=all --param selection=all)
s=(-s "$scene_id" -r 256x256 -th "$threads" -l 10 -qbt L -pbt S -pbc "-$pbc")
measure() { # command... -> "wall_s,cpu_s" (cpu = user + sys)
    /usr/bin/time -f "%e %U %S" -o time.txt "$@" > /dev/null 2>&1
    awk '{ printf "%s,%.2f\n", $1, $2 + $3 }' time.txt
}
row() { # round program technique iterations "wall,cpu"
    echo "$1,$2,$3,$4,$5,$(awk -v c="${5#*,}" -v n="$4" 'BEGIN { printf "%.4f", c / n }')" >> timing.csv
}
echo "round,program,technique,iterations,wall_s,cpu_s,cpu_s_per_iteration" > timing.csv
for round in $(seq "$rounds"); do
    for entry in bpt:10 pp3d:10 pb2d:10 bb1d:4 all:4; do
        t=${entry%:*}
        n=${entry#*:}
        row "$round" caustic "$t" "$n" "$(measure "$c" render "$scene" -a upbp --spp "$n" \
            --threads "$threads" "${p[@]}" --param techniques="$t" -o "caustic-$t.exr")"
        row "$round" smallupbp "$t" "$n" "$(measure "$sup" "${s[@]}" -a "upbp_$t" -i "$n" \
            -o "smallupbp-$t.exr")"
    done
done
python3 - timing.csv <<'PY' | tee timing-summary.txt
import csv, statistics, sys
rows = list(csv.DictReader(open(sys.argv[1])))
med = {}
for r in rows:
    med.setdefault((r["program"], r["technique"]), []).append(float(r["cpu_s_per_iteration"]))
print("technique  caustic_cpu_s/it  smallupbp_cpu_s/it  ratio")
for t in dict.fromkeys(r["technique"] for r in rows):
    a = statistics.median(med[("caustic", t)])
    b = statistics.median(med[("smallupbp", t)])
    print(f"{t:<10} {a:16.3f} {b:19.3f} {a / b:6.2f}")
PY
[ "$secs" = 0 ] && exit 0
"$c" render "$scene" -a upbp --time "$secs" --threads "$threads" "${p[@]}" -o caustic-all-eq.exr
"$sup" "${s[@]}" -a upbp_all -t "$secs" -o smallupbp-all-eq.exr > smallupbp-all-eq.log
"$c" render "$scene" -a upbp --time "$secs" --threads "$threads" --param max_depth=10 \
    --param selection=adaptive -o caustic-upbp-defaults-eq.exr
"$c" render "$scene" -a upbp --time "$secs" --threads "$threads" --param max_depth=10 \
    --param selection=all -o caustic-upbp-all-defaults-eq.exr
"$c" render "$scene" -a upbp --time "$secs" --threads "$threads" --param max_depth=10 \
    --param techniques=bpt -o caustic-bpt-eq.exr
"$c" render "$scene" -a volpath --time "$secs" --threads "$threads" --param max_depth=10 -o caustic-volpath-eq.exr
"$c" render "$scene" -a volpath --time "$ref" --threads "$threads" --seed 7 --param max_depth=10 -o reference.exr
for f in caustic-all-eq smallupbp-all-eq caustic-upbp-defaults-eq caustic-upbp-all-defaults-eq caustic-bpt-eq caustic-volpath-eq; do
    echo "$f $("$c" diff "$f.exr" reference.exr | tr '\n' ' ')"
done | tee equal-time.txt
