#!/usr/bin/env python3
"""How closely the noise estimate (est_rmse, from a run's own iterations) tracks the
measured RMSE against a reference, over a `caustic bench` run (issue 40).

The measured RMSE includes the reference's own noise: with REF_RMSE, the reference
render's estimated RMSE (the second summary line of `caustic render`), the comparison
is against sqrt(rmse^2 - REF_RMSE^2), what a noiseless reference would give.

    deploy/scripts/noise_vs_truth.py BENCH_DIR [REF_RMSE]

Prints, per algorithm, every measured point from 16 iterations on (iteration, seconds,
measured RMSE, corrected RMSE, estimated RMSE, their ratio), then the median ratio and
its range. Standard library only.
"""
import csv
import math
import os
import statistics
import sys


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    bench = sys.argv[1]
    ref = float(sys.argv[2]) if len(sys.argv) > 2 else 0.0
    runs = {}
    with open(os.path.join(bench, "bench.csv")) as f:
        for row in csv.DictReader(f):
            runs.setdefault(row["algorithm"], []).append(row)
    for alg, rows in runs.items():
        print(f"{alg}:")
        print(f"  {'iteration':>9} {'seconds':>8} {'rmse':>10} {'corrected':>10} {'est_rmse':>10} {'est/corr':>8}")
        ratios = []
        for r in rows:
            it = int(r["iteration"])
            if it < 16 or not r.get("est_rmse"):
                continue
            rmse, est = float(r["rmse"]), float(r["est_rmse"])
            corrected = math.sqrt(max(rmse * rmse - ref * ref, 0.0))
            ratio = est / corrected if corrected > 0 else float("inf")
            ratios.append(ratio)
            print(f"  {it:>9} {float(r['elapsed_s']):>8.2f} {rmse:>10.3e} {corrected:>10.3e} {est:>10.3e} {ratio:>8.3f}")
        if ratios:
            print(f"  median est/corrected {statistics.median(ratios):.3f}, range {min(ratios):.3f} to {max(ratios):.3f} over {len(ratios)} points")
        else:
            print("  no estimate (fewer than 16 iterations, or a chained algorithm)")


if __name__ == "__main__":
    main()
