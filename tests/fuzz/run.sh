#!/usr/bin/env bash
# Fuzzes one reader: tests/fuzz/run.sh TARGET SECONDS [extra afl-fuzz options]
# Builds the AFL binaries if needed, writes seeds on first use, then runs afl-fuzz
# niced, with a memory cap (AFL_MEM_MB, default 2048: an allocation past the
# readers' caps shows up as a crash) and a hang timeout (AFL_TIMEOUT_MS, default
# 2000). Findings land in out/TARGET/default/{crashes,hangs}.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
target="${1:?usage: run.sh TARGET SECONDS}"
seconds="${2:?usage: run.sh TARGET SECONDS}"
shift 2
targets="scene_json bundle exr hdr png jpeg obj ply vol raw_grid vdb"
[[ " $targets " == *" $target "* ]] || { echo "unknown target $target; one of: $targets" >&2; exit 2; }
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$here/target}"
cd "$here"
cargo afl build --release
bin="$CARGO_TARGET_DIR/release"
[[ -d corpus/$target ]] || "$bin/make_seeds" corpus
mkdir -p "out/$target"
# No CPU binding (the machine is shared); start fresh unless AFL_RESUME=1.
export AFL_NO_AFFINITY=1 AFL_SKIP_CPUFREQ=1 AFL_NO_UI=1
# Caught panics (see src/bin) would print a backtrace each: slow, and not wanted.
unset RUST_BACKTRACE
input=(-i "corpus/$target")
[[ "${AFL_RESUME:-0}" == 1 ]] && input=(-i -)
exec nice -n 10 cargo afl fuzz "${input[@]}" -o "out/$target" \
  -m "${AFL_MEM_MB:-2048}" -t "${AFL_TIMEOUT_MS:-2000}" -V "$seconds" "$@" \
  "$bin/$target"
