#!/usr/bin/env python3
"""Summary of an equal-time benchmark run over several seeds (issue 39).

Reads what `deploy/scripts/bench-upbp.sh` writes: OUT/<scene>/reference.exr and, per
seed, OUT/<scene>/seed<S>/ with `caustic bench`'s final images (<algorithm>.exr) and
bench.csv. For each scene and algorithm it prints, over the seeds:

- the median iteration count;
- RMSE over all linear RGB values (as `caustic bench` and `caustic diff` compute it):
  median, then the min-max spread;
- the same RMSE without the lamp pixels, those whose mean over R, G and B in the
  reference is above --bright (default 3, as `pair_variance.py`): directly visible
  lights, which converge with the iteration count whatever the algorithm;
- each median divided by the best median of the single methods (every entry whose name
  does not start with `upbp`; of all entries if there are none), the figure the issue's
  targets are stated in.

Where the reference has a `variance` layer (`caustic reference --variance-layer`, as
bench-upbp.sh renders it), each pixel's estimated variance of the reference is taken
out of the squared errors: E[(image - reference)^2] = E[(image - truth)^2] +
var(reference), as the two renders share no samples. Every figure is then the RMSE
against the true image, which matters when the runs are long enough that the
reference's own noise is not small beside theirs (the 240 s budget); the header says
so and gives the reference's own RMSE.

It also writes OUT/summary.csv, one row per scene and algorithm.

    python3 deploy/scripts/equal_time_summary.py OUT [SCENE...] [--bright 3]

Needs numpy and OpenEXR (pip install numpy OpenEXR).
"""
import argparse
import csv
import os
import statistics

import numpy as np

import OpenEXR

from pair_variance import load


def rmse(image, reference, keep=None, noise=None):
    """RMSE over all values (of the pixels in `keep`), less the reference's estimated
    variance `noise` where given (never below 0)."""
    d2 = (image - reference) ** 2
    if noise is not None:
        d2 = d2 - noise
    return float(np.sqrt(max(d2[keep].mean() if keep is not None else d2.mean(), 0.0)))


def reference_noise(path):
    """The reference's `variance` layer, or None."""
    part = OpenEXR.File(path).parts[0]
    for name in ("variance.RGB", "variance"):
        if name in part.channels:
            return np.asarray(part.channels[name].pixels, dtype=np.float64)
    if all(f"variance.{c}" in part.channels for c in "RGB"):
        return np.stack([np.asarray(part.channels[f"variance.{c}"].pixels, dtype=np.float64)
                         for c in "RGB"], axis=-1)
    return None


def last_rows(bench_csv):
    """Each algorithm's last row of a bench.csv (its state at the end of the budget)."""
    rows = {}
    with open(bench_csv) as f:
        for row in csv.DictReader(f):
            rows[row["algorithm"]] = row
    return rows


def seed_dirs(scene_dir):
    return sorted(
        os.path.join(scene_dir, d)
        for d in os.listdir(scene_dir)
        if d.startswith("seed") and os.path.isfile(os.path.join(scene_dir, d, "bench.csv"))
    )


def measure_scene(scene_dir, bright):
    """({algorithm: [(iterations, rmse, rmse without lamp), one per seed]}, lamp pixels,
    the reference's own estimated RMSE or None)."""
    path = os.path.join(scene_dir, "reference.exr")
    reference, noise = load(path), reference_noise(path)
    keep = reference.mean(axis=2) <= bright
    runs = {}
    for d in seed_dirs(scene_dir):
        for name, row in last_rows(os.path.join(d, "bench.csv")).items():
            image = load(os.path.join(d, f"{name}.exr"))
            runs.setdefault(name, []).append(
                (int(row["iteration"]), rmse(image, reference, None, noise),
                 rmse(image, reference, keep, noise))
            )
    own = None if noise is None else float(np.sqrt(noise.mean()))
    return runs, int((~keep).sum()), own


def best_single(medians):
    single = [m for name, m in medians.items() if not name.startswith("upbp")]
    return min(single or medians.values())


def spread(values):
    return statistics.median(values), min(values), max(values)


def summarise(scene, runs, lamp_pixels, own):
    """Printed table and csv rows of one scene."""
    all_px = {name: spread([r[1] for r in rs]) for name, rs in runs.items()}
    no_lamp = {name: spread([r[2] for r in rs]) for name, rs in runs.items()}
    best = best_single({n: s[0] for n, s in all_px.items()})
    best_nl = best_single({n: s[0] for n, s in no_lamp.items()})
    seeds = max(len(rs) for rs in runs.values())
    lines = [
        f"{scene}: {seeds} seeds; without lamp = without the {lamp_pixels} pixels above "
        f"the threshold in the reference; x best = median / best single method's median"
        + ("" if own is None else
           f"; the reference's own noise (RMSE {own:.4e}) taken out of every figure"),
        f"{'algorithm':<26} {'seeds':>5} {'iters':>7} {'RMSE':>10} {'min':>10} {'max':>10}"
        f" {'x best':>7} {'w/o lamp':>10} {'min':>10} {'max':>10} {'x best':>7}",
    ]
    rows = []
    for name, rs in runs.items():
        iters = statistics.median(r[0] for r in rs)
        a, n = all_px[name], no_lamp[name]
        lines.append(
            f"{name:<26} {len(rs):>5} {iters:>7.0f} {a[0]:>10.4e} {a[1]:>10.4e} {a[2]:>10.4e}"
            f" {a[0] / best:>7.2f} {n[0]:>10.4e} {n[1]:>10.4e} {n[2]:>10.4e} {n[0] / best_nl:>7.2f}"
        )
        rows.append([scene, name, len(rs), iters, *a, a[0] / best, *n, n[0] / best_nl,
                     "" if own is None else own])
    return "\n".join(lines), rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("out", help="the OUT directory of bench-upbp.sh")
    ap.add_argument("scenes", nargs="*", help="scene names (default: every OUT/<scene>/ with seed runs)")
    ap.add_argument("--bright", type=float, default=3.0, help="lamp pixels: reference mean above this")
    a = ap.parse_args()
    scenes = a.scenes or sorted(
        d for d in os.listdir(a.out)
        if os.path.isdir(os.path.join(a.out, d)) and seed_dirs(os.path.join(a.out, d))
    )
    header = ["scene", "algorithm", "seeds", "iterations", "rmse_median", "rmse_min", "rmse_max",
              "rmse_x_best", "no_lamp_median", "no_lamp_min", "no_lamp_max", "no_lamp_x_best",
              "reference_rmse_removed"]
    table = [header]
    for scene in scenes:
        text, rows = summarise(scene, *measure_scene(os.path.join(a.out, scene), a.bright))
        print(text + "\n")
        table += rows
    with open(os.path.join(a.out, "summary.csv"), "w", newline="") as f:
        csv.writer(f).writerows(table)


if __name__ == "__main__":
    main()
