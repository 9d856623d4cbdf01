#!/usr/bin/env python3
"""Speed of two caustic binaries, alternating in one run, on the configurations that
integrator changes must not slow down (issue 19): cornell-box pt, gbs_p pt/bpt/vcm,
fog-cornell volpath, smoke-room volpath; and, since issue 38 gave the photon mappers
the shared photon walk, cornell-box sppm and fog-cornell vpm.

Each round runs `caustic bench SCENE --algorithms A --spp N --repeat 1` with both
binaries (the order alternates between rounds, so drift in the machine's load hits
both alike) and the table gives the medians of ms and CPU s per iteration and the
median of the per-round new/old ratios. On a shared machine, quote ratios, not times.

    python3 deploy/scripts/speed_old_new.py OLD_BINARY NEW_BINARY [--rounds 5]
"""
import argparse
import os
import statistics
import subprocess

CONFIGS = [
    ("scenes/cornell-box.json", "pt", 16),
    ("scenes/smallvcm/gbs_p.json", "pt", 8),
    ("scenes/smallvcm/gbs_p.json", "bpt", 4),
    ("scenes/smallvcm/gbs_p.json", "vcm", 4),
    ("scenes/media/fog-cornell.json", "volpath", 4),
    ("scenes/media/smoke-room.json", "volpath", 4),
    ("scenes/cornell-box.json", "sppm", 16),
    ("scenes/media/fog-cornell.json", "vpm", 1),
]
ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")


def bench(binary, scene, algorithm, spp):
    """(ms per iteration, CPU s per iteration) of one timed run."""
    out = subprocess.run(
        [binary, "bench", os.path.join(ROOT, scene), "--algorithms", algorithm,
         "--spp", str(spp), "--repeat", "1"],
        capture_output=True, text=True, check=True).stdout
    for line in out.splitlines():
        fields = line.split()
        if fields and fields[0] == algorithm:
            return float(fields[1]), float(fields[2])
    raise RuntimeError(f"no row for {algorithm} in:\n{out}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("old")
    ap.add_argument("new")
    ap.add_argument("--rounds", type=int, default=5)
    a = ap.parse_args()
    print(f"{'scene':32} {'alg':8} {'old ms':>9} {'new ms':>9} {'new/old':>8} "
          f"{'old CPU s':>9} {'new CPU s':>9} {'new/old CPU':>11}", flush=True)
    for scene, alg, spp in CONFIGS:
        runs = {"old": [], "new": []}
        for r in range(a.rounds):
            order = ["old", "new"] if r % 2 == 0 else ["new", "old"]
            for which in order:
                runs[which].append(bench(getattr(a, which), scene, alg, spp))
        ratio = statistics.median(n[0] / o[0] for o, n in zip(runs["old"], runs["new"]))
        ratio_cpu = statistics.median(n[1] / o[1] for o, n in zip(runs["old"], runs["new"]))
        med = {k: (statistics.median(x[0] for x in v), statistics.median(x[1] for x in v))
               for k, v in runs.items()}
        print(f"{scene:32} {alg:8} {med['old'][0]:9.2f} {med['new'][0]:9.2f} {ratio:8.3f} "
              f"{med['old'][1]:9.4f} {med['new'][1]:9.4f} {ratio_cpu:11.3f}", flush=True)


if __name__ == "__main__":
    main()
