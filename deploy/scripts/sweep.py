#!/usr/bin/env python3
"""Run a parameter sweep on a caustic server over REST and print RMSE against time.

Needs only the standard library and `requests`:

    pip install requests
    python3 deploy/scripts/sweep.py --url http://127.0.0.1:7878 --scene cornell-box

The sweep renders the scene once as a long reference job, then runs every algorithm
for each time budget against that reference, and prints one row per job.
"""
import argparse
import os
import sys
import time

import requests


def api(session, method, url, **kw):
    r = session.request(method, url, timeout=60, **kw)
    if r.status_code >= 400:
        sys.exit(f"{method} {url}: {r.status_code} {r.text}")
    return r.json() if r.content else None


def wait(session, base, job_id, poll=0.5):
    while True:
        job = api(session, "GET", f"{base}/v1/jobs/{job_id}")
        if job["state"] in ("completed", "cancelled", "failed"):
            return job
        time.sleep(poll)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--url", default="http://127.0.0.1:7878")
    p.add_argument("--scene", default="cornell-box")
    p.add_argument("--algorithms", default="pt")
    p.add_argument("--times", default="1,2,4", help="time budgets in seconds")
    p.add_argument("--reference-spp", type=int, default=256)
    p.add_argument("--token", default=os.environ.get("CAUSTIC_TOKEN"))
    a = p.parse_args()

    s = requests.Session()
    if a.token:
        s.headers["Authorization"] = f"Bearer {a.token}"

    ref = api(s, "POST", f"{a.url}/v1/jobs", json={
        "scene": a.scene, "halt": {"spp": a.reference_spp}, "seed": 1000,
        "name": "reference", "priority": 1})
    print(f"reference job {ref['id']}: {a.reference_spp} spp", file=sys.stderr)
    ref = wait(s, a.url, ref["id"])
    if ref["state"] != "completed":
        sys.exit(f"reference job ended {ref['state']}: {ref.get('error')}")

    grid = {
        "algorithm": a.algorithms.split(","),
        "halt.time_s": [float(t) for t in a.times.split(",")],
    }
    sweep = api(s, "POST", f"{a.url}/v1/sweeps", json={
        "base": {"scene": a.scene, "halt": {"time_s": 1}, "reference": {"job": ref["id"]},
                 "snapshot_every": {"seconds": 0.5}},
        "grid": grid, "name": "rmse-vs-time"})
    print(f"sweep {sweep['id']}: {len(sweep['rows'])} jobs", file=sys.stderr)
    for row in sweep["rows"]:
        wait(s, a.url, row["job"])
    table = api(s, "GET", f"{a.url}/v1/sweeps/{sweep['id']}")
    print(f"{'algorithm':<10} {'time_s':>8} {'iterations':>10} {'rmse':>12}")
    for r in sorted(table["rows"], key=lambda r: (r["point"]["algorithm"], r["time_s"])):
        rmse = "-" if r["rmse"] is None else f"{r['rmse']:.4e}"
        print(f"{r['point']['algorithm']:<10} {r['time_s']:>8.2f} {r['iterations']:>10} {rmse:>12}")


if __name__ == "__main__":
    main()
