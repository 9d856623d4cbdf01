#!/usr/bin/env bash
# Per-range overhead of a worker pool on a large image, for the scaling model in the
# README: a coordinator (`serve --nats`, RUST_LOG=caustic=debug) and two 1-thread
# workers render the Cornell box at WIDTH x HEIGHT; the coordinator's debug log gives,
# per range, fetch_s (object store to memory, on the NATS runtime, up to 4 at once),
# decode_s and merge_s (both on the scheduler thread). Prints their medians, the
# result size, the median unit length, and the worker counts at which the
# coordinator's serial part (decode + merge) and its fetching would saturate.
#
#   deploy/scripts/bench-pool-scaling.sh [WIDTH] [HEIGHT] [SPP]
#   deploy/scripts/bench-pool-scaling.sh 1920 1080 24
#
# Needs a release build (cargo build --release) and python3; installs nats-server
# with install-nats-server.sh.
set -euo pipefail
cd "$(dirname "$0")/../.."
W=${1:-1920}; H=${2:-1080}; SPP=${3:-24}
BIN=target/release/caustic
NATS=$(deploy/scripts/install-nats-server.sh)
TMP=$(mktemp -d)
PIDS=()
cleanup() { kill "${PIDS[@]}" 2>/dev/null || true; rm -rf "$TMP"; }
trap cleanup EXIT

"$NATS" -js -a 127.0.0.1 -p 14932 -sd "$TMP/nats" >/dev/null 2>&1 & PIDS+=($!)
sleep 1
NO_COLOR=1 RUST_LOG=caustic=debug "$BIN" serve --nats nats://127.0.0.1:14932 --data-dir "$TMP/pool" \
    --addr 127.0.0.1:14988 --grpc-addr 127.0.0.1:14989 >"$TMP/coordinator.log" 2>&1 & PIDS+=($!)
for w in 1 2; do
    "$BIN" worker --nats nats://127.0.0.1:14932 --threads 1 --name "w$w" --cache-dir "$TMP/w$w" >/dev/null 2>&1 & PIDS+=($!)
done
sleep 2

python3 - http://127.0.0.1:14988 "$W" "$H" "$SPP" <<'PY'
import json, sys, time, urllib.request
url, w, h, spp = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
scene = json.load(open("scenes/cornell-box.json"))
scene["film"]["width"], scene["film"]["height"] = w, h
post = lambda path, body: json.load(urllib.request.urlopen(urllib.request.Request(
    url + path, json.dumps(body).encode(), {"content-type": "application/json"})))
sid = post("/v1/scenes", scene)["id"]
job = post("/v1/jobs", {"scene": sid, "halt": {"spp": spp}, "snapshot_every": {"iterations": 10**9}})
while job["state"] not in ("completed", "failed", "cancelled"):
    time.sleep(0.5)
    job = json.load(urllib.request.urlopen(url + "/v1/jobs/" + job["id"]))
assert job["state"] == "completed", job
print(f"job: cornell-box {w}x{h} pt {spp} spp on 2 workers x 1 thread: "
      f"{job['finished_at'] - job['created_at']:.1f} s")
PY

python3 - "$TMP/coordinator.log" "$W" "$H" "$SPP" <<'PY'
import re, statistics, sys
log = open(sys.argv[1]).read()
w, h, spp = int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
def values(field):
    return [float(v) for v in re.findall(field + r"=([0-9.eE+-]+)", log)]
fetch, decode, merge = values("fetch_s"), values("decode_s"), values("merge_s")
med = lambda xs: statistics.median(xs) if xs else float("nan")
ranges = len(merge)
sizes = values("bytes")
print(f"ranges: {ranges}; result per range: {96 * w * h / 1e6:.0f} MB of exact sums "
      f"(sums and second moments), {med(sizes) / 1e6:.1f} MB as sent (median)")
print(f"median fetch_s {med(fetch):.3f} (min {min(fetch):.3f}, max {max(fetch):.3f})")
print(f"median decode_s {med(decode):.3f}, merge_s {med(merge):.3f}")
serial = med(decode) + med(merge)
# A unit is about 2 s of one worker's time, but never less than one iteration.
for unit in (2.0, 20.0):
    print(f"units of {unit:.0f} s: decode+merge saturates the scheduler thread at "
          f"{unit / serial:.0f} workers; 4 concurrent fetches at {4 * unit / med(fetch):.0f}")
PY
