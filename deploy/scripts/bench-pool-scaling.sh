#!/usr/bin/env bash
# How far a worker pool scales on a large image, for the scaling section of the
# README. A coordinator (`serve --nats`, RUST_LOG=caustic=debug) renders the Cornell
# box at WIDTH x HEIGHT on a pool; its debug log gives, per range, fetch_s (object
# store to memory, on the NATS runtime, up to 8 at once), decode_s and fold_s (on its
# blocking threads, as many at once as it has cores), and per group of ranges merge_s
# (the one addition left on the scheduler thread). From their medians: the ranges per
# second the coordinator can take, and the unit length it picks for 10, 100 and 1,000
# workers (twice the intake they need).
#
#   deploy/scripts/bench-pool-scaling.sh [WIDTH] [HEIGHT] [SPP]
#       two real 1-thread workers render SPP iterations: the per-range costs, and the
#       worker counts the model says the coordinator saturates at.
#   SIMULATE=N [ITER_S=1] [SECONDS=120] deploy/scripts/bench-pool-scaling.sh W H
#       N simulated workers (`caustic worker --simulate`, one process: each waits
#       ITER_S seconds per iteration and returns a copy of one real result) for
#       SECONDS: the coordinator's measured intake against what N workers offer.
#       The image is wrong by design; only the rates mean anything.
#
# Needs a release build (cargo build --release) and python3; installs nats-server
# with install-nats-server.sh.
set -euo pipefail
cd "$(dirname "$0")/../.."
W=${1:-1920}; H=${2:-1080}; SPP=${3:-24}
SIMULATE=${SIMULATE:-0}; ITER_S=${ITER_S:-1}; SECONDS_RUN=${SECONDS:-120}
BIN=target/release/caustic
NATS=$(deploy/scripts/install-nats-server.sh)
TMP=$(mktemp -d)
PIDS=()
# LOG_COPY=FILE keeps the coordinator's log. The processes are waited for, so that a
# next run finds the ports free.
cleanup() {
    kill "${PIDS[@]}" 2>/dev/null || true
    wait "${PIDS[@]}" 2>/dev/null || true
    cp "$TMP/coordinator.log" "${LOG_COPY:-/dev/null}" 2>/dev/null || true
    rm -rf "$TMP"
}
trap cleanup EXIT

"$NATS" -js -a 127.0.0.1 -p 14932 -sd "$TMP/nats" >/dev/null 2>&1 & PIDS+=($!)
sleep 1
NO_COLOR=1 RUST_LOG=caustic=debug "$BIN" serve --nats nats://127.0.0.1:14932 --data-dir "$TMP/pool" \
    --addr 127.0.0.1:14988 --grpc-addr 127.0.0.1:14989 >"$TMP/coordinator.log" 2>&1 & PIDS+=($!)
if [ "$SIMULATE" -gt 0 ]; then
    "$BIN" worker --nats nats://127.0.0.1:14932 --threads 1 --name sim --cache-dir "$TMP/sim" \
        --simulate "$SIMULATE" --simulate-iteration-s "$ITER_S" >"$TMP/sim.log" 2>&1 & PIDS+=($!)
else
    for w in 1 2; do
        "$BIN" worker --nats nats://127.0.0.1:14932 --threads 1 --name "w$w" --cache-dir "$TMP/w$w" >/dev/null 2>&1 & PIDS+=($!)
    done
fi
sleep 2

python3 - http://127.0.0.1:14988 "$W" "$H" "$SPP" "$SIMULATE" "$ITER_S" "$SECONDS_RUN" <<'PY'
import json, sys, time, urllib.request
url, w, h, spp, sim, iter_s, secs = sys.argv[1], *map(int, sys.argv[2:6]), float(sys.argv[6]), float(sys.argv[7])
scene = json.load(open("scenes/cornell-box.json"))
scene["film"]["width"], scene["film"]["height"] = w, h
post = lambda path, body: json.load(urllib.request.urlopen(urllib.request.Request(
    url + path, json.dumps(body).encode(), {"content-type": "application/json"})))
get = lambda path: json.load(urllib.request.urlopen(url + path))
for _ in range(60):  # the coordinator is up once it answers
    try:
        get("/v1/jobs")
        break
    except OSError:
        time.sleep(0.5)
sid = post("/v1/scenes", scene)["id"]
halt = {"time_s": secs} if sim else {"spp": spp}
job = post("/v1/jobs", {"scene": sid, "halt": halt, "snapshot_every": {"iterations": 10**9}})
trace = []
while job["state"] not in ("completed", "failed", "cancelled"):
    time.sleep(1.0)
    job = get("/v1/jobs/" + job["id"])
    trace.append((time.time(), job["iteration"]))
assert job["state"] == "completed", job
took = job["finished_at"] - job["created_at"]
if not sim:
    print(f"job: cornell-box {w}x{h} pt {spp} spp on 2 workers x 1 thread: {took:.1f} s")
    sys.exit(0)
# The intake rate from the first group added to the last one (the pool's start-up,
# one unit's time, is not the coordinator's doing).
moved = [(t, i) for t, i in trace if i > 0]
(t0, i0), (t1, i1) = moved[0], moved[-1]
rate = (i1 - i0) / (t1 - t0) if t1 > t0 else float("nan")
offered = sim / iter_s
# The second half of the run, once units have their length: groups are added whole,
# so this spans the groups added in it.
half = [(t, i) for t, i in moved if t >= (t0 + t1) / 2]
(h0, j0) = next(((t, i) for t, i in reversed(moved) if t < half[0][0]), moved[0]) if half else (t0, i0)
late = (i1 - j0) / (t1 - h0) if half and t1 > h0 else float("nan")
print(f"job: cornell-box {w}x{h} pt, {sim} simulated workers at {iter_s} s/iteration for {secs:.0f} s: "
      f"{job['iteration']} iterations")
print(f"intake: {rate:.1f} iterations/s added (from iteration {i0} to {i1}) of {offered:.1f} offered: "
      f"{100 * rate / offered:.0f} %; in the second half {late:.1f} iterations/s, {100 * late / offered:.0f} %")
PY

python3 - "$TMP/coordinator.log" "$W" "$H" "$SIMULATE" <<'PY'
import os, re, statistics, sys
log = open(sys.argv[1]).read()
w, h, sim = int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
def values(field):
    return [float(v) for v in re.findall(field + r"=([0-9.eE+-]+)", log)]
fetch, decode, fold, merge = (values(f) for f in ("fetch_s", "decode_s", "fold_s", "merge_s"))
med = lambda xs: statistics.median(xs) if xs else float("nan")
raw = 96 * w * h
print(f"ranges: {len(fold)}, groups: {len(merge)}; a range's exact sums: {raw / 1e6:.0f} MB plain "
      f"(sums and second moments), {med(values('bytes')) / 1e6:.1f} MB packed (median)")
print(f"median fetch_s {med(fetch):.3f} (max {max(fetch, default=float('nan')):.3f}), "
      f"decode_s {med(decode):.3f}, fold_s {med(fold):.3f}; per group merge_s {med(merge):.3f}")
cores = os.cpu_count() or 2
cpu = [d + f for d, f in zip(decode, fold)]
# What the coordinator can take: 8 fetches at once, one decode and addition per core
# (src/job/remote/coordinator.rs), from the median costs per range.
fetching, decoding = 8 / med(fetch), cores / med(cpu)
capacity = min(fetching, decoding)
print(f"intake capacity: {capacity:.1f} ranges/s (fetching {fetching:.1f}, decoding and adding "
      f"{decoding:.1f} on {cores} cores; median decode+fold {med(cpu):.3f} s)")
print(f"workers the intake takes with 2 s units: {capacity * 2:.0f}; the scheduler thread "
      f"adds one group per round of units ({med(merge):.3f} s each)")
# Units are sized so that the intake has twice what all workers send
# (src/job/remote/ranges.rs): unit = max(2 s, 2 N / capacity).
for n in (10, 100, 1000):
    print(f"{n} workers: units of {max(2.0, 2 * n / capacity):.1f} s")
PY
