#!/usr/bin/env python3
"""Variance per iteration and per second of an algorithm, from two independent renders.

Renders SCENE twice (seeds 1 and 2) with `caustic render --spp N`, then estimates the
per-pixel variance of one render as mean((a - b)^2) / 2, reported times N (variance of
one iteration) and times the seconds per render (variance x time: lower is more
efficient). With --reference, pixels brighter than --bright in it (directly visible
lights) are also left out, for a second figure.

    python3 deploy/scripts/pair_variance.py scenes/media/fog-cornell.json upbp 4 \
        --param techniques=bpt --reference REF.exr

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


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene")
    ap.add_argument("algorithm")
    ap.add_argument("iterations", type=int)
    ap.add_argument("--param", action="append", default=[])
    ap.add_argument("--reference")
    ap.add_argument("--bright", type=float, default=3.0)
    ap.add_argument("--caustic", default="target/release/caustic")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        images, seconds = [], 0.0
        for seed in (1, 2):
            out = os.path.join(tmp, f"{seed}.exr")
            cmd = [a.caustic, "render", a.scene, "-a", a.algorithm, "--spp", str(a.iterations),
                   "--seed", str(seed), "-o", out]
            for p in a.param:
                cmd += ["--param", p]
            t0 = time.monotonic()
            subprocess.run(cmd, check=True, capture_output=True)
            seconds += time.monotonic() - t0
            images.append(load(out))
    seconds /= 2
    var = ((images[0] - images[1]) ** 2).mean(axis=2) / 2
    line = (f"{a.algorithm} {' '.join(a.param)}: {seconds / a.iterations:.3f} s/iteration, "
            f"variance x iterations {var.mean() * a.iterations:.3e}, "
            f"variance x seconds {var.mean() * seconds:.3e}")
    if a.reference:
        keep = load(a.reference).mean(axis=2) <= a.bright
        v = var[keep].mean()
        line += (f"; without pixels above {a.bright} in the reference: "
                 f"{v * a.iterations:.3e}, {v * seconds:.3e}")
    print(line)


if __name__ == "__main__":
    main()
