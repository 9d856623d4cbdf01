"""Times Mitsuba 3's volumetric path tracer on the media scenes of issue 5, set up as
scenes/media/fog-cornell.json and scenes/media/smoke-room.json (256x256, box filter,
volpath with max_depth 64 and rr_depth 5), and optionally writes its images for a
side-by-side check. Not used by the tests.

    python deploy/scripts/mitsuba_media.py [--scene fog|smoke] [--spp 16] [--repeat 5] [--out img.exr]

Setup (libLLVM 19 and the venv) as in mitsuba_cornell.py. Prints milliseconds per
sample per pixel (median over repeats after a warm-up render that pays for JIT
compilation) and the CPU time per spp of all threads.
"""

import argparse
import os
import statistics
import time

import drjit as dr
import mitsuba as mi

HERE = os.path.dirname(os.path.abspath(__file__))
SCENES = os.path.join(HERE, "..", "..", "scenes", "media")


def cornell():
    d = mi.cornell_box()
    d["sensor"]["film"]["width"] = 256
    d["sensor"]["film"]["height"] = 256
    d["sensor"]["film"]["rfilter"] = {"type": "box"}
    d["integrator"] = {"type": "volpath", "max_depth": 64, "rr_depth": 5}
    return d


def fog_box():
    d = cornell()
    # The fog volume encloses the box slightly (no surface coincides with a wall), as in
    # scenes/media/fog-cornell.json.
    d["fog"] = {
        "type": "cube",
        "to_world": mi.ScalarTransform4f().scale(1.001),
        "bsdf": {"type": "null"},
        "interior": {
            "type": "homogeneous",
            "sigma_t": 0.5,
            "albedo": 0.8,
            "phase": {"type": "isotropic"},
        },
    }
    return d


def smoke_room():
    d = cornell()
    for k in ("large-box", "small-box"):
        d.pop(k, None)
    # The 64^3 grid of scenes/media/smoke.vol placed as in smoke-room.json.
    lo, hi = [-0.6, -0.99, -0.6], [0.6, 0.81, 0.6]
    scale = [h - l for l, h in zip(lo, hi)]
    to_world = mi.ScalarTransform4f().translate(lo).scale(scale)
    d["smoke"] = {
        "type": "cube",
        "to_world": mi.ScalarTransform4f().translate([0.0, -0.09, 0.0]).scale([0.6, 0.9, 0.6]),
        "bsdf": {"type": "null"},
        "interior": {
            "type": "heterogeneous",
            "sigma_t": {
                "type": "gridvolume",
                "filename": os.path.join(SCENES, "smoke.vol"),
                "to_world": to_world,
            },
            "scale": 25.0,
            "albedo": 0.9,
        },
    }
    return d


def finish(img):
    dr.eval(img)
    dr.sync_thread()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--scene", default="fog", choices=["fog", "smoke"])
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--out")
    args = ap.parse_args()
    mi.set_variant(args.variant)
    scene = mi.load_dict(fog_box() if args.scene == "fog" else smoke_room())
    img = mi.render(scene, spp=args.spp, seed=0)
    finish(img)
    times, cpu = [], []
    for r in range(args.repeat):
        start, start_cpu = time.perf_counter(), time.process_time()
        img = mi.render(scene, spp=args.spp, seed=r + 1)
        finish(img)
        times.append(time.perf_counter() - start)
        cpu.append(time.process_time() - start_cpu)
    ms = statistics.median(times) * 1e3 / args.spp
    ms_cpu = statistics.median(cpu) * 1e3 / args.spp
    print(f"{args.variant} {args.scene} spp={args.spp}: {ms:.2f} ms/spp, CPU {ms_cpu:.2f} ms/spp")
    if args.out:
        mi.util.write_bitmap(args.out, img)


if __name__ == "__main__":
    main()
