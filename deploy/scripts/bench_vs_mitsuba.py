"""Times caustic's `pt` against Mitsuba 3's `path` (llvm_ad_rgb) on the same textured
rough-material scene, scenes/mitsuba-rough/textured-rough.xml (256 x 192: rough metal,
rough glass and rough plastic with a bitmap base, area light, max_depth 8, rr_depth 5),
side by side: same file, same spp, median of --repeat timed runs each, and the RMSE of
each run against one high-spp reference (Mitsuba's, cached in --out). Not a test.

    cargo build --release
    /tmp/mi/bin/python deploy/scripts/bench_vs_mitsuba.py [--spp 64] [--repeat 3]

caustic's time is the wall time its `render` summary line reports (the render loop,
without loading the scene). Mitsuba's is the wall time of mi.render plus the wait for
its result, after one untimed warm-up render of the same spp; the warm-up's time
(tracing, JIT compilation of the kernels) is printed on its own line. Both use every
core. The machine is shared: run it twice and compare ratios, not absolute times.
Mitsuba's llvm variants need libLLVM 19 on Debian 12 (see mitsuba_cornell.py).
"""

import argparse
import os
import re
import statistics
import subprocess
import time
from pathlib import Path

LLVM = "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1"
if "DRJIT_LIBLLVM_PATH" not in os.environ and Path(LLVM).exists():
    os.environ["DRJIT_LIBLLVM_PATH"] = LLVM

import numpy as np  # noqa: E402

import drjit as dr  # noqa: E402
import mitsuba as mi  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
SCENE = REPO / "scenes" / "mitsuba-rough" / "textured-rough.xml"


def rmse(img, ref):
    return float(np.sqrt(np.mean((img[..., :3] - ref[..., :3]) ** 2)))


def read_exr(path):
    return np.array(mi.Bitmap(str(path)), dtype=np.float64)[..., :3]


def mitsuba_render(scene, spp, seed):
    t = time.perf_counter()
    img = mi.render(scene, spp=spp, seed=seed)
    dr.eval(img)
    dr.sync_thread()
    return time.perf_counter() - t, np.array(img, dtype=np.float64)[..., :3]


def reference(scene, out, spp):
    path = out / f"reference-{spp}spp.exr"
    if path.exists():
        return read_exr(path)
    passes = max(1, spp // 256)
    acc = sum(mitsuba_render(scene, 256, 10_000 + i)[1] for i in range(passes)) / passes
    mi.Bitmap(acc.astype(np.float32)).write(str(path))
    return acc


def caustic_render(binary, spp, seed, out):
    exr = out / f"caustic-{seed}.exr"
    cmd = [binary, "render", str(SCENE), "-a", "pt", "--spp", str(spp),
           "--seed", str(seed), "-o", str(exr)]
    res = subprocess.run(cmd, capture_output=True, text=True, check=True)
    m = re.search(r"pt: (\d+) iterations in ([0-9.]+) s", res.stdout)
    if not m:
        raise SystemExit(f"unexpected caustic output: {res.stdout}\n{res.stderr}")
    assert int(m.group(1)) == spp
    return float(m.group(2)), read_exr(exr)


def row(name, times, errors, spp, pixels):
    t = statistics.median(times)
    print(f"{name:<22} {t:9.3f} {spp:6d} {spp * pixels / t / 1e6:12.3f} "
          f"{statistics.median(errors):12.5f}   (times {', '.join(f'{x:.3f}' for x in times)})")
    return t


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--ref-spp", type=int, default=8192)
    ap.add_argument("--caustic", default=str(REPO / "target" / "release" / "caustic"))
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--out", default="/tmp/bench_vs_mitsuba")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    mi.set_variant(args.variant)
    scene = mi.load_file(str(SCENE))
    pixels = 256 * 192
    ref = reference(scene, out, args.ref_spp)

    warm, _ = mitsuba_render(scene, args.spp, 0)
    mts = [mitsuba_render(scene, args.spp, 1 + i) for i in range(args.repeat)]
    cst = [caustic_render(args.caustic, args.spp, 1 + i, out) for i in range(args.repeat)]

    print(f"scene {SCENE.relative_to(REPO)}, {pixels} pixels, reference: Mitsuba "
          f"{args.ref_spp} spp")
    print(f"Mitsuba {args.variant} warm-up render (JIT compilation included): {warm:.3f} s")
    print(f"{'renderer':<22} {'time s':>9} {'spp':>6} {'M samples/s':>12} {'RMSE':>12}")
    tc = row("caustic pt", [t for t, _ in cst], [rmse(i, ref) for _, i in cst], args.spp, pixels)
    tm = row(f"mitsuba {args.variant}", [t for t, _ in mts], [rmse(i, ref) for _, i in mts],
             args.spp, pixels)
    print(f"time ratio caustic / Mitsuba: {tc / tm:.3f}")
    mean_c = np.mean([i.mean(axis=(0, 1)) for _, i in cst], axis=0)
    print(f"image means: caustic {mean_c}, reference {ref.mean(axis=(0, 1))}")


if __name__ == "__main__":
    main()
