#!/usr/bin/env bash
# Throughput of a worker pool against in-process rendering on the same machine:
# the same job (scene, algorithm, spp) on `caustic serve` with --workers 2, and on a
# coordinator (`serve --nats`) with two `caustic worker --threads 1`, alternately,
# ROUNDS times. Prints each run's wall time (job creation to completion) and the
# median ratio pool / in-process (1.0 = no overhead).
#
#   deploy/scripts/bench-pool.sh [SCENE] [ALGORITHM] [SPP] [ROUNDS]
#   deploy/scripts/bench-pool.sh cornell-box pt 1200 2
#
# Needs a release build (cargo build --release) and python3; installs nats-server
# with install-nats-server.sh.
set -euo pipefail
cd "$(dirname "$0")/../.."
SCENE=${1:-cornell-box}; ALG=${2:-pt}; SPP=${3:-1200}; ROUNDS=${4:-2}
BIN=target/release/caustic
NATS=$(deploy/scripts/install-nats-server.sh)
TMP=$(mktemp -d)
PIDS=()
cleanup() { kill "${PIDS[@]}" 2>/dev/null || true; rm -rf "$TMP"; }
trap cleanup EXIT

"$NATS" -js -a 127.0.0.1 -p 14922 -sd "$TMP/nats" >/dev/null 2>&1 & PIDS+=($!)
sleep 1
"$BIN" serve --nats nats://127.0.0.1:14922 --data-dir "$TMP/pool" --addr 127.0.0.1:14978 --grpc-addr 127.0.0.1:14979 >/dev/null 2>&1 & PIDS+=($!)
for w in 1 2; do
    "$BIN" worker --nats nats://127.0.0.1:14922 --threads 1 --name "w$w" --cache-dir "$TMP/w$w" >/dev/null 2>&1 & PIDS+=($!)
done
"$BIN" serve --workers 2 --data-dir "$TMP/local" --addr 127.0.0.1:14980 --grpc-addr 127.0.0.1:14981 >/dev/null 2>&1 & PIDS+=($!)
sleep 2

run() { # URL -> seconds from creation to completion
    python3 - "$1" "$SCENE" "$ALG" "$SPP" <<'PY'
import json, sys, time, urllib.request
url, scene, alg, spp = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
spec = {"scene": scene, "algorithm": alg, "halt": {"spp": spp}, "snapshot_every": {"iterations": 10**9}}
req = urllib.request.Request(url + "/v1/jobs", json.dumps(spec).encode(), {"content-type": "application/json"})
job = json.load(urllib.request.urlopen(req))
while job["state"] not in ("completed", "failed", "cancelled"):
    time.sleep(0.2)
    job = json.load(urllib.request.urlopen(url + "/v1/jobs/" + job["id"]))
assert job["state"] == "completed", job
print(f"{job['finished_at'] - job['created_at']:.2f}")
PY
}

echo "job: $SCENE $ALG $SPP spp; in-process --workers 2 vs 2 workers x 1 thread"
ratios=()
for r in $(seq 1 "$ROUNDS"); do
    t_local=$(run http://127.0.0.1:14980)
    t_pool=$(run http://127.0.0.1:14978)
    ratio=$(python3 -c "print(f'{$t_pool / $t_local:.3f}')")
    ratios+=("$ratio")
    echo "round $r: in-process ${t_local} s, pool ${t_pool} s, pool / in-process ${ratio}"
done
python3 -c "import statistics,sys; print('median pool / in-process:', statistics.median(map(float, sys.argv[1:])))" "${ratios[@]}"
