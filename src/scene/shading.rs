//! The local frame BSDFs are evaluated in at a hit. Its normal is the shading normal;
//! its tangent matters only to anisotropic roughness (`alpha_u` along the frame's x,
//! `alpha_v` along y), which Mitsuba 3 orients by the surface: x is dp/du made
//! orthogonal to the shading normal (`SurfaceInteraction::initialize_sh_frame`; on a
//! normal- or bump-mapped surface, orthogonal to the perturbed normal, as its
//! `normalmap`/`bumpmap` build their frames).
//!
//! Only shapes whose material is anisotropic carry that orientation (`ShapeInfo::
//! oriented`, with their tangents); every other hit gets `Frame::from_normal(ns)`, an
//! arbitrary tangent, as before, behind one branch. Stored vertices (light vertices,
//! virtual point lights) keep the frame as its normal and a twist angle
//! ([`Frame::twist`]), zero where the material is isotropic.

use super::format::MaterialDesc;
use super::Scene;
use crate::geometry::Interaction;
use crate::material::normal_map::tangent_frame;
use crate::math::{Frame, Vec3};

/// Whether a material's roughness differs along the two tangents, so that its frame
/// must follow dp/du: `alpha_u` and `alpha_v` that differ or may (textures), in the
/// material itself or in any it holds.
pub fn anisotropic(m: &MaterialDesc) -> bool {
    match m.scattering() {
        MaterialDesc::RoughConductor {
            alpha_u: Some(u),
            alpha_v: Some(v),
            ..
        }
        | MaterialDesc::RoughDielectric {
            alpha_u: Some(u),
            alpha_v: Some(v),
            ..
        } => match (u.constant(), v.constant()) {
            (Some(u), Some(v)) => u != v,
            _ => true,
        },
        other => other.components().iter().any(anisotropic),
    }
}

impl Scene {
    /// The local shading frame at a hit: the shading normal, with dp/du as its x axis
    /// where the material is anisotropic.
    #[inline(always)]
    pub fn shading_frame(&self, it: &Interaction) -> Frame {
        if self.shapes[it.shape as usize].oriented {
            match self.dpdu(*it) {
                Some(dpdu) => tangent_frame(it.ns, dpdu),
                None => Frame::from_normal(it.ns),
            }
        } else {
            Frame::from_normal(it.ns)
        }
    }

    /// The twist of `frame`, the shading frame at `it`, for a vertex that stores its
    /// normal and rebuilds the frame with [`Frame::twisted`]: exactly zero where the
    /// material is isotropic, so that those frames come back bit for bit.
    #[inline(always)]
    pub fn frame_twist(&self, it: &Interaction, frame: &Frame) -> f32 {
        if self.shapes[it.shape as usize].oriented {
            frame.twist()
        } else {
            0.0
        }
    }

    /// dp/du at a hit on an oriented shape (None without tangents). Out of line, and
    /// only the tangent returned: a frame returned from here was written through the
    /// caller's frame, which then stayed in memory on the common path too.
    #[cold]
    #[inline(never)]
    fn dpdu(&self, it: Interaction) -> Option<Vec3> {
        let tangents = self.shapes[it.shape as usize].tangents.as_ref();
        tangents.map(|t| t.at(&it).0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::load::parse_scene;

    fn scene(materials: &str, shape: &str) -> Scene {
        let json = format!(
            r#"{{"format": 1,
              "camera": {{"look_at": {{"origin": [0, 0, 5], "target": [0, 0, 0], "up": [0, 1, 0]}},
                "fov": 40}},
              "film": {{"width": 4, "height": 4}},
              "materials": {materials}, "shapes": [{shape}]}}"#
        );
        Scene::compile(&parse_scene(&json).unwrap(), None).unwrap()
    }

    #[test]
    fn anisotropic_materials_have_unequal_or_textured_alphas() {
        let m = |j: &str| serde_json::from_str::<MaterialDesc>(j).unwrap();
        let rough = |u: &str, v: &str| {
            format!(r#"{{"type": "roughconductor", "alpha_u": {u}, "alpha_v": {v}}}"#)
        };
        assert!(!anisotropic(&m(&rough("0.2", "0.2"))));
        assert!(!anisotropic(&m(
            r#"{"type": "roughconductor", "alpha": 0.2}"#
        )));
        assert!(anisotropic(&m(&rough("0.2", "0.1"))));
        let checker =
            r#"{"type": "checkerboard", "color0": [0.1, 0.1, 0.1], "color1": [0.2, 0.2, 0.2]}"#;
        assert!(anisotropic(&m(&rough(checker, "0.2"))));
        let blend = format!(
            r#"{{"type": "blend", "weight": 0.5, "materials": [{{"type": "diffuse", "reflectance": 0.5}}, {}]}}"#,
            rough("0.3", "0.1")
        );
        assert!(anisotropic(&m(&blend)));
        assert!(!anisotropic(&m(
            r#"{"type": "diffuse", "reflectance": 0.5}"#
        )));
    }

    /// A rectangle's dp/du is its x axis (Mitsuba's (u, v)): the frame of an
    /// anisotropic material follows it whatever the normal, an isotropic one keeps
    /// `from_normal`'s.
    #[test]
    fn anisotropic_frames_follow_dpdu() {
        let rect = r#"{"type": "rectangle", "material": "m",
            "transform": {"rotate": [{"axis": [1, 0, 0], "angle": 20}, {"axis": [0, 0, 1], "angle": 30}]}}"#;
        let aniso = scene(
            r#"{"m": {"type": "roughconductor", "alpha_u": 0.3, "alpha_v": 0.1}}"#,
            rect,
        );
        let ray = crate::geometry::Ray::new(Vec3::new(0.0, 0.0, 5.0), -Vec3::Z);
        let it = aniso.intersect(&ray).unwrap();
        let f = aniso.shading_frame(&it);
        let c = 30f32.to_radians();
        let x = Vec3::new(c.cos(), c.sin(), 0.0);
        let x = crate::math::Mat3::from_rotation_x(20f32.to_radians()) * x;
        assert!((f.s - x).length() < 1e-5, "{} vs {x}", f.s);
        assert!((f.s.cross(f.t) - f.n).length() < 1e-5);
        let rebuilt = Frame::twisted(f.n, aniso.frame_twist(&it, &f));
        assert!((rebuilt.s - f.s).length() < 1e-5 && (rebuilt.t - f.t).length() < 1e-5);
        let iso = scene(r#"{"m": {"type": "roughconductor", "alpha": 0.3}}"#, rect);
        let it = iso.intersect(&ray).unwrap();
        let f = iso.shading_frame(&it);
        assert_eq!(f, Frame::from_normal(it.ns));
        assert_eq!(iso.frame_twist(&it, &f), 0.0);
    }
}
