"""Renders Mitsuba 3's reference images for tests/mitsuba_reference.rs.

Each scene tests/data/mitsuba_refs/<name>.xml (files starting with "_" are shared
includes) is rendered by Mitsuba 3 with its own integrator and film, at many samples
per pixel, into <name>.exr beside it (half floats, a few tens of KB); the spp and the
standard error of each channel's image mean (from independent passes) go into
references.json, which the test reads. Where caustic reads something Mitsuba 3 cannot
(0.x's scale texture), <name>.mitsuba.xml is the same scene in Mitsuba 3's terms and
is what Mitsuba renders. The textures the scenes name are made here, deterministically,
when missing.

    /tmp/mi/bin/python deploy/scripts/mitsuba_references.py            # every scene
    /tmp/mi/bin/python deploy/scripts/mitsuba_references.py bsdf-mask  # some of them

To add a scene: write its XML (include _setup.xml and _stage.xml for an object on the
stage, 64 x 48, box filter), run this script on it, add one line to the test's table,
and commit the three files (XML, EXR, references.json).

Mitsuba's llvm variants need a libLLVM that can lower llvm.minimum (LLVM 19 on Debian
12: apt-get install libllvm19; see mitsuba_cornell.py); scalar_rgb gives the same
images, slower (--variant scalar_rgb).
"""

import argparse
import json
import os
import sys
import time
from pathlib import Path

LLVM = "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1"
if "DRJIT_LIBLLVM_PATH" not in os.environ and Path(LLVM).exists():
    os.environ["DRJIT_LIBLLVM_PATH"] = LLVM

import numpy as np  # noqa: E402

import drjit as dr  # noqa: E402
import mitsuba as mi  # noqa: E402

ROOT = Path(__file__).resolve().parents[2] / "tests" / "data" / "mitsuba_refs"


def textures():
    """name -> (uint8 image, raw?): small, asymmetric (a flipped or swapped axis
    shows), with sharp steps and smooth ramps (bilinear filtering shows)."""
    y, x = np.mgrid[0:12, 0:16]
    srgb = np.stack(
        [x * 16 + 8, y * 20 + 10, ((x // 4 + y // 3) % 2) * 190 + 40], axis=-1
    )
    y, x = np.mgrid[0:8, 0:8]
    raw = np.stack([(x * 37) % 256, 255 - y * 30, ((x + y) % 3) * 100 + 20], axis=-1)
    y, x = np.mgrid[0:8, 0:8]
    opacity = np.where((x - 3.5) ** 2 + (y - 3.5) ** 2 < 10, 230, 30) - (x * 3)
    return {
        "tex-srgb.png": srgb,
        "tex-raw.png": raw,
        "opacity.png": opacity[..., None],
    }


def perturbation_textures():
    """name -> uint8 image of the normal and bump map scenes: a normal map of bumps
    tilted differently along x and y (a swapped or flipped tangent shows), and a
    smooth height field (its bilinear gradient is what bumpmap reads)."""
    y, x = np.mgrid[0:16, 0:16]
    a = 0.6 * np.sin(2 * np.pi * x / 8)
    b = 0.3 * np.cos(2 * np.pi * y / 16) + 0.1
    n = np.stack([a, b, np.ones_like(a)], axis=-1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    y, x = np.mgrid[0:12, 0:16]
    h = 0.5 + 0.3 * np.sin(2 * np.pi * x / 16) + 0.15 * np.cos(2 * np.pi * y / 6)
    return {
        "normals.png": np.round((n * 0.5 + 0.5) * 255),
        "height.png": np.round(h * 255)[..., None],
    }


def make_textures():
    for name, img in {**textures(), **perturbation_textures()}.items():
        path = ROOT / name
        if not path.exists():
            mi.Bitmap(np.ascontiguousarray(img.astype(np.uint8))).write(str(path))
            print(f"wrote {path.name}")


def scenes(names):
    found = sorted(
        p.stem
        for p in ROOT.glob("*.xml")
        if not p.name.startswith("_") and ".mitsuba." not in p.name
    )
    for n in names:
        if n not in found:
            sys.exit(f"no scene {n}.xml in {ROOT}")
    return names or found


def render(name, spp, pass_spp):
    """The mean image over independent passes, and the standard error of each
    channel's image mean (from the passes' means)."""
    twin = ROOT / f"{name}.mitsuba.xml"
    scene = mi.load_file(str(twin if twin.exists() else ROOT / f"{name}.xml"))
    passes = max(1, spp // pass_spp)
    total = None
    means = []
    for i in range(passes):
        img = np.array(mi.render(scene, spp=pass_spp, seed=1000 + i), dtype=np.float64)
        img = img[..., :3]
        total = img if total is None else total + img
        means.append(img.mean(axis=(0, 1)))
    se = np.std(np.array(means), axis=0, ddof=1) / np.sqrt(passes) if passes > 1 else None
    return total / passes, passes * pass_spp, se


def write_exr(path, img):
    bmp = mi.Bitmap(np.ascontiguousarray(img.astype(np.float32)), mi.Bitmap.PixelFormat.RGB)
    bmp = bmp.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float16, srgb_gamma=False)
    bmp.write(str(path))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("names", nargs="*", help="scene names (default: every scene)")
    ap.add_argument("--spp", type=int, default=16384)
    ap.add_argument("--pass-spp", type=int, default=1024)
    ap.add_argument("--variant", default="llvm_ad_rgb")
    args = ap.parse_args()
    mi.set_variant(args.variant)
    make_textures()
    index_path = ROOT / "references.json"
    index = json.loads(index_path.read_text()) if index_path.exists() else {}
    for name in scenes(args.names):
        t = time.time()
        img, spp, se = render(name, args.spp, args.pass_spp)
        write_exr(ROOT / f"{name}.exr", img)
        mean = img.mean(axis=(0, 1))
        index[name] = {
            "spp": spp,
            "mean": [round(float(m), 7) for m in mean],
            "mean_se": [float(f"{s:.3g}") for s in se] if se is not None else None,
            "mitsuba": mi.__version__,
            "variant": args.variant,
        }
        print(f"{name}: {spp} spp in {time.time() - t:.1f} s, mean {mean}, se {se}")
        index_path.write_text(json.dumps(dict(sorted(index.items())), indent=1) + "\n")
    dr.sync_thread()


if __name__ == "__main__":
    main()
