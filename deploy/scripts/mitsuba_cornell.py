"""Times Mitsuba 3 on its built-in Cornell box, set up as scenes/cornell-box.json
(256x256, box filter, path tracer with max_depth 64 and rr_depth 5), for the speed
comparison of issue 2. Not used by the tests.

    pip install mitsuba
    python deploy/scripts/mitsuba_cornell.py [--variant llvm_ad_rgb] [--spp 16 32 64] [--repeat 5]

Prints milliseconds per sample per pixel: the median over repeats of each spp count,
after a warm-up render that pays for JIT compilation.

The llvm_* variants need a libLLVM recent enough for Dr.Jit: LLVM 14 and 15 both
abort with "LLVM ERROR: Cannot select: ... fminimum" (Dr.Jit 1.x emits
llvm.minimum/maximum, which their x86 backends cannot lower). LLVM 19 from Debian
bookworm's own archive works. The recipe that ran on Debian 12 (Python 3.11):

    apt-get install libllvm19           # 1:19.1.7-3~deb12u1, bookworm/main
    python3 -m venv /tmp/mi-venv && /tmp/mi-venv/bin/pip install mitsuba  # 3.9.1
    DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 \
        /tmp/mi-venv/bin/python deploy/scripts/mitsuba_cornell.py --spp 16 --repeat 5

Dr.Jit runs one worker per core and vectorises to the widest registers it finds
(16 lanes with AVX-512). It is very sensitive to other load: on a 2-core machine it
measured 190-220 ms/spp at load average ~8 and 26-65 ms/spp at ~3.5. Compare it with
caustic alternately, in one session; the CPU time also printed (all threads, per
spp) is steadier than wall time on a busy machine.
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
        times, cpu = [], []
        for r in range(args.repeat):
            start, start_cpu = time.perf_counter(), time.process_time()
            finish(mi.render(scene, spp=spp, seed=r + 1))
            times.append(time.perf_counter() - start)
            cpu.append(time.process_time() - start_cpu)
        ms = statistics.median(times) * 1e3 / spp
        ms_cpu = statistics.median(cpu) * 1e3 / spp
        print(
            f"{args.variant} spp={spp}: {ms:.2f} ms/spp, CPU {ms_cpu:.2f} ms/spp "
            f"(medians of {args.repeat})"
        )


if __name__ == "__main__":
    main()
