"""Equal-time error of caustic and SmallVCM on the four SmallVCM scenes (the second
half of issue 4's target): both render each scene with each algorithm for the same
CPU time, and both images are compared with one long reference by `caustic diff`.
Not used by the tests.

SmallVCM (Davidovic and Georgiev, MIT licence) is built from its own sources, as in
smallvcm_compare.py. Its images are Radiance .hdr files, which `caustic diff` reads.
A reference per scene comes first, e.g.

    caustic reference scenes/smallvcm/gbs_p.json -a vcm --time 400 -o ref/gbs_p.exr

then

    python3 deploy/scripts/smallvcm_equal_time.py --smallvcm /path/smallvcm \\
        --references ref --cpu 30 --out equal-time

Protocol, per scene and algorithm:
- SmallVCM: two iterations (one per core) time its CPU seconds per iteration; it then
  renders the whole number of iterations, even so that both threads get the same
  count, nearest to --cpu CPU seconds (`-i N`: its time limit `-t` reads `clock()`,
  overshoots by up to an iteration per thread and can give two threads one iteration
  index). Its user + system time and the RMSE of its image are recorded.
- caustic: `caustic bench --time` for --cpu / cores wall seconds, which logs RMSE
  against the same reference at log-spaced times with the CPU seconds spent; the
  figure is its RMSE interpolated (log-log) at SmallVCM's CPU seconds, so the
  comparison is at equal CPU time even when the two runs' totals differ.

Settings are SmallVCM's (max path length 10, r0 = 0.003 R, alpha 0.75, light paths =
pixels; RR by albedo comes with the scene files). SmallVCM's `ppm` traces new camera
paths every iteration and merges at their first non-specular vertex with one global
radius schedule: it is compared with caustic's `sppm` (new camera samples every pass,
per-pixel radii, Hachisuka and Jensen 2009) given SmallVCM's r0 and alpha. caustic's
`ppm` keeps one fixed visible point per pixel (Hachisuka et al. 2008), which converges
to an aliased image and would be compared with a different integral.

Where neither program can sample some light paths (pt, lt and bpt miss the caustics
seen through the mirror in the scenes lit by a delta light, lt misses everything seen
through specular surfaces), both converge to the same error against the vcm
reference: a floor, not noise, and the ratio tends to 1. SmallVCM's `lt` also leaves
out emitters seen directly, which caustic's `lt` splats from the light's surface.
"""

import argparse
import csv
import math
import os
import resource
import subprocess

SCENES = ["gbs_s", "glm_c", "gbs_p", "gbs_b"]  # SmallVCM's scene ids 0-3
ALGORITHMS = ["pt", "lt", "bpt", "ppm", "bpm", "vcm"]
# caustic's algorithm for each of SmallVCM's, and the parameters that give it
# SmallVCM's settings.
OURS = {"ppm": "sppm"}
PARAMS = {
    "ppm": ["radius_factor=0.003", "alpha=0.75"],
}


def cpu_of(cmd):
    """Runs `cmd` quietly; returns its children's user + system CPU seconds."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def rmse(caustic, image, reference):
    out = subprocess.run([caustic, "diff", image, reference], check=True,
                         capture_output=True, text=True).stdout
    return float(out.split()[1])


def smallvcm_run(binary, scene, alg, cpu_budget, out):
    sid = str(SCENES.index(scene))
    probe = cpu_of([binary, "-s", sid, "-a", alg, "-i", "2", "-o", out]) / 2
    n = max(2, 2 * round(cpu_budget / probe / 2))
    cpu = cpu_of([binary, "-s", sid, "-a", alg, "-i", str(n), "-o", out])
    return n, cpu


def caustic_curve(caustic, scene, alg, wall, reference, out_dir):
    ours = OURS.get(alg, alg)
    cmd = [caustic, "bench", f"scenes/smallvcm/{scene}.json", "--algorithms", ours,
           "--time", str(wall), "--reference", reference, "-o", out_dir]
    for p in PARAMS.get(alg, []):
        cmd += ["--param", p]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    with open(os.path.join(out_dir, "bench.csv")) as f:
        rows = [r for r in csv.DictReader(f) if r["algorithm"] == ours]
    return [(float(r["cpu_s"]), float(r["rmse"]), int(r["iteration"])) for r in rows]


def at_cpu(curve, cpu):
    """RMSE at `cpu` CPU seconds, log-log between the logged points (the last
    point's value past the end, which only favours SmallVCM)."""
    pts = [(c, e) for c, e, _ in curve if c > 0 and e > 0]
    if cpu >= pts[-1][0]:
        return pts[-1][1]
    for (c0, e0), (c1, e1) in zip(pts, pts[1:]):
        if c0 <= cpu <= c1:
            t = (math.log(cpu) - math.log(c0)) / (math.log(c1) - math.log(c0))
            return math.exp(math.log(e0) + t * (math.log(e1) - math.log(e0)))
    return pts[0][1]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--smallvcm", action="append", required=True,
                    help="a SmallVCM binary (repeat for several builds)")
    ap.add_argument("--caustic", default="target/release/caustic")
    ap.add_argument("--references", required=True,
                    help="directory with <scene>.exr reference images")
    ap.add_argument("--cpu", type=float, default=30.0, help="CPU seconds per run")
    ap.add_argument("--cores", type=int, default=os.cpu_count())
    ap.add_argument("--out", default="equal-time")
    ap.add_argument("--scenes", nargs="+", default=SCENES, choices=SCENES)
    ap.add_argument("--algorithms", nargs="+", default=ALGORITHMS, choices=ALGORITHMS)
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    names = [os.path.basename(b) for b in a.smallvcm]
    head = ["scene", "SmallVCM alg", "caustic alg"]
    for n in names:
        head += [f"{n} iterations", f"{n} CPU s", f"{n} RMSE", f"caustic RMSE at {n}'s CPU s",
                 f"caustic / {n}"]
    head += ["caustic iterations", "caustic CPU s", "caustic final RMSE"]
    rows = []
    for scene in a.scenes:
        ref = os.path.join(a.references, f"{scene}.exr")
        for alg in a.algorithms:
            row = [scene, alg, OURS.get(alg, alg)]
            cells = []
            for b, n in zip(a.smallvcm, names):
                img = os.path.join(a.out, f"{scene}-{alg}-{n}.hdr")
                iters, cpu = smallvcm_run(b, scene, alg, a.cpu, img)
                cells.append((iters, cpu, rmse(a.caustic, img, ref)))
            d = os.path.join(a.out, f"{scene}-{alg}-caustic")
            curve = caustic_curve(a.caustic, scene, alg, a.cpu / a.cores, ref, d)
            for iters, cpu, err in cells:
                ours = at_cpu(curve, cpu)
                row += [iters, f"{cpu:.1f}", f"{err:.4g}", f"{ours:.4g}", f"{ours / err:.2f}"]
            last = curve[-1]
            row += [last[2], f"{last[0]:.1f}", f"{last[1]:.4g}"]
            rows.append(row)
            print(" | ".join(map(str, row)), flush=True)
    with open(os.path.join(a.out, "equal_time.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(head)
        w.writerows(rows)
    print("| " + " | ".join(head) + " |")
    print("|---" * len(head) + "|")
    for r in rows:
        print("| " + " | ".join(map(str, r)) + " |")


if __name__ == "__main__":
    main()
