#!/usr/bin/env python3
"""Writes the nine scenes of ../shared/scenes/vrl-thesis.md into scenes/media/.

vrl-cornell-g<g> and vrl-cornell-dense-g<g>: the thesis's Cornell box (x in
[-2.55, 2.55], y in [-2.5, 2.5], z in [-4.5, 0.5], every wall's normal pointing into
the box) filled with a homogeneous medium, lit by a directional light through four
rectangular openings in the ceiling. The ceiling is the plane y = 2.5 over the box
with the openings cut out, tiled by seven rectangles: a strip in front of the
openings, a strip behind them, and five pieces between and beside them in the band
z in [-3.5, -3.18] they share.

The medium is the box's interior. Every wall and ceiling piece names it as its
`exterior` (the side its normal points to, i.e. inside the box), and each opening is
closed by an index-matched (`null`) rectangle facing down with the same `exterior`, so
the medium's boundary is closed: light from above enters the medium through an
opening, and a shadow ray leaves it there into vacuum. The grey boxes name no medium
(opaque objects inside a medium keep it), and the camera names it.

vrl-point-g<g>: no shapes at all; the camera's medium is unbounded, and an isotropic
point light sits in it.

Plain python3. Run from the repository root:

    python3 deploy/scripts/make_vrl_scenes.py
"""

import json
import os
import sys

X0, X1 = -2.55, 2.55
Y0, Y1 = -2.5, 2.5
Z0, Z1 = -4.5, 0.5
OPEN_Z = (-3.5, -3.18)
OPEN_X = ((-0.65, -0.495), (-0.425, -0.27), (-0.2, -0.045), (0.025, 0.18))
GS = (("gm09", -0.9), ("g0", 0.0), ("g09", 0.9))


def rect(name, corners, material, medium=None):
    """A rectangle with these corners (counter-clockwise seen from its front)."""
    s = {"name": name, "type": "rectangle", "corners": corners, "material": material}
    if medium:
        s["exterior"] = medium
    return s


def facing_down(name, x, z, material, medium):
    """The rectangle x[0]..x[1] by z[0]..z[1] at y = Y1, its normal along -y."""
    (xa, xb), (za, zb) = x, z
    corners = [[xa, Y1, za], [xb, Y1, za], [xb, Y1, zb], [xa, Y1, zb]]
    return rect(name, corners, material, medium)


def ceiling(medium):
    """The ceiling minus the openings, and the openings as null rectangles."""
    za, zb = OPEN_Z
    pieces = [
        facing_down("ceiling front", (X0, X1), (zb, Z1), "grey", medium),
        facing_down("ceiling back", (X0, X1), (Z0, za), "grey", medium),
    ]
    edges = [X0] + [e for xs in OPEN_X for e in xs] + [X1]
    for i in range(0, len(edges), 2):
        x = (edges[i], edges[i + 1])
        pieces.append(facing_down(f"ceiling band {i // 2}", x, OPEN_Z, "grey", medium))
    for i, x in enumerate(OPEN_X):
        pieces.append(facing_down(f"opening {i}", x, OPEN_Z, "opening", medium))
    return pieces


def box(name, lo, hi):
    """An axis-aligned box [lo, hi] from the unit cube."""
    centre = [0.5 * (a + b) for a, b in zip(lo, hi)]
    half = [0.5 * (b - a) for a, b in zip(lo, hi)]
    return {
        "name": name,
        "type": "cube",
        "material": "grey",
        "transform": {"translate": centre, "scale": half},
    }


def camera(medium):
    return {
        "type": "pinhole",
        "look_at": {"origin": [0, 0, 0], "target": [0, 0, -1], "up": [0, 1, 0]},
        "fov": 90,
        "fov_axis": "x",
        "medium": medium,
    }


def common(medium, sigma_s, g):
    return {
        "format": 1,
        "camera": camera(medium),
        "film": {"width": 512, "height": 512, "filter": "box"},
        "integrator": {"algorithm": "volpath", "max_depth": 64},
        "media": {
            medium: {
                "type": "homogeneous",
                "sigma_a": [0.1, 0.1, 0.1],
                "sigma_s": [sigma_s] * 3,
                "phase": {"type": "henyey_greenstein", "g": g},
            }
        },
    }


def cornell(sigma_s, g):
    m = "medium"
    scene = common(m, sigma_s, g)
    scene["materials"] = {
        "grey": {"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]},
        "orange": {"type": "diffuse", "reflectance": [1.0, 0.5, 0.0]},
        "cyan": {"type": "diffuse", "reflectance": [0.0, 1.0, 1.0]},
        "opening": {"type": "null"},
    }
    scene["shapes"] = [
        rect("floor", [[X0, Y0, Z1], [X1, Y0, Z1], [X1, Y0, Z0], [X0, Y0, Z0]], "grey", m),
        rect("back wall", [[X0, Y0, Z0], [X1, Y0, Z0], [X1, Y1, Z0], [X0, Y1, Z0]], "grey", m),
        rect("front wall", [[X0, Y1, Z1], [X1, Y1, Z1], [X1, Y0, Z1], [X0, Y0, Z1]], "grey", m),
        rect("left wall", [[X0, Y0, Z1], [X0, Y0, Z0], [X0, Y1, Z0], [X0, Y1, Z1]], "orange", m),
        rect("right wall", [[X1, Y0, Z0], [X1, Y0, Z1], [X1, Y1, Z1], [X1, Y1, Z0]], "cyan", m),
        *ceiling(m),
        box("box 1", [0.25, -2.5, -3.75], [1.75, -1.0, -2.75]),
        box("box 2", [-1.75, -2.5, -4.5], [-0.25, 0.5, -3.75]),
    ]
    scene["lights"] = [
        {
            "type": "directional",
            "direction": [-0.1, -1.0, 0.075],
            "irradiance": [400, 400, 400],
        }
    ]
    return scene


def point(g):
    scene = common("medium", 0.25, g)
    scene["lights"] = [{"type": "point", "position": [0, 0, -2], "intensity": [8, 8, 8]}]
    return scene


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else "scenes/media"
    scenes = {}
    for tag, g in GS:
        scenes[f"vrl-cornell-{tag}"] = cornell(0.01, g)
        scenes[f"vrl-cornell-dense-{tag}"] = cornell(0.25, g)
        scenes[f"vrl-point-{tag}"] = point(g)
    for name, scene in scenes.items():
        with open(os.path.join(out, f"{name}.json"), "w") as f:
            json.dump(scene, f, indent=2)
            f.write("\n")


if __name__ == "__main__":
    main()
