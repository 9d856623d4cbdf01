//! BSDF values against Mitsuba 3.9 itself: eval (f |cos|) and pdf of each material
//! at a few direction pairs, on both sides and in both transport modes, as printed by
//! `/tmp/mi/bin/python deploy/scripts/mitsuba_bsdf_values.py` (mitsuba 3.9.1 from
//! PyPI, variant scalar_rgb).
//!
//! Tolerances: GGX conductors, dielectrics and smooth plastic agree to float rounding.
//! Beckmann's masking is exact here and Walter's rational fit (within 0.35 %) in
//! Mitsuba, so Beckmann values agree within 1 %; rough plastic's tabulated coating
//! transmittance comes from a quadrature over visible-normal samples whose mapping
//! differs between the two renderers, hence also 1 %. Blends (`blendbsdf`, caustic's
//! mixture of two) weigh eval and pdf alike, a smooth component adding to neither.

use caustic::material::microfacet::{Distribution, Microfacet};
use caustic::material::{
    Coating, Conductor, Dielectric, Diffuse, Material, Mixture, Mode, Plastic, RoughDielectric,
    RoughPlastic,
};
use caustic::math::{Rgb, Vec3};

type Row = (&'static str, char, [f32; 3], [f32; 3], [f32; 3], f32);

// The values as Mitsuba printed them.
#[rustfmt::skip]
#[allow(clippy::excessive_precision)]
const MITSUBA: &[Row] = &[
    ("conductor_beckmann_03", 'R', [0.3, 0.2, 0.9], [-0.4, -0.1, 0.8], [8.4078741e-01, 5.4390943e-01, 3.2668835e-01], 8.8336539e-01),
    ("conductor_beckmann_03", 'R', [0.3, 0.2, 0.9], [-0.2, -0.3, 0.5], [7.1442050e-01, 4.6219501e-01, 2.7836353e-01], 7.5070417e-01),
    ("conductor_beckmann_03", 'R', [0.3, 0.2, 0.9], [-0.2, 0.1, -0.9], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("conductor_beckmann_03", 'R', [0.2, -0.3, -0.85], [-0.1, 0.3, 0.9], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("conductor_beckmann_03", 'R', [0.2, -0.3, -0.85], [-0.3, 0.2, -0.8], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("conductor_beckmann_03", 'I', [0.3, 0.2, 0.9], [-0.4, -0.1, 0.8], [8.4078741e-01, 5.4390943e-01, 3.2668835e-01], 8.8336539e-01),
    ("conductor_beckmann_03", 'I', [0.3, 0.2, 0.9], [-0.2, -0.3, 0.5], [7.1442050e-01, 4.6219501e-01, 2.7836353e-01], 7.5070417e-01),
    ("conductor_beckmann_03", 'I', [0.3, 0.2, 0.9], [-0.2, 0.1, -0.9], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("conductor_beckmann_03", 'I', [0.2, -0.3, -0.85], [-0.1, 0.3, 0.9], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("conductor_beckmann_03", 'I', [0.2, -0.3, -0.85], [-0.3, 0.2, -0.8], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("conductor_ggx_01_04", 'R', [0.3, 0.2, 0.9], [-0.4, -0.1, 0.8], [8.3919853e-01, 5.4288161e-01, 3.2607099e-01], 8.8279676e-01),
    ("conductor_ggx_01_04", 'R', [0.3, 0.2, 0.9], [-0.2, -0.3, 0.5], [1.5429593e+00, 9.9821895e-01, 6.0119158e-01], 1.6449728e+00),
    ("conductor_ggx_01_04", 'R', [0.3, 0.2, 0.9], [-0.2, 0.1, -0.9], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("conductor_ggx_01_04", 'R', [0.2, -0.3, -0.85], [-0.1, 0.3, 0.9], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("conductor_ggx_01_04", 'R', [0.2, -0.3, -0.85], [-0.3, 0.2, -0.8], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("conductor_ggx_01_04", 'I', [0.3, 0.2, 0.9], [-0.4, -0.1, 0.8], [8.3919853e-01, 5.4288161e-01, 3.2607099e-01], 8.8279676e-01),
    ("conductor_ggx_01_04", 'I', [0.3, 0.2, 0.9], [-0.2, -0.3, 0.5], [1.5429593e+00, 9.9821895e-01, 6.0119158e-01], 1.6449728e+00),
    ("conductor_ggx_01_04", 'I', [0.3, 0.2, 0.9], [-0.2, 0.1, -0.9], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("conductor_ggx_01_04", 'I', [0.2, -0.3, -0.85], [-0.1, 0.3, 0.9], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("conductor_ggx_01_04", 'I', [0.2, -0.3, -0.85], [-0.3, 0.2, -0.8], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("dielectric_beckmann_03", 'R', [0.3, 0.2, 0.9], [-0.4, -0.1, 0.8], [3.6336157e-02, 3.6336157e-02, 3.6336157e-02], 3.6336161e-02),
    ("dielectric_beckmann_03", 'R', [0.3, 0.2, 0.9], [-0.2, -0.3, 0.5], [3.1311452e-02, 3.1311452e-02, 3.1311452e-02], 3.1311456e-02),
    ("dielectric_beckmann_03", 'R', [0.3, 0.2, 0.9], [-0.2, 0.1, -0.9], [5.0459731e-02, 5.0459731e-02, 5.0459731e-02], 1.1416854e-01),
    ("dielectric_beckmann_03", 'R', [0.2, -0.3, -0.85], [-0.1, 0.3, 0.9], [6.0506618e-01, 6.0506618e-01, 6.0506618e-01], 2.6742461e-01),
    ("dielectric_beckmann_03", 'R', [0.2, -0.3, -0.85], [-0.3, 0.2, -0.8], [3.9605659e-02, 3.9605659e-02, 3.9605659e-02], 3.9605662e-02),
    ("dielectric_beckmann_03", 'I', [0.3, 0.2, 0.9], [-0.4, -0.1, 0.8], [3.6336157e-02, 3.6336157e-02, 3.6336157e-02], 3.6336161e-02),
    ("dielectric_beckmann_03", 'I', [0.3, 0.2, 0.9], [-0.2, -0.3, 0.5], [3.1311452e-02, 3.1311452e-02, 3.1311452e-02], 3.1311456e-02),
    ("dielectric_beckmann_03", 'I', [0.3, 0.2, 0.9], [-0.2, 0.1, -0.9], [1.1416854e-01, 1.1416854e-01, 1.1416854e-01], 1.1416854e-01),
    ("dielectric_beckmann_03", 'I', [0.2, -0.3, -0.85], [-0.1, 0.3, 0.9], [2.6742461e-01, 2.6742461e-01, 2.6742461e-01], 2.6742461e-01),
    ("dielectric_beckmann_03", 'I', [0.2, -0.3, -0.85], [-0.3, 0.2, -0.8], [3.9605659e-02, 3.9605659e-02, 3.9605659e-02], 3.9605662e-02),
    ("dielectric_ggx_02_05", 'R', [0.3, 0.2, 0.9], [-0.4, -0.1, 0.8], [2.6947133e-02, 2.6947133e-02, 2.6947133e-02], 2.7040496e-02),
    ("dielectric_ggx_02_05", 'R', [0.3, 0.2, 0.9], [-0.2, -0.3, 0.5], [2.9951546e-02, 2.9951546e-02, 2.9951546e-02], 3.0656779e-02),
    ("dielectric_ggx_02_05", 'R', [0.3, 0.2, 0.9], [-0.2, 0.1, -0.9], [1.0976774e+00, 1.0976774e+00, 1.0976774e+00], 2.4867077e+00),
    ("dielectric_ggx_02_05", 'R', [0.2, -0.3, -0.85], [-0.1, 0.3, 0.9], [7.8967798e-01, 7.8967798e-01, 7.8967798e-01], 3.5146812e-01),
    ("dielectric_ggx_02_05", 'R', [0.2, -0.3, -0.85], [-0.3, 0.2, -0.8], [3.0029237e-02, 3.0029237e-02, 3.0029237e-02], 3.0187929e-02),
    ("dielectric_ggx_02_05", 'I', [0.3, 0.2, 0.9], [-0.4, -0.1, 0.8], [2.6947133e-02, 2.6947133e-02, 2.6947133e-02], 2.7040496e-02),
    ("dielectric_ggx_02_05", 'I', [0.3, 0.2, 0.9], [-0.2, -0.3, 0.5], [2.9951546e-02, 2.9951546e-02, 2.9951546e-02], 3.0656779e-02),
    ("dielectric_ggx_02_05", 'I', [0.3, 0.2, 0.9], [-0.2, 0.1, -0.9], [2.4835687e+00, 2.4835687e+00, 2.4835687e+00], 2.4867077e+00),
    ("dielectric_ggx_02_05", 'I', [0.2, -0.3, -0.85], [-0.1, 0.3, 0.9], [3.4901851e-01, 3.4901851e-01, 3.4901851e-01], 3.5146812e-01),
    ("dielectric_ggx_02_05", 'I', [0.2, -0.3, -0.85], [-0.3, 0.2, -0.8], [3.0029237e-02, 3.0029237e-02, 3.0029237e-02], 3.0187929e-02),
    ("plastic", 'R', [0.3, 0.2, 0.9], [-0.4, -0.1, 0.8], [8.6205840e-02, 1.4367640e-01, 2.0114696e-01], 2.6167384e-01),
    ("plastic", 'R', [0.3, 0.2, 0.9], [-0.2, -0.3, 0.5], [7.8469038e-02, 1.3078173e-01, 1.8309441e-01], 2.3877619e-01),
    ("plastic", 'R', [0.3, 0.2, 0.9], [-0.2, 0.1, -0.9], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("plastic", 'R', [0.2, -0.3, -0.85], [-0.1, 0.3, 0.9], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("plastic", 'R', [0.2, -0.3, -0.85], [-0.3, 0.2, -0.8], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("plastic", 'I', [0.3, 0.2, 0.9], [-0.4, -0.1, 0.8], [8.6205840e-02, 1.4367640e-01, 2.0114696e-01], 2.6167384e-01),
    ("plastic", 'I', [0.3, 0.2, 0.9], [-0.2, -0.3, 0.5], [7.8469038e-02, 1.3078173e-01, 1.8309441e-01], 2.3877619e-01),
    ("plastic", 'I', [0.3, 0.2, 0.9], [-0.2, 0.1, -0.9], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("plastic", 'I', [0.2, -0.3, -0.85], [-0.1, 0.3, 0.9], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("plastic", 'I', [0.2, -0.3, -0.85], [-0.3, 0.2, -0.8], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("plastic_nonlinear", 'R', [0.3, 0.2, 0.9], [-0.4, -0.1, 0.8], [4.2903133e-02, 8.3487242e-02, 1.4041054e-01], 2.6167384e-01),
    ("plastic_nonlinear", 'R', [0.3, 0.2, 0.9], [-0.2, -0.3, 0.5], [3.9052662e-02, 7.5994425e-02, 1.2780897e-01], 2.3877619e-01),
    ("plastic_nonlinear", 'R', [0.3, 0.2, 0.9], [-0.2, 0.1, -0.9], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("plastic_nonlinear", 'R', [0.2, -0.3, -0.85], [-0.1, 0.3, 0.9], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("plastic_nonlinear", 'R', [0.2, -0.3, -0.85], [-0.3, 0.2, -0.8], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("plastic_nonlinear", 'I', [0.3, 0.2, 0.9], [-0.4, -0.1, 0.8], [4.2903133e-02, 8.3487242e-02, 1.4041054e-01], 2.6167384e-01),
    ("plastic_nonlinear", 'I', [0.3, 0.2, 0.9], [-0.2, -0.3, 0.5], [3.9052662e-02, 7.5994425e-02, 1.2780897e-01], 2.3877619e-01),
    ("plastic_nonlinear", 'I', [0.3, 0.2, 0.9], [-0.2, 0.1, -0.9], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("plastic_nonlinear", 'I', [0.2, -0.3, -0.85], [-0.1, 0.3, 0.9], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("plastic_nonlinear", 'I', [0.2, -0.3, -0.85], [-0.3, 0.2, -0.8], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("roughplastic_beckmann_02", 'R', [0.3, 0.2, 0.9], [-0.4, -0.1, 0.8], [1.4879288e-01, 2.0161054e-01, 2.5442821e-01], 3.9627486e-01),
    ("roughplastic_beckmann_02", 'R', [0.3, 0.2, 0.9], [-0.2, -0.3, 0.5], [1.1889242e-01, 1.6692932e-01, 2.1496621e-01], 3.2804939e-01),
    ("roughplastic_beckmann_02", 'R', [0.3, 0.2, 0.9], [-0.2, 0.1, -0.9], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("roughplastic_beckmann_02", 'R', [0.2, -0.3, -0.85], [-0.1, 0.3, 0.9], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("roughplastic_beckmann_02", 'R', [0.2, -0.3, -0.85], [-0.3, 0.2, -0.8], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("roughplastic_beckmann_02", 'I', [0.3, 0.2, 0.9], [-0.4, -0.1, 0.8], [1.4879288e-01, 2.0161054e-01, 2.5442821e-01], 3.9627486e-01),
    ("roughplastic_beckmann_02", 'I', [0.3, 0.2, 0.9], [-0.2, -0.3, 0.5], [1.1889242e-01, 1.6692932e-01, 2.1496621e-01], 3.2804939e-01),
    ("roughplastic_beckmann_02", 'I', [0.3, 0.2, 0.9], [-0.2, 0.1, -0.9], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("roughplastic_beckmann_02", 'I', [0.2, -0.3, -0.85], [-0.1, 0.3, 0.9], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("roughplastic_beckmann_02", 'I', [0.2, -0.3, -0.85], [-0.3, 0.2, -0.8], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("roughplastic_ggx_03_nonlinear", 'R', [0.3, 0.2, 0.9], [-0.4, -0.1, 0.8], [7.0916131e-02, 1.0387102e-01, 1.4437389e-01], 3.3206704e-01),
    ("roughplastic_ggx_03_nonlinear", 'R', [0.3, 0.2, 0.9], [-0.2, -0.3, 0.5], [5.9289847e-02, 8.9149617e-02, 1.2584846e-01], 2.9016179e-01),
    ("roughplastic_ggx_03_nonlinear", 'R', [0.3, 0.2, 0.9], [-0.2, 0.1, -0.9], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("roughplastic_ggx_03_nonlinear", 'R', [0.2, -0.3, -0.85], [-0.1, 0.3, 0.9], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("roughplastic_ggx_03_nonlinear", 'R', [0.2, -0.3, -0.85], [-0.3, 0.2, -0.8], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("roughplastic_ggx_03_nonlinear", 'I', [0.3, 0.2, 0.9], [-0.4, -0.1, 0.8], [7.0916131e-02, 1.0387102e-01, 1.4437389e-01], 3.3206704e-01),
    ("roughplastic_ggx_03_nonlinear", 'I', [0.3, 0.2, 0.9], [-0.2, -0.3, 0.5], [5.9289847e-02, 8.9149617e-02, 1.2584846e-01], 2.9016179e-01),
    ("roughplastic_ggx_03_nonlinear", 'I', [0.3, 0.2, 0.9], [-0.2, 0.1, -0.9], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("roughplastic_ggx_03_nonlinear", 'I', [0.2, -0.3, -0.85], [-0.1, 0.3, 0.9], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("roughplastic_ggx_03_nonlinear", 'I', [0.2, -0.3, -0.85], [-0.3, 0.2, -0.8], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("blend_03_diffuse_conductor_ggx_02", 'R', [0.3, 0.2, 0.9], [-0.4, -0.1, 0.8], [4.8491815e-01, 3.7428793e-01, 3.0396998e-01], 6.4629173e-01),
    ("blend_03_diffuse_conductor_ggx_02", 'R', [0.3, 0.2, 0.9], [-0.2, -0.3, 0.5], [2.8882009e-01, 2.4213989e-01, 2.1791895e-01], 4.2852005e-01),
    ("blend_03_diffuse_conductor_ggx_02", 'R', [0.3, 0.2, 0.9], [-0.2, 0.1, -0.9], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("blend_03_diffuse_conductor_ggx_02", 'R', [0.2, -0.3, -0.85], [-0.1, 0.3, 0.9], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("blend_03_diffuse_conductor_ggx_02", 'R', [0.2, -0.3, -0.85], [-0.3, 0.2, -0.8], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("blend_03_diffuse_conductor_ggx_02", 'I', [0.3, 0.2, 0.9], [-0.4, -0.1, 0.8], [4.8491815e-01, 3.7428793e-01, 3.0396998e-01], 6.4629173e-01),
    ("blend_03_diffuse_conductor_ggx_02", 'I', [0.3, 0.2, 0.9], [-0.2, -0.3, 0.5], [2.8882009e-01, 2.4213989e-01, 2.1791895e-01], 4.2852005e-01),
    ("blend_03_diffuse_conductor_ggx_02", 'I', [0.3, 0.2, 0.9], [-0.2, 0.1, -0.9], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("blend_03_diffuse_conductor_ggx_02", 'I', [0.2, -0.3, -0.85], [-0.1, 0.3, 0.9], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("blend_03_diffuse_conductor_ggx_02", 'I', [0.2, -0.3, -0.85], [-0.3, 0.2, -0.8], [0.0000000e+00, 0.0000000e+00, 0.0000000e+00], 0.0000000e+00),
    ("blend_06_dielectric_roughdielectric_ggx_03", 'R', [0.3, 0.2, 0.9], [-0.4, -0.1, 0.8], [1.9857872e-02, 1.9857872e-02, 1.9857872e-02], 1.9975856e-02),
    ("blend_06_dielectric_roughdielectric_ggx_03", 'R', [0.3, 0.2, 0.9], [-0.2, -0.3, 0.5], [1.4865418e-02, 1.4865418e-02, 1.4865418e-02], 1.5037353e-02),
    ("blend_06_dielectric_roughdielectric_ggx_03", 'R', [0.3, 0.2, 0.9], [-0.2, 0.1, -0.9], [1.5723483e-01, 1.5723483e-01, 1.5723483e-01], 3.5624775e-01),
    ("blend_06_dielectric_roughdielectric_ggx_03", 'R', [0.2, -0.3, -0.85], [-0.1, 0.3, 0.9], [1.0860227e+00, 1.0860227e+00, 1.0860227e+00], 4.8132542e-01),
    ("blend_06_dielectric_roughdielectric_ggx_03", 'R', [0.2, -0.3, -0.85], [-0.3, 0.2, -0.8], [2.1824893e-02, 2.1824893e-02, 2.1824893e-02], 2.1924190e-02),
    ("blend_06_dielectric_roughdielectric_ggx_03", 'I', [0.3, 0.2, 0.9], [-0.4, -0.1, 0.8], [1.9857872e-02, 1.9857872e-02, 1.9857872e-02], 1.9975856e-02),
    ("blend_06_dielectric_roughdielectric_ggx_03", 'I', [0.3, 0.2, 0.9], [-0.2, -0.3, 0.5], [1.4865418e-02, 1.4865418e-02, 1.4865418e-02], 1.5037353e-02),
    ("blend_06_dielectric_roughdielectric_ggx_03", 'I', [0.3, 0.2, 0.9], [-0.2, 0.1, -0.9], [3.5575438e-01, 3.5575438e-01, 3.5575438e-01], 3.5624775e-01),
    ("blend_06_dielectric_roughdielectric_ggx_03", 'I', [0.2, -0.3, -0.85], [-0.1, 0.3, 0.9], [4.7999570e-01, 4.7999570e-01, 4.7999570e-01], 4.8132542e-01),
    ("blend_06_dielectric_roughdielectric_ggx_03", 'I', [0.2, -0.3, -0.85], [-0.3, 0.2, -0.8], [2.1824893e-02, 2.1824893e-02, 2.1824893e-02], 2.1924190e-02),
];

const GLASS: f32 = 1.5046 / 1.000277;
const POLYPROPYLENE: f32 = 1.49 / 1.000277;

fn metal(d: Microfacet) -> Material {
    Material::Conductor(Conductor {
        eta: Rgb::new(0.2, 0.9, 1.1),
        k: Rgb::new(3.9, 2.4, 1.6),
        distribution: d,
        specular_reflectance: Rgb::ONE,
        two_sided: false,
    })
}

fn glass(d: Microfacet) -> Material {
    Material::RoughDielectric(RoughDielectric {
        eta: GLASS,
        distribution: d,
        specular_reflectance: Rgb::ONE,
        specular_transmittance: Rgb::ONE,
    })
}

fn coating(nonlinear: bool) -> Coating {
    Coating {
        diffuse_reflectance: Rgb::new(0.3, 0.5, 0.7),
        specular_reflectance: Rgb::ONE,
        eta: POLYPROPYLENE,
        nonlinear,
    }
}

/// Mitsuba 3's `blendbsdf`: (1 - w) a + w b.
fn blend(w: f32, a: Material, b: Material) -> Material {
    Material::Mixture(Box::new(Mixture {
        components: vec![a, b],
        weights: vec![1.0 - w, w],
    }))
}

/// The material of a row's name, and its relative tolerance.
fn material(name: &str) -> (Material, f64) {
    use Distribution::{Beckmann, Ggx};
    let plastic = |nonlinear| {
        Material::Plastic(Plastic {
            coating: coating(nonlinear),
            two_sided: false,
        })
    };
    let rough =
        |nonlinear, d| Material::RoughPlastic(RoughPlastic::new(coating(nonlinear), d, false));
    match name {
        "conductor_beckmann_03" => (metal(Microfacet::new(Beckmann, 0.3, 0.3)), 1e-2),
        "conductor_ggx_01_04" => (metal(Microfacet::new(Ggx, 0.1, 0.4)), 1e-4),
        "dielectric_beckmann_03" => (glass(Microfacet::new(Beckmann, 0.3, 0.3)), 1e-2),
        "dielectric_ggx_02_05" => (glass(Microfacet::new(Ggx, 0.2, 0.5)), 1e-4),
        "plastic" => (plastic(false), 1e-4),
        "plastic_nonlinear" => (plastic(true), 1e-4),
        "roughplastic_beckmann_02" => (rough(false, Microfacet::new(Beckmann, 0.2, 0.2)), 1e-2),
        "roughplastic_ggx_03_nonlinear" => (rough(true, Microfacet::new(Ggx, 0.3, 0.3)), 1e-2),
        "blend_03_diffuse_conductor_ggx_02" => {
            let diffuse = Material::Diffuse(Diffuse {
                reflectance: Rgb::new(0.3, 0.5, 0.7),
                two_sided: false,
            });
            (
                blend(0.3, diffuse, metal(Microfacet::new(Ggx, 0.2, 0.2))),
                1e-4,
            )
        }
        "blend_06_dielectric_roughdielectric_ggx_03" => {
            let smooth = Material::Dielectric(Dielectric {
                eta: GLASS,
                specular_reflectance: Rgb::ONE,
                specular_transmittance: Rgb::ONE,
            });
            (
                blend(0.6, smooth, glass(Microfacet::new(Ggx, 0.3, 0.3))),
                1e-4,
            )
        }
        other => panic!("no material {other}"),
    }
}

fn close(got: f32, want: f32, rel: f64) -> bool {
    let (g, w) = (got as f64, want as f64);
    (g - w).abs() <= rel * w.abs().max(1e-6)
}

#[test]
fn bsdf_eval_and_pdf_match_mitsuba() {
    let mut compared = 0;
    // Rough plastic tabulates its coating when built: once per material.
    let mut built: std::collections::HashMap<&str, (Material, f64)> = Default::default();
    for &(name, mode, wo, wi, f, pdf) in MITSUBA {
        let (m, rel) = built.entry(name).or_insert_with(|| material(name));
        let rel = *rel;
        let mode = if mode == 'R' {
            Mode::Radiance
        } else {
            Mode::Importance
        };
        let (wo, wi) = (Vec3::from(wo).normalize(), Vec3::from(wi).normalize());
        let got = m.eval(wo, wi, mode);
        for c in 0..3 {
            assert!(
                close(got[c], f[c], rel),
                "{name} {mode:?} wo {wo} wi {wi}: eval {got} vs Mitsuba {f:?}"
            );
        }
        let got = m.pdf(wo, wi);
        assert!(
            close(got, pdf, rel),
            "{name} wo {wo} wi {wi}: pdf {got} vs Mitsuba {pdf}"
        );
        compared += (pdf > 0.0) as usize;
    }
    assert!(compared >= 40, "{compared}");
}
