#!/usr/bin/env python3
"""Variance per iteration and per second of an algorithm, from two independent renders.

Renders SCENE twice (seeds 1 and 2) with `caustic render --spp N`, then estimates the
per-pixel variance of one render as mean((a - b)^2) / 2, reported times N (variance of
one iteration) and times the seconds per render (variance x time: lower is more
efficient). With --reference, pixels brighter than --bright in it (directly visible
lights) are also left out, for a second figure.

    python3 deploy/scripts/pair_variance.py scenes/media/fog-cornell.json upbp 4 \
        --param techniques=bpt --reference REF.exr

With --matched R2 R1 (the ALGORITHM argument is then ignored), the volume estimators
run alone at matched, fixed radii (alpha 1), one line each: `vpm` (beam radiance
estimate, radius R2) against `upbp` with `pb2d` alone (point x beam 2D, radius R2), and
`ppb` (photon beams, radius R1) against `upbp` with `bb1d` alone (beam x beam 1D, radius
R1), then `upbp` with every technique at those radii (issue 39). The pairs share the
volume kernel and its radius, not the whole image: `vpm` and `ppb` also path-trace the
surfaces, which `upbp` with one technique leaves out, so their variance includes that
part too, and a ratio near or below 1 for them is a lower bound on what upbp's walks and
beam counts cost.

    python3 deploy/scripts/pair_variance.py scenes/media/fog-cornell.json - 4 \
        --matched 0.03 0.02

Needs numpy and OpenEXR (pip install numpy OpenEXR); caustic built in release mode.
"""
import argparse
import os
import subprocess
import tempfile
import time

import numpy as np
import OpenEXR


def load(path):
    return np.asarray(OpenEXR.File(path).parts[0].channels["RGB"].pixels, dtype=np.float64)


def measure(a, algorithm, params):
    """(seconds per render, per-pixel variance of one render) of ALGORITHM with PARAMS."""
    with tempfile.TemporaryDirectory() as tmp:
        images, seconds = [], 0.0
        for seed in (1, 2):
            out = os.path.join(tmp, f"{seed}.exr")
            cmd = [a.caustic, "render", a.scene, "-a", algorithm, "--spp", str(a.iterations),
                   "--seed", str(seed), "-o", out]
            for p in params:
                cmd += ["--param", p]
            t0 = time.monotonic()
            subprocess.run(cmd, check=True, capture_output=True)
            seconds += time.monotonic() - t0
            images.append(load(out))
    return seconds / 2, ((images[0] - images[1]) ** 2).mean(axis=2) / 2


def report(a, algorithm, params):
    seconds, var = measure(a, algorithm, params)
    line = (f"{algorithm} {' '.join(params)}: {seconds / a.iterations:.3f} s/iteration, "
            f"variance x iterations {var.mean() * a.iterations:.3e}, "
            f"variance x seconds {var.mean() * seconds:.3e}")
    if a.reference:
        keep = load(a.reference).mean(axis=2) <= a.bright
        v = var[keep].mean()
        line += (f"; without pixels above {a.bright} in the reference: "
                 f"{v * a.iterations:.3e}, {v * seconds:.3e}")
    print(line, flush=True)


def matched(r2, r1):
    """The runs of --matched: (algorithm, parameters) at fixed radii r2 (2D) and r1 (1D)."""
    upbp = ["pb2d_alpha=1", "bb1d_alpha=1", f"pb2d_radius={r2}", f"bb1d_radius={r1}"]
    return [
        ("vpm", [f"radius={r2}", "alpha=1"]),
        ("upbp", ['techniques=["pb2d"]'] + upbp),
        ("ppb", [f"radius={r1}", "alpha=1"]),
        ("upbp", ['techniques=["bb1d"]'] + upbp),
        ("upbp", upbp),
    ]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene")
    ap.add_argument("algorithm")
    ap.add_argument("iterations", type=int)
    ap.add_argument("--param", action="append", default=[])
    ap.add_argument("--matched", nargs=2, type=float, metavar=("R2", "R1"))
    ap.add_argument("--reference")
    ap.add_argument("--bright", type=float, default=3.0)
    ap.add_argument("--caustic", default="target/release/caustic")
    a = ap.parse_args()
    runs = matched(*a.matched) if a.matched else [(a.algorithm, [])]
    for algorithm, params in runs:
        report(a, algorithm, params + a.param)


if __name__ == "__main__":
    main()
