#!/usr/bin/env python3
"""Writes the small OpenVDB files that src/medium/grid_io/vdb.rs tests read.

They are made here because neither the vdb-rs crate nor its repository ships sample
files, and OpenVDB's published samples are large and cannot be fetched in the build.
This needs the real OpenVDB library, from Debian:

    apt-get install python3-openvdb libopenvdb-tools
    /usr/bin/python3 deploy/scripts/make_vdb_fixture.py tests/data

Every value is a multiple of 1/16 so that it survives half-float storage exactly, and
the tests can recompute each expected voxel from `voxel_value` below.

Files:
- grids.vdb (blosc, OpenVDB's default codec):
  - "density": float, a few single voxels at negative and positive coordinates plus
    one filled 8^3 block that OpenVDB stores as an active tile, not as a leaf;
    transform: voxel size 0.25, translated by (1, 2, 3).
  - "temperature": float saved as half, a 2x3x4 block, voxel size 0.5, no translation.
  - "velocity": vec3s, to check that non-scalar grids are refused.
  - "sdf": two voxels marked as a level set, to check that level sets are refused.
- density_zip.vdb: the "density" grid alone, rewritten by vdb_tool with the zlib codec.
- temperature_active.vdb: the "temperature" grid alone, with active-mask compression
  only: vdb-rs 0.6 misreads half floats under zlib or blosc, but not without them.

Each root-level node costs about 9 KB of uncompressed masks, so the grids stay near
the origin and the zlib file holds one grid only.
"""

import os
import subprocess
import sys

import pyopenvdb as vdb


def voxel_value(i, j, k):
    """The value the tests expect at index (i, j, k) of the sparse voxels."""
    return 0.125 * ((7 * i + 3 * j + 5 * k) % 8) + 0.0625


def density_grid():
    grid = vdb.FloatGrid(0.0)
    grid.name = "density"
    # Class left "unknown": OpenVDB never zip-compresses fog volumes or level sets,
    # and density_zip.vdb must exercise zlib.
    # A whole leaf-sized, leaf-aligned block: OpenVDB keeps it as one active tile.
    grid.fill((8, 8, 8), (15, 15, 15), 0.5, True)
    acc = grid.getAccessor()
    for i in range(-3, 3):
        for j in range(0, 4):
            for k in range(5, 7):
                acc.setValueOn((i, j, k), voxel_value(i, j, k))
    transform = vdb.createLinearTransform(voxelSize=0.25)
    transform.translate((1.0, 2.0, 3.0))
    grid.transform = transform
    return grid


def temperature_grid():
    grid = vdb.FloatGrid(0.0)
    grid.name = "temperature"
    grid.saveFloatAsHalf = True
    acc = grid.getAccessor()
    for i in range(2):
        for j in range(3):
            for k in range(4):
                acc.setValueOn((i, j, k), 1.0 + voxel_value(i, j, k))
    grid.transform = vdb.createLinearTransform(voxelSize=0.5)
    return grid


def velocity_grid():
    grid = vdb.Vec3SGrid((0.0, 0.0, 0.0))
    grid.name = "velocity"
    grid.getAccessor().setValueOn((0, 0, 0), (1.0, 0.0, 0.0))
    return grid


def sdf_grid():
    # Two voxels are enough: what matters is the class; a real level set would span
    # eight root nodes around the origin and grow the file tenfold.
    grid = vdb.FloatGrid(0.5)
    grid.name = "sdf"
    grid.gridClass = vdb.GridClass.LEVEL_SET
    acc = grid.getAccessor()
    acc.setValueOn((0, 0, 0), -0.5)
    acc.setValueOn((1, 0, 0), 0.5)
    return grid


def recode(out, grid, name, codec):
    """Writes `grid` alone to out/name with vdb_tool's `codec` (Python cannot choose)."""
    tmp = os.path.join(out, name + ".tmp.vdb")
    vdb.write(tmp, grids=[grid])
    path = os.path.join(out, name)
    subprocess.run(["vdb_tool", "-read", tmp, "-write", "codec=" + codec, path], check=True)
    os.remove(tmp)
    return path


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else "tests/data"
    os.makedirs(out, exist_ok=True)
    blosc = os.path.join(out, "grids.vdb")
    grids = [density_grid(), temperature_grid(), velocity_grid(), sdf_grid()]
    vdb.write(blosc, grids=grids)
    zipped = recode(out, density_grid(), "density_zip.vdb", "zip")
    active = recode(out, temperature_grid(), "temperature_active.vdb", "active")
    for path in (blosc, zipped, active):
        print(path, os.path.getsize(path), "bytes")


if __name__ == "__main__":
    main()
