"""Times Mitsuba 3 on its built-in Cornell box, set up as scenes/cornell-box.json
(256x256, box filter, path tracer with max_depth 64 and rr_depth 5), for the speed
comparison of issue 2. Not used by the tests.

    pip install mitsuba
    python benches/mitsuba_cornell.py [--variant llvm_ad_rgb] [--spp 16 32 64] [--repeat 5]

Prints milliseconds per sample per pixel: the median over repeats of each spp count,
after a warm-up render that pays for JIT compilation.

The llvm_* variants need a libLLVM recent enough for Dr.Jit (LLVM 14 aborts with
"Cannot select ... fminimum"); point DRJIT_LIBLLVM_PATH at a newer one if needed.
"""

import argparse
import statistics
import time

import drjit as dr
import mitsuba as mi


def scene_dict():
    d = mi.cornell_box()
    d["sensor"]["film"]["width"] = 256
    d["sensor"]["film"]["height"] = 256
    d["sensor"]["film"]["rfilter"] = {"type": "box"}
    d["integrator"] = {"type": "path", "max_depth": 64, "rr_depth": 5}
    return d


def finish(img):
    # JIT variants record lazily: evaluate and wait, or the timing measures nothing.
    dr.eval(img)
    dr.sync_thread()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--spp", type=int, nargs="+", default=[16, 32, 64])
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    mi.set_variant(args.variant)
    scene = mi.load_dict(scene_dict())
    for spp in args.spp:
        # Warm-up: the first render at a given spp traces and compiles the kernel.
        finish(mi.render(scene, spp=spp, seed=0))
        times = []
        for r in range(args.repeat):
            start = time.perf_counter()
            finish(mi.render(scene, spp=spp, seed=r + 1))
            times.append(time.perf_counter() - start)
        ms = statistics.median(times) * 1e3 / spp
        print(f"{args.variant} spp={spp}: {ms:.2f} ms/spp (median of {args.repeat})")


if __name__ == "__main__":
    main()
