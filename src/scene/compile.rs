//! Compiling a validated scene file: materials, media, shapes and lights to their
//! enums and primitives, the BVH over them, light selection and the camera.
//! Imports `shapes`, `materials`, `lights`, `emitters`, `media`, `textures`.

use super::emitters;
use super::error::Result;
use super::format::*;
use super::lights::{light, light_medium};
use super::materials::material;
use super::shapes::{Builder, BuiltShape};
use super::tangent::Tangents;
use super::textures::Textures;
use super::{CompileBudget, Scene, SceneStats, ShapeInfo};
use crate::camera::Camera;
use crate::geometry::{Accel, Prim, PrimMeta};
use crate::light::{Light, LightSampler, SceneSphere};
use crate::material::Material;
use crate::math::{Vec2, Vec3};
use std::collections::BTreeMap;
use std::path::Path;

fn camera(file: &SceneFile) -> Camera {
    let c = &file.camera;
    Camera::new(
        c.look_at.origin.into(),
        c.look_at.target.into(),
        c.look_at.up.into(),
        c.fov,
        c.fov_axis == FovAxis::X,
        file.film.width,
        file.film.height,
        c.aperture_radius,
        c.focus_distance,
    )
}

pub fn compile(file: &SceneFile, base: Option<&Path>, budget: &CompileBudget) -> Result<Scene> {
    let names: BTreeMap<&str, u32> = file
        .materials
        .keys()
        .enumerate()
        .map(|(i, k)| (k.as_str(), i as u32))
        .collect();
    let mut textures = Textures::new(base, budget);
    let textured = (file.materials.iter())
        .map(|(name, m)| textures.material(name, m))
        .collect::<Result<Vec<_>>>()?;
    let opacity = (file.materials.iter())
        .map(|(name, m)| textures.opacity(name, m))
        .collect::<Result<Vec<_>>>()?;
    let perturb = (file.materials.iter())
        .map(|(name, m)| textures.perturb(name, m))
        .collect::<Result<Vec<_>>>()?;
    // A textured parameter's template value is the texture's at the centre of
    // (u, v): what the albedo estimate (`Material::albedo`) reads.
    let materials: Vec<Material> = (file.materials.values().zip(&textured))
        .map(|(m, t)| {
            let m = material(m);
            t.as_ref()
                .map_or(m.clone(), |t| t.template(&m, Vec2::splat(0.5)))
        })
        .collect();
    let medium_names: BTreeMap<&str, u32> = file
        .media
        .keys()
        .enumerate()
        .map(|(i, k)| (k.as_str(), i as u32))
        .collect();
    let media = file
        .media
        .iter()
        .map(|(name, m)| super::media::medium(&format!("media.{name}"), m, base))
        .collect::<Result<Vec<_>>>()?;
    let medium_ref = |m: &Option<String>| m.as_deref().map(|n| medium_names[n]);
    let mut b = Builder {
        base,
        budget,
        prims: Vec::new(),
        meta: Vec::new(),
        stats: SceneStats::default(),
    };
    let mut shapes = Vec::with_capacity(file.shapes.len());
    let mut lights = Vec::new();
    for (i, s) in file.shapes.iter().enumerate() {
        let path = format!("shapes[{i}]");
        let desc = &file.materials[&s.common.material];
        let oriented = super::shading::anisotropic(desc);
        let material_uv = desc.reads_uv() || oriented;
        let uv = material_uv || emitters::reads_uv(&s.common.emission);
        let BuiltShape {
            prims,
            shading,
            uvs,
        } = b.shape(i as u32, &path, s, uv)?;
        let material_index = names[s.common.material.as_str()];
        // Normal and bump maps and anisotropic roughness need dp/du; other shapes
        // carry nothing more.
        let tangents = (perturb[material_index as usize].is_some() || oriented)
            .then_some(uvs.as_ref())
            .flatten()
            .map(|t| Tangents::new(&prims, t));
        let light = emitters::area_light(&mut textures, &path, i as u32, &s.common, prims, &uvs)?;
        let light_index = light.map(|l| {
            lights.push(l);
            lights.len() as u32 - 1
        });
        shapes.push(ShapeInfo {
            name: s.common.name.clone().unwrap_or_else(|| path.clone()),
            material: material_index,
            light: light_index,
            flip: s.common.flip_normals,
            shading,
            // Only the material reads them here (the light keeps its own).
            uvs: uvs.filter(|_| material_uv),
            tangents,
            oriented,
            interior: medium_ref(&s.common.interior),
            exterior: medium_ref(&s.common.exterior),
        });
    }
    for (i, l) in file.lights.iter().enumerate() {
        lights.push(light(&format!("lights[{i}]"), l, base)?);
    }
    if b.stats.degenerate_dropped > 0 {
        tracing::warn!(
            dropped = b.stats.degenerate_dropped,
            "degenerate triangles dropped"
        );
    }
    let camera_medium = medium_ref(&file.camera.medium);
    let has_media = camera_medium.is_some()
        || shapes
            .iter()
            .any(|s: &ShapeInfo| s.interior.is_some() || s.exterior.is_some());
    let (prims, meta) = if has_media {
        (b.prims, b.meta)
    } else {
        drop_null_boundaries(b.prims, b.meta, &shapes, &materials)
    };
    let accel = Accel::build(prims, meta);
    b.stats.bvh_build = accel.build_time;
    b.stats.bvh_threads = rayon::current_num_threads();
    b.stats.bvh_bytes = accel.memory_bytes();
    b.stats.texture_bytes = textures.bytes;
    let camera = camera(file);
    let sphere = if accel.prim_count() > 0 {
        let (lo, hi) = (Vec3::from(accel.bounds.min), Vec3::from(accel.bounds.max));
        SceneSphere {
            center: 0.5 * (lo + hi),
            radius: (0.5 * (hi - lo).length()).max(1e-6),
        }
    } else {
        SceneSphere {
            center: camera.origin,
            radius: 1.0,
        }
    };
    let light_sampler = LightSampler::new(&lights, file.light_selection, &sphere);
    let env_lights = lights
        .iter()
        .enumerate()
        .filter(|(_, l)| matches!(l, Light::Constant { .. } | Light::EnvMap(_)))
        .map(|(i, _)| i as u32)
        .collect();
    let mut scene = Scene {
        media,
        camera_medium,
        has_media,
        // Masks are holes that rays, shadow rays and light paths must look through.
        has_null: opacity.iter().any(Option::is_some)
            || has_media
                && shapes
                    .iter()
                    .any(|s| matches!(materials[s.material as usize], Material::Null)),
        accel,
        shapes,
        materials,
        textured,
        opacity,
        perturb,
        lights,
        env_lights,
        light_sampler,
        camera,
        filter: crate::film::PixelFilter::new(file.film.filter.0),
        sphere,
        integrator: file.integrator.clone(),
        stats: b.stats,
        light_media: Vec::new(),
    };
    scene.light_media = (0..scene.lights.len())
        .map(|i| light_medium(&scene, i))
        .collect();
    Ok(scene)
}

/// Without media an index-matched (`null`) boundary changes nothing, so it is left
/// out of the tree: rays never stop at it and shadow rays keep the plain any-hit test.
fn drop_null_boundaries(
    prims: Vec<Prim>,
    meta: Vec<PrimMeta>,
    shapes: &[ShapeInfo],
    materials: &[Material],
) -> (Vec<Prim>, Vec<PrimMeta>) {
    prims
        .into_iter()
        .zip(meta)
        .filter(|(_, m)| {
            let material = shapes[m.shape as usize].material as usize;
            !matches!(materials[material], Material::Null)
        })
        .unzip()
}
