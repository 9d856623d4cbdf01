#!/usr/bin/env python3
"""Writes scenes/media/smoke.vol: a 64^3 smoke plume as a Mitsuba volume (version 3).

Plain python3, no numpy. The plume rises along +y inside a cylinder that widens with
height and whose axis winds around the grid's centre; inside it, density is a few
octaves of hash-based value noise, sampled in coordinates that twist with height so
the puffs look swirled. Values lie in [0, 1]; every border voxel is zero so the
grid's box needs no clamping. Bounds are the unit cube.

The output depends only on this file: the noise comes from an integer hash, not from
a random number generator. Run from the repository root:

    python3 deploy/scripts/make_smoke.py [output path]
"""

import math
import os
import struct
import sys
from array import array

RES = 64
OCTAVES = ((4, 0.5), (8, 0.25), (16, 0.15), (32, 0.1))  # (lattice cells, weight)


def hash01(x, y, z, seed):
    """A lattice value in [0, 1) from 32-bit integer mixing (any good mixer would do)."""
    h = (x * 0x8DA6B343 + y * 0xD8163841 + z * 0xCB1AB31F + seed * 0x165667B1) & 0xFFFFFFFF
    h ^= h >> 15
    h = (h * 0x2C1B3C6D) & 0xFFFFFFFF
    h ^= h >> 12
    h = (h * 0x297A2D39) & 0xFFFFFFFF
    h ^= h >> 15
    return h / 4294967296.0


def lattice(cells, seed):
    """Values at the (cells + 1)^3 lattice points of one octave, x fastest."""
    n = cells + 1
    return [hash01(x, y, z, seed) for z in range(n) for y in range(n) for x in range(n)]


def smooth(t):
    """Smoothstep on [0, 1]; clamped, since the cubic turns back up outside it."""
    t = min(max(t, 0.0), 1.0)
    return t * t * (3.0 - 2.0 * t)


def value_noise(values, cells, p):
    """Smoothly interpolated lattice noise at p in [0, 1]^3."""
    n = cells + 1
    fx, fy, fz = (min(max(c, 0.0), 1.0) * cells for c in p)
    ix, iy, iz = (min(int(f), cells - 1) for f in (fx, fy, fz))
    tx, ty, tz = smooth(fx - ix), smooth(fy - iy), smooth(fz - iz)

    def at(dx, dy, dz):
        return values[(ix + dx) + n * ((iy + dy) + n * (iz + dz))]

    def lerp(a, b, t):
        return a + (b - a) * t

    x00 = lerp(at(0, 0, 0), at(1, 0, 0), tx)
    x10 = lerp(at(0, 1, 0), at(1, 1, 0), tx)
    x01 = lerp(at(0, 0, 1), at(1, 0, 1), tx)
    x11 = lerp(at(0, 1, 1), at(1, 1, 1), tx)
    return lerp(lerp(x00, x10, ty), lerp(x01, x11, ty), tz)


def plume_shape(x, y, z):
    """Envelope in [0, 1]: 1 on the winding axis, 0 outside the widening cylinder."""
    cx = 0.5 + 0.06 * math.sin(7.0 * y)
    cz = 0.5 + 0.06 * math.cos(7.0 * y)
    radius = 0.08 + 0.25 * y
    r = math.hypot(x - cx, z - cz) / radius
    if r >= 1.0:
        return 0.0
    # Fade in above the source and out below the top, so the column has soft ends.
    vertical = smooth(y / 0.12) * smooth((0.95 - y) / 0.25)
    return vertical * smooth(1.0 - r)


def density(x, y, z, octaves):
    shape = plume_shape(x, y, z)
    if shape == 0.0:
        return 0.0
    # Twist the noise around the axis with height: the swirl.
    angle = 5.0 * y
    dx, dz = x - 0.5, z - 0.5
    tx = 0.5 + dx * math.cos(angle) - dz * math.sin(angle)
    tz = 0.5 + dx * math.sin(angle) + dz * math.cos(angle)
    # Shift the noise downward with height so the puffs read as rising, not stacked.
    p = (tx, min(y * 0.8 + 0.1, 1.0), tz)
    noise = sum(w * value_noise(v, cells, p) for cells, w, v in octaves)
    # Subtract a floor so the plume breaks into wisps instead of a uniform fog.
    d = shape * max(noise - 0.3, 0.0) * 2.2
    return min(d, 1.0)


def voxels():
    octaves = [(cells, w, lattice(cells, seed)) for seed, (cells, w) in enumerate(OCTAVES)]
    out = array("f", [0.0]) * (RES * RES * RES)
    for k in range(1, RES - 1):
        z = (k + 0.5) / RES
        for j in range(1, RES - 1):
            y = (j + 0.5) / RES
            for i in range(1, RES - 1):
                x = (i + 0.5) / RES
                out[i + RES * (j + RES * k)] = density(x, y, z, octaves)
    return out


def write_vol(path, data):
    header = struct.pack("<3sBiiiii6f", b"VOL", 3, 1, RES, RES, RES, 1, 0, 0, 0, 1, 1, 1)
    if sys.byteorder != "little":
        data.byteswap()
    with open(path, "wb") as f:
        f.write(header)
        f.write(data.tobytes())


def main():
    path = sys.argv[1] if len(sys.argv) > 1 else "scenes/media/smoke.vol"
    os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
    data = voxels()
    write_vol(path, data)
    nonzero = sum(1 for v in data if v > 0.0)
    print(f"{path}: {RES}^3, max {max(data):.3f}, {nonzero} non-zero voxels")


if __name__ == "__main__":
    main()
