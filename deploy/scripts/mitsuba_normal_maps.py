#!/usr/bin/env python3
"""Reference means of Mitsuba 3 for tests/normal_maps.rs: the normal-mapped and the
bump-mapped plane of tests/data/mitsuba/ref-{normalmap,bumpmap}.xml, rendered with
scalar_rgb at high spp; prints and writes tests/data/mitsuba/normal-maps-ref.json
(per-channel image means and their standard errors over independent seeds).

    /tmp/mi/bin/python deploy/scripts/mitsuba_normal_maps.py
"""
import json
import os
import statistics

import mitsuba as mi

mi.set_variant("scalar_rgb")
DATA = os.path.join(os.path.dirname(__file__), "..", "..", "tests", "data", "mitsuba")
SEEDS = 8
SPP = 256


def means(name):
    scene = mi.load_file(os.path.join(DATA, f"ref-{name}.xml"))
    per_seed = []
    for seed in range(SEEDS):
        img = mi.TensorXf(mi.render(scene, spp=SPP, seed=seed))
        flat = list(img.array)
        per_seed.append([statistics.fmean(flat[c::3]) for c in range(3)])
    out = []
    for c in range(3):
        vals = [s[c] for s in per_seed]
        out.append([statistics.fmean(vals), statistics.stdev(vals) / SEEDS**0.5])
    return out


refs = {name: means(name) for name in ["normalmap", "bumpmap"]}
print(json.dumps(refs, indent=1))
with open(os.path.join(DATA, "normal-maps-ref.json"), "w") as f:
    json.dump(refs, f, indent=1)
    f.write("\n")
