#!/usr/bin/env bash
# caustic's upbp against SmallUPBP (Křivánek et al. 2014's reference code) on
# SmallUPBP's scene 1 (scenes/media/smallupbp-scene1.json: the Cornell box with a
# sphere of isotropic medium, sigma_s 0.9), 256 x 256, 2 threads, path length 10.
#
#   deploy/scripts/smallupbp_compare.sh SMALLUPBP_BINARY [OUT] [ROUNDS] [SECONDS] [REFERENCE]
#
# 1. CPU seconds per iteration (user + sys over a fixed iteration count) of each
#    technique set, bpt, pp3d, pb2d, bb1d and all, for both programs, alternately,
#    ROUNDS times: OUT/timing.csv.
# 2. Equal time: upbp_all for SECONDS of wall time in each program, plus caustic's
#    upbp at its own defaults, its bpt and volpath, against a caustic volpath
#    reference of REFERENCE seconds (another seed): OUT/equal-time.txt.
#
# caustic runs with SmallUPBP's defaults on this scene: surface radius 0.0015 x the
# scene radius (2.2171) with alpha 0.75; point x point, point x beam and beam x beam
# radius 0.001 x the scene radius, not reduced (alpha 1); every light path's segments
# become photon beams; long query beams, short photon beams.
#
# SmallUPBP is not part of this repository. Build it outside it from its public
# sources (github.com/PetrVevoda/smallupbp): its bundled Embree 2.0, Debian's
# libopenexr-dev, a small Makefile instead of the Visual Studio project, and mending
# the MSVC-isms (sscanf_s/fopen_s, __declspec(align), missing typename and
# template<>, windows.h). Its timer uses clock(), which on Linux sums the CPU time of
# all threads: replace it with a wall clock so that -t is in wall seconds.
set -euo pipefail
sup=${1:?path to the SmallUPBP binary}
out=${2:-smallupbp-compare}
rounds=${3:-3}
secs=${4:-60}
ref=${5:-600}
cd "$(dirname "$0")/../.."
cargo build --release --quiet
c=$PWD/target/release/caustic
scene=$PWD/scenes/media/smallupbp-scene1.json
mkdir -p "$out"
cd "$out"
p=(--param radius=0.003326 --param alpha=0.75
   --param medium_radius=0.002217 --param medium_alpha=1
   --param pb2d_radius=0.002217 --param pb2d_alpha=1
   --param bb1d_radius=0.002217 --param bb1d_alpha=1
   --param beam_paths=1 --param query_beams=long --param max_depth=10)
cpu() { # command... -> CPU seconds (user + sys)
    /usr/bin/time -f "%U %S" -o cpu.txt "$@" > /dev/null 2>&1
    awk '{ print $1 + $2 }' cpu.txt
}
echo "round,program,technique,iterations,cpu_s,cpu_s_per_iteration" > timing.csv
for round in $(seq "$rounds"); do
    for entry in bpt:10 pp3d:10 pb2d:10 bb1d:2 all:2; do
        t=${entry%:*}
        n=${entry#*:}
        s=$(cpu "$c" render "$scene" -a upbp --spp "$n" --threads 2 "${p[@]}" \
            --param techniques="$t" -o "caustic-$t.exr")
        echo "$round,caustic,$t,$n,$s,$(echo "$s / $n" | bc -l)" >> timing.csv
        s=$(cpu "$sup" -s 1 -a "upbp_$t" -r 256x256 -th 2 -i "$n" -o "smallupbp-$t.exr")
        echo "$round,smallupbp,$t,$n,$s,$(echo "$s / $n" | bc -l)" >> timing.csv
    done
done
"$c" render "$scene" -a upbp --time "$secs" --threads 2 "${p[@]}" -o caustic-all-eq.exr
"$sup" -s 1 -a upbp_all -r 256x256 -th 2 -t "$secs" -o smallupbp-all-eq.exr > smallupbp-all-eq.log
"$c" render "$scene" -a upbp --time "$secs" --threads 2 --param max_depth=10 -o caustic-upbp-defaults-eq.exr
"$c" render "$scene" -a upbp --time "$secs" --threads 2 --param max_depth=10 \
    --param techniques=bpt -o caustic-bpt-eq.exr
"$c" render "$scene" -a volpath --time "$secs" --threads 2 --param max_depth=10 -o caustic-volpath-eq.exr
"$c" render "$scene" -a volpath --time "$ref" --threads 2 --seed 7 --param max_depth=10 -o reference.exr
for f in caustic-all-eq smallupbp-all-eq caustic-upbp-defaults-eq caustic-bpt-eq caustic-volpath-eq; do
    echo "$f $("$c" diff "$f.exr" reference.exr | tr '\n' ' ')"
done | tee equal-time.txt
