#!/usr/bin/env python3
"""Print Mitsuba 3's BSDF eval and pdf at a few direction pairs, for the reference
table in tests/mitsuba_bsdf.rs (issue 37).

    python3 -m venv /tmp/mi && /tmp/mi/bin/pip install mitsuba numpy
    /tmp/mi/bin/python deploy/scripts/mitsuba_bsdf_values.py

Mitsuba's `si.wi` is caustic's `wo` (towards where the path came from) and Mitsuba's
`wo` is caustic's `wi`; both return f |cos theta| of the sampled side.
"""
import drjit as dr
import mitsuba as mi

mi.set_variant("scalar_rgb")

METAL = {"eta": {"type": "rgb", "value": [0.2, 0.9, 1.1]},
         "k": {"type": "rgb", "value": [3.9, 2.4, 1.6]}}
BSDFS = {
    "conductor_beckmann_03": dict(type="roughconductor", distribution="beckmann", alpha=0.3, **METAL),
    "conductor_ggx_01_04": dict(type="roughconductor", distribution="ggx", alpha_u=0.1, alpha_v=0.4, **METAL),
    "dielectric_beckmann_03": dict(type="roughdielectric", distribution="beckmann", alpha=0.3),
    "dielectric_ggx_02_05": dict(type="roughdielectric", distribution="ggx", alpha_u=0.2, alpha_v=0.5),
    "plastic": dict(type="plastic", diffuse_reflectance={"type": "rgb", "value": [0.3, 0.5, 0.7]}),
    "plastic_nonlinear": dict(type="plastic", nonlinear=True,
                              diffuse_reflectance={"type": "rgb", "value": [0.3, 0.5, 0.7]}),
    "roughplastic_beckmann_02": dict(type="roughplastic", alpha=0.2,
                                     diffuse_reflectance={"type": "rgb", "value": [0.3, 0.5, 0.7]}),
    "roughplastic_ggx_03_nonlinear": dict(type="roughplastic", distribution="ggx", alpha=0.3, nonlinear=True,
                                          diffuse_reflectance={"type": "rgb", "value": [0.3, 0.5, 0.7]}),
    # blendbsdf: (1 - weight) first + weight second; a smooth (delta) component adds
    # nothing to eval and pdf.
    "blend_03_diffuse_conductor_ggx_02": dict(
        type="blendbsdf", weight=0.3,
        a=dict(type="diffuse", reflectance={"type": "rgb", "value": [0.3, 0.5, 0.7]}),
        b=dict(type="roughconductor", distribution="ggx", alpha=0.2, **METAL)),
    "blend_06_dielectric_roughdielectric_ggx_03": dict(
        type="blendbsdf", weight=0.6,
        a=dict(type="dielectric"),
        b=dict(type="roughdielectric", distribution="ggx", alpha=0.3)),
}
# (caustic wo, caustic wi), unnormalised.
PAIRS = [
    ((0.3, 0.2, 0.9), (-0.4, -0.1, 0.8)),
    ((0.3, 0.2, 0.9), (-0.2, -0.3, 0.5)),
    ((0.3, 0.2, 0.9), (-0.2, 0.1, -0.9)),
    ((0.2, -0.3, -0.85), (-0.1, 0.3, 0.9)),
    ((0.2, -0.3, -0.85), (-0.3, 0.2, -0.8)),
]


def main():
    for name, props in BSDFS.items():
        bsdf = mi.load_dict(props)
        for mode in (mi.TransportMode.Radiance, mi.TransportMode.Importance):
            ctx = mi.BSDFContext(mode)
            for wo, wi in PAIRS:
                si = mi.SurfaceInteraction3f()
                si.wi = mi.Vector3f(dr.normalize(mi.Vector3f(wo)))
                w = mi.Vector3f(dr.normalize(mi.Vector3f(wi)))
                f = bsdf.eval(ctx, si, w)
                pdf = bsdf.pdf(ctx, si, w)
                m = "R" if mode == mi.TransportMode.Radiance else "I"
                print(f"    (\"{name}\", '{m}', {list(wo)}, {list(wi)}, "
                      f"[{f[0]:.7e}, {f[1]:.7e}, {f[2]:.7e}], {pdf:.7e}),")
    # thindielectric is all delta: the sampled weights and lobe probabilities.
    thin = mi.load_dict({"type": "thindielectric"})
    ctx = mi.BSDFContext()
    for wo in [(0.0, 0.0, 1.0), (0.6, 0.0, 0.8), (0.0, -0.9, -0.2)]:
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(dr.normalize(mi.Vector3f(wo)))
        for u in (0.01, 0.99):
            bs, w = thin.sample(ctx, si, u, mi.Point2f(0.5, 0.5))
            print(f"    (\"thindielectric\", {list(wo)}, {u}, [{bs.wo[0]:.7e}, {bs.wo[1]:.7e}, "
                  f"{bs.wo[2]:.7e}], {w[0]:.7e}, {bs.pdf:.7e}),")


if __name__ == "__main__":
    main()
