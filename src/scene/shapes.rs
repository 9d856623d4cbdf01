//! Compiling a validated scene file: shapes to world-space primitives, materials and
//! lights to their enums, and the camera.

use super::emitters;
use super::error::{Result, SceneError};
use super::format::*;
use super::cube;
use super::files::resolve;
use super::load::transform_matrix;
use super::meshes::{load_obj, load_ply, MeshData};
use super::tangent::Tangents;
use super::textures::Textures;
use super::{CompileBudget, Scene, SceneStats, ShapeInfo};
use crate::camera::Camera;
use crate::geometry::uv::corner_map;
use crate::geometry::{Accel, Prim, PrimMeta, TexCoords};
use crate::light::DirectionalLight;
use crate::light::{EnvMap, Light, LightSampler, PointLight, SceneSphere, SpotLight};
use crate::material::microfacet::{Distribution, Microfacet};
use crate::material::{
    Coating, Conductor, Dielectric, Diffuse, Material, Mirror, Mixture, Phong, Plastic,
    RoughDielectric, RoughPlastic, ThinDielectric,
};
use crate::math::{Mat3, Mat4, Rgb, Vec2, Vec3};
use std::collections::BTreeMap;
use std::path::Path;

/// World-space vertex normals of a mesh shape, indexed like its triangles.
#[derive(Clone, Debug)]
pub struct ShadingNormals {
    normals: Vec<Vec3>,
    indices: Vec<[u32; 3]>,
}

impl ShadingNormals {
    /// Interpolated normal at barycentrics (b1, b2), turned to the side of `ng`.
    #[inline]
    pub fn normal(&self, tri: u32, b: Vec2, ng: Vec3) -> Vec3 {
        let [i0, i1, i2] = self.indices[tri as usize];
        let n = self.normals[i0 as usize] * (1.0 - b.x - b.y)
            + self.normals[i1 as usize] * b.x
            + self.normals[i2 as usize] * b.y;
        let n = n.normalize_or_zero();
        if n == Vec3::ZERO {
            ng
        } else if n.dot(ng) < 0.0 {
            -n
        } else {
            n
        }
    }
}

fn rgb(v: V3) -> Rgb {
    Rgb::from(v)
}

/// A parameter's constant; a texture's value is set per hit (`Textured`), and its
/// template value here is overwritten at compile time.
fn constant(p: &Param) -> Rgb {
    p.constant().map_or(Rgb::ZERO, rgb)
}

fn material(m: &MaterialDesc) -> Material {
    match m {
        MaterialDesc::Diffuse {
            reflectance,
            two_sided,
        } => Material::Diffuse(Diffuse {
            reflectance: constant(reflectance),
            two_sided: *two_sided,
        }),
        MaterialDesc::Phong {
            kd,
            ks,
            exponent,
            two_sided,
        } => Material::Phong(Phong::new(rgb(*kd), rgb(*ks), *exponent, *two_sided)),
        MaterialDesc::Mirror {
            reflectance,
            two_sided,
        } => Material::Mirror(Mirror {
            reflectance: constant(reflectance),
            two_sided: *two_sided,
        }),
        MaterialDesc::Dielectric {
            int_ior,
            ext_ior,
            specular_reflectance,
            specular_transmittance,
        } => Material::Dielectric(Dielectric {
            eta: int_ior / ext_ior,
            specular_reflectance: constant(specular_reflectance),
            specular_transmittance: constant(specular_transmittance),
        }),
        MaterialDesc::Conductor {
            eta,
            k,
            roughness,
            specular_reflectance,
            two_sided,
        } => Material::Conductor(Conductor {
            eta: rgb(*eta),
            k: rgb(*k),
            distribution: Microfacet::new(Distribution::Ggx, *roughness, *roughness),
            specular_reflectance: constant(specular_reflectance),
            two_sided: *two_sided,
        }),
        MaterialDesc::RoughConductor {
            distribution,
            alpha,
            alpha_u,
            alpha_v,
            eta,
            k,
            specular_reflectance,
            two_sided,
        } => Material::Conductor(Conductor {
            eta: rgb(*eta),
            k: rgb(*k),
            distribution: microfacet(*distribution, alpha, alpha_u, alpha_v),
            specular_reflectance: constant(specular_reflectance),
            two_sided: *two_sided,
        }),
        MaterialDesc::RoughDielectric {
            distribution,
            alpha,
            alpha_u,
            alpha_v,
            int_ior,
            ext_ior,
            specular_reflectance,
            specular_transmittance,
        } => {
            let distribution = microfacet(*distribution, alpha, alpha_u, alpha_v);
            let (eta, r, t) = (
                int_ior / ext_ior,
                constant(specular_reflectance),
                constant(specular_transmittance),
            );
            // Below the smooth threshold the lobes are Dirac deltas: the smooth
            // interface renders the same image without the lobes' float trouble. (A
            // textured roughness decides per hit: `Textured::resolve`.)
            let textured = [alpha, alpha_u, alpha_v]
                .iter()
                .any(|a| a.as_ref().is_some_and(|a| a.0.is_texture()));
            if distribution.is_smooth() && !textured {
                Material::Dielectric(Dielectric {
                    eta,
                    specular_reflectance: r,
                    specular_transmittance: t,
                })
            } else {
                Material::RoughDielectric(RoughDielectric {
                    eta,
                    distribution,
                    specular_reflectance: r,
                    specular_transmittance: t,
                })
            }
        }
        MaterialDesc::Plastic {
            diffuse_reflectance,
            specular_reflectance,
            int_ior,
            ext_ior,
            nonlinear,
            two_sided,
        } => Material::Plastic(Plastic {
            coating: Coating {
                diffuse_reflectance: constant(diffuse_reflectance),
                specular_reflectance: rgb(*specular_reflectance),
                eta: int_ior / ext_ior,
                nonlinear: *nonlinear,
            },
            two_sided: *two_sided,
        }),
        MaterialDesc::RoughPlastic {
            distribution,
            alpha,
            diffuse_reflectance,
            specular_reflectance,
            int_ior,
            ext_ior,
            nonlinear,
            two_sided,
        } => {
            let coating = Coating {
                diffuse_reflectance: constant(diffuse_reflectance),
                specular_reflectance: rgb(*specular_reflectance),
                eta: int_ior / ext_ior,
                nonlinear: *nonlinear,
            };
            let d = microfacet(*distribution, &Some(Scalar::value(*alpha)), &None, &None);
            if d.is_smooth() {
                Material::Plastic(Plastic {
                    coating,
                    two_sided: *two_sided,
                })
            } else {
                Material::RoughPlastic(RoughPlastic::new(coating, d, *two_sided))
            }
        }
        MaterialDesc::ThinDielectric {
            int_ior,
            ext_ior,
            specular_reflectance,
            specular_transmittance,
        } => Material::ThinDielectric(ThinDielectric {
            eta: int_ior / ext_ior,
            specular_reflectance: rgb(*specular_reflectance),
            specular_transmittance: rgb(*specular_transmittance),
        }),
        MaterialDesc::Null {} => Material::Null,
        MaterialDesc::Mask { material: m, .. }
        | MaterialDesc::NormalMap { material: m, .. }
        | MaterialDesc::BumpMap { material: m, .. } => material(m),
        MaterialDesc::Mixture { weights, materials } => {
            // Mitsuba 0.x divides weights that sum past 1 by their sum.
            let sum: f32 = weights.iter().sum();
            let scale = if sum > 1.0 { 1.0 / sum } else { 1.0 };
            mixture(materials, weights.iter().map(|w| w * scale).collect())
        }
        MaterialDesc::Blend { weight, materials } => {
            // A textured weight's template value is set per hit.
            let w = weight.constant().unwrap_or(0.5);
            mixture(materials, vec![1.0 - w, w])
        }
    }
}

fn mixture(materials: &[MaterialDesc], weights: Vec<f32>) -> Material {
    Material::Mixture(Box::new(Mixture {
        components: materials.iter().map(material).collect(),
        weights,
    }))
}

fn microfacet(
    d: DistributionDesc,
    alpha: &Option<Scalar>,
    alpha_u: &Option<Scalar>,
    alpha_v: &Option<Scalar>,
) -> Microfacet {
    let kind = match d {
        DistributionDesc::Beckmann => Distribution::Beckmann,
        DistributionDesc::Ggx => Distribution::Ggx,
    };
    let (au, av) = alphas(alpha, alpha_u, alpha_v);
    Microfacet::new(kind, au, av)
}

/// One shape's primitives with what hits on them need.
struct BuiltShape {
    prims: Vec<Prim>,
    shading: Option<ShadingNormals>,
    uvs: Option<TexCoords>,
}

/// Builds the primitives of every shape; returns them with the per-shape info.
struct Builder<'a> {
    base: Option<&'a Path>,
    budget: &'a CompileBudget,
    prims: Vec<Prim>,
    meta: Vec<PrimMeta>,
    stats: SceneStats,
}

impl Builder<'_> {
    /// The mesh of a shape; `uv` asks for Mitsuba's texture coordinates where the
    /// geometry defines them (the cube then takes Mitsuba's layout of 24 vertices).
    fn mesh(&mut self, path: &str, g: &GeometryDesc, uv: bool) -> Result<MeshData> {
        let v = |a: &[V3]| a.iter().map(|p| Vec3::from(*p)).collect::<Vec<_>>();
        Ok(match g {
            GeometryDesc::Rectangle { corners } => {
                let c = corners.unwrap_or([
                    [-1.0, -1.0, 0.0],
                    [1.0, -1.0, 0.0],
                    [1.0, 1.0, 0.0],
                    [-1.0, 1.0, 0.0],
                ]);
                MeshData {
                    positions: v(&c),
                    normals: None,
                    // Mitsuba's rectangle: (u, v) = ((x + 1) / 2, (y + 1) / 2).
                    uvs: Some(vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y]),
                    indices: vec![[0, 1, 2], [0, 2, 3]],
                }
            }
            GeometryDesc::Cube {} if uv => cube::textured(),
            GeometryDesc::Cube {} => cube::plain(),
            GeometryDesc::Mesh {
                positions,
                indices,
                normals,
                uvs,
            } => MeshData {
                positions: v(positions),
                normals: normals.as_ref().map(|n| v(n)),
                uvs: uvs
                    .as_ref()
                    .map(|t| t.iter().map(|&c| Vec2::from(c)).collect()),
                indices: indices.clone(),
            },
            GeometryDesc::Obj { filename } | GeometryDesc::Ply { filename } => {
                let field = format!("{path}.filename");
                let base = self.base.ok_or_else(|| {
                    SceneError::new(&field, "file references need a scene folder")
                })?;
                let full = resolve(base, &field, filename)?;
                if matches!(g, GeometryDesc::Obj { .. }) {
                    load_obj(&full, &field, filename)?
                } else {
                    load_ply(&full, &field, filename)?
                }
            }
            GeometryDesc::Sphere { .. } | GeometryDesc::Disk {} => unreachable!("analytic"),
        })
    }

    /// Adds one shape's primitives; returns them (for an area light) with its
    /// normals and, when `uv` asks for them, its texture coordinates.
    fn shape(&mut self, index: u32, path: &str, s: &ShapeDesc, uv: bool) -> Result<BuiltShape> {
        let m = transform_matrix(s.common.transform.as_ref());
        let mirrored = m.determinant() < 0.0;
        let lin = Mat3::from_mat4(m);
        let prims: Vec<Prim>;
        let mut shading = None;
        let uvs;
        match &s.geometry {
            GeometryDesc::Sphere { center, radius } => {
                let scale = similarity_scale(lin).ok_or_else(|| {
                    SceneError::new(
                        format!("{path}.transform"),
                        "a sphere may only be translated, rotated and scaled uniformly",
                    )
                })?;
                let c = m.transform_point3(Vec3::from(*center));
                prims = vec![Prim::Sphere {
                    c: c.into(),
                    r: radius * scale,
                }];
                uvs = uv.then(|| TexCoords::Sphere {
                    center: c,
                    to_object: (lin * (1.0 / scale)).transpose(),
                });
                self.stats.spheres += 1;
            }
            GeometryDesc::Disk {} => {
                let (mut u, mut v) = (lin * Vec3::X, lin * Vec3::Y);
                if mirrored {
                    std::mem::swap(&mut u, &mut v);
                }
                prims = vec![Prim::Disk {
                    c: m.transform_point3(Vec3::ZERO).into(),
                    u: u.into(),
                    v: v.into(),
                }];
                uvs = uv.then_some(TexCoords::Disk { swapped: mirrored });
                self.stats.disks += 1;
            }
            g => {
                let mesh = self.mesh(path, g, uv)?;
                let built = self.triangles(&m, mirrored, mesh, uv);
                prims = built.prims;
                shading = built.shading;
                uvs = built.uvs;
            }
        }
        self.budget
            .check_primitives(path, self.prims.len() + prims.len())?;
        for (k, p) in prims.iter().enumerate() {
            self.prims.push(*p);
            self.meta.push(PrimMeta {
                shape: index,
                local: k as u32,
            });
        }
        Ok(BuiltShape {
            prims,
            shading,
            uvs,
        })
    }

    /// World-space triangles; degenerate ones are dropped and counted. Without shading
    /// normals (which are interpolated per triangle), consecutive triangles that form a
    /// parallelogram (in (u, v) too, when `uv` asks for texture coordinates) become one
    /// [`Prim::Quad`].
    fn triangles(&mut self, m: &Mat4, mirrored: bool, mesh: MeshData, uv: bool) -> BuiltShape {
        let pos: Vec<Vec3> = mesh
            .positions
            .iter()
            .map(|p| m.transform_point3(*p))
            .collect();
        let normal_m = Mat3::from_mat4(*m).inverse().transpose();
        let mut kept = Vec::with_capacity(mesh.indices.len());
        for &[a, mut b, mut c] in &mesh.indices {
            // A mirroring transform reverses the winding; restore the front side.
            if mirrored {
                std::mem::swap(&mut b, &mut c);
            }
            let (p0, p1, p2) = (pos[a as usize], pos[b as usize], pos[c as usize]);
            let n = (p1 - p0).cross(p2 - p0);
            if n.length_squared() <= 0.0 || !n.is_finite() {
                self.stats.degenerate_dropped += 1;
                continue;
            }
            kept.push([a, b, c]);
        }
        self.stats.triangles += kept.len();
        let vertex_uvs = mesh.uvs.as_deref().filter(|_| uv);
        let uvs = |corners: &[[u32; 3]]| match vertex_uvs {
            Some(t) => TexCoords::Mesh(
                corners
                    .iter()
                    .map(|c| corner_map(c.map(|i| t[i as usize])))
                    .collect(),
            ),
            // Mitsuba's rule for a mesh without texture coordinates: each
            // triangle's barycentrics.
            None => TexCoords::Mesh(vec![
                corner_map([Vec2::ZERO, Vec2::X, Vec2::Y]);
                corners.len()
            ]),
        };
        let Some(ns) = mesh.normals else {
            let may_merge = !uv || vertex_uvs.is_some();
            let (prims, corners) = if may_merge {
                merge_parallelograms(&kept, &pos, vertex_uvs)
            } else {
                (
                    kept.iter().map(|&t| triangle(t, &pos)).collect(),
                    kept.clone(),
                )
            };
            self.stats.quads += kept.len() - prims.len();
            return BuiltShape {
                prims,
                shading: None,
                uvs: uv.then(|| uvs(&corners)),
            };
        };
        let prims = kept.iter().map(|&t| triangle(t, &pos)).collect();
        let tex = uv.then(|| uvs(&kept));
        let shading = ShadingNormals {
            normals: ns
                .iter()
                .map(|n| (normal_m * *n).normalize_or_zero())
                .collect(),
            indices: kept,
        };
        BuiltShape {
            prims,
            shading: Some(shading),
            uvs: tex,
        }
    }
}

fn triangle([a, b, c]: [u32; 3], pos: &[Vec3]) -> Prim {
    let p0 = pos[a as usize];
    Prim::Tri {
        p0: p0.into(),
        e1: (pos[b as usize] - p0).into(),
        e2: (pos[c as usize] - p0).into(),
    }
}

/// Triangles in mesh order, each pair of consecutive ones that forms a parallelogram
/// (how rectangles, cubes and most quad meshes are split) as one [`Prim::Quad`]; with
/// each primitive, its corners in the order it is parametrised (p0, the ends of e1
/// and e2). With texture coordinates, a pair merges only where they form a
/// parallelogram as well.
fn merge_parallelograms(
    tris: &[[u32; 3]],
    pos: &[Vec3],
    uvs: Option<&[Vec2]>,
) -> (Vec<Prim>, Vec<[u32; 3]>) {
    let mut prims = Vec::with_capacity(tris.len());
    let mut corners = Vec::with_capacity(tris.len());
    let mut i = 0;
    while i < tris.len() {
        match tris
            .get(i + 1)
            .and_then(|&next| parallelogram(tris[i], next, pos, uvs))
        {
            Some((q, c)) => {
                prims.push(q);
                corners.push(c);
                i += 2;
            }
            None => {
                prims.push(triangle(tris[i], pos));
                corners.push(tris[i]);
                i += 1;
            }
        }
    }
    (prims, corners)
}

/// The parallelogram made of two triangles that share an edge, traverse it in
/// opposite directions (consistent winding), and whose far corners are reflections of
/// each other through the edge's midpoint, to within rounding of the vertex positions.
fn parallelogram(
    t1: [u32; 3],
    t2: [u32; 3],
    pos: &[Vec3],
    uvs: Option<&[Vec2]>,
) -> Option<(Prim, [u32; 3])> {
    // Rotate each triangle to start at its vertex off the shared edge.
    let own = |t: [u32; 3], other: [u32; 3]| {
        let k = (0..3).find(|&k| !other.contains(&t[k]))?;
        Some([t[k], t[(k + 1) % 3], t[(k + 2) % 3]])
    };
    let [a, s, t] = own(t1, t2)?;
    let [b, x, y] = own(t2, t1)?;
    if (x, y) != (t, s) {
        return None;
    }
    let p = |i: u32| pos[i as usize];
    let scale = [p(a), p(s), p(t), p(b)]
        .iter()
        .map(|q| q.abs().max_element())
        .fold(0.0f32, f32::max);
    let gap = (p(s) + p(t) - p(a) - p(b)).abs().max_element();
    let flat_uv = uvs.is_none_or(|uv| {
        let q = |i: u32| uv[i as usize];
        let scale = [q(a), q(s), q(t), q(b)]
            .iter()
            .map(|c| c.abs().max_element())
            .fold(0.0f32, f32::max);
        (q(s) + q(t) - q(a) - q(b)).abs().max_element() <= 8.0 * f32::EPSILON * scale
    });
    (gap <= 8.0 * f32::EPSILON * scale && flat_uv).then(|| {
        let quad = Prim::Quad {
            p0: p(a).into(),
            e1: (p(s) - p(a)).into(),
            e2: (p(t) - p(a)).into(),
        };
        (quad, [a, s, t])
    })
}

/// The uniform scale of a similarity transform's linear part, if it is one.
fn similarity_scale(l: Mat3) -> Option<f32> {
    let (a, b, c) = (l.x_axis, l.y_axis, l.z_axis);
    let s = a.length();
    let tol = 1e-4 * s;
    let ok = (b.length() - s).abs() <= tol
        && (c.length() - s).abs() <= tol
        && a.dot(b).abs() <= tol * s
        && a.dot(c).abs() <= tol * s
        && b.dot(c).abs() <= tol * s;
    (ok && s > 0.0).then_some(s)
}

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

fn light(path: &str, l: &LightDesc, base: Option<&Path>) -> Result<Light> {
    Ok(match l {
        LightDesc::Point {
            position,
            intensity,
        } => Light::Point(PointLight {
            position: (*position).into(),
            intensity: rgb(*intensity),
        }),
        LightDesc::Spot {
            position,
            target,
            intensity,
            cutoff_angle,
            beam_width,
        } => {
            let p = Vec3::from(*position);
            Light::Spot(SpotLight::new(
                p,
                Vec3::from(*target) - p,
                rgb(*intensity),
                cutoff_angle.to_radians(),
                beam_width.unwrap_or(cutoff_angle * 0.75).to_radians(),
            ))
        }
        LightDesc::Directional {
            direction,
            irradiance,
        } => Light::Directional(DirectionalLight {
            direction: Vec3::from(*direction).normalize(),
            irradiance: rgb(*irradiance),
        }),
        LightDesc::Constant { radiance } => Light::Constant {
            radiance: rgb(*radiance),
        },
        LightDesc::Envmap {
            filename,
            scale,
            transform,
        } => {
            let field = format!("{path}.filename");
            let base =
                base.ok_or_else(|| SceneError::new(&field, "file references need a scene folder"))?;
            let full = resolve(base, &field, filename)?;
            // Named as the scene names it: the server shows the message to clients.
            let img = crate::film::read_exr_named(&full, filename)
                .map_err(|e| SceneError::new(&field, e.to_string()))?;
            let texels: Vec<Rgb> = img.pixels().iter().map(|p| *p * *scale).collect();
            if texels.iter().any(|t| !crate::math::is_valid_radiance(*t)) {
                return Err(SceneError::new(
                    &field,
                    "the map holds NaN, infinite or negative values",
                ));
            }
            let rot = Mat3::from_mat4(transform_matrix(transform.as_ref()));
            if similarity_scale(rot).is_none_or(|s| (s - 1.0).abs() > 1e-3) {
                return Err(SceneError::new(
                    format!("{path}.transform"),
                    "an environment map may only be rotated",
                ));
            }
            Light::EnvMap(EnvMap::new(
                img.width() as usize,
                img.height() as usize,
                texels,
                rot,
            ))
        }
    })
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

/// The medium a light emits into: an area light on a medium boundary emits into the
/// medium on its normal side; other lights sit in whatever medium surrounds them.
fn light_medium(scene: &Scene, i: usize) -> Option<u32> {
    if !scene.has_media {
        return None;
    }
    match &scene.lights[i] {
        Light::Area(a) => {
            let shape = &scene.shapes[a.shape as usize];
            if shape.is_medium_boundary() {
                return shape.exterior;
            }
            let (p, n) = a.sample_area(0.5, crate::math::Vec2::splat(0.5));
            scene.medium_at(p + n * 1e-4 * (1.0 + p.abs().max_element()))
        }
        Light::Point(l) => scene.medium_at(l.position),
        Light::Spot(l) => scene.medium_at(l.position),
        // Light from infinity arrives through whatever surrounds the scene.
        _ => scene.medium_at(scene.sphere.center + Vec3::Y * 2.0 * scene.sphere.radius),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quads(tris: &[[u32; 3]], pos: &[Vec3]) -> usize {
        merge_parallelograms(tris, pos, None)
            .0
            .iter()
            .filter(|p| matches!(p, Prim::Quad { .. }))
            .count()
    }

    #[test]
    fn parallelogram_pairs_merge_and_nothing_else() {
        let skew = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(2.0, 0.5, 0.0),
            Vec3::new(2.5, 1.5, 0.0),
            Vec3::new(0.5, 1.0, 0.0),
        ];
        // A fan split and the other diagonal both merge, with the front side kept.
        for tris in [[[0, 1, 2], [0, 2, 3]], [[0, 1, 3], [1, 2, 3]]] {
            let (prims, corners) = merge_parallelograms(&tris, &skew, None);
            assert_eq!(corners.len(), 1);
            assert_eq!(prims.len(), 1, "{tris:?}");
            let n = prims[0].flat_normal();
            assert!(n.z > 0.99, "{tris:?}: normal {n}");
            assert!((prims[0].area() - 2.0 * triangle(tris[0], &skew).area()).abs() < 1e-5);
        }
        // Opposite windings (one triangle facing away) stay triangles.
        assert_eq!(quads(&[[0, 1, 2], [0, 3, 2]], &skew), 0);
        // A trapezoid is not a parallelogram.
        let mut trap = skew;
        trap[3].x += 0.25;
        assert_eq!(quads(&[[0, 1, 2], [0, 2, 3]], &trap), 0);
        // Nor is a non-planar quad.
        let mut bent = skew;
        bent[3].z = 0.01;
        assert_eq!(quads(&[[0, 1, 2], [0, 2, 3]], &bent), 0);
        // Triangles that share one vertex only, or none, stay apart.
        let pos = [skew.as_slice(), &[Vec3::new(3.0, 3.0, 0.0)]].concat();
        assert_eq!(quads(&[[0, 1, 2], [2, 4, 3]], &pos), 0);
        // A cube merges into six faces.
        let cube = cube::plain();
        assert_eq!(merge_parallelograms(&cube.indices, &cube.positions, None).0.len(), 6);
        // Mitsuba's cube with its (u, v) merges too, each face's map a unit square.
        let m = cube::textured();
        let (prims, corners) = merge_parallelograms(&m.indices, &m.positions, m.uvs.as_deref());
        assert_eq!(prims.len(), 6);
        let t = m.uvs.unwrap();
        for c in corners {
            let [o, a, b] = corner_map(c.map(|i| t[i as usize]));
            let far = o + a + b;
            assert!(
                a.abs().max_element() == 1.0 && b.abs().max_element() == 1.0,
                "{a} {b}"
            );
            assert!(
                far.cmpge(Vec2::ZERO).all() && far.cmple(Vec2::ONE).all(),
                "{far}"
            );
        }
        // Texture coordinates that do not form a parallelogram keep two triangles.
        let uvs = [Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::new(0.0, 2.0)];
        assert_eq!(
            merge_parallelograms(&[[0, 1, 2], [0, 2, 3]], &skew, Some(&uvs))
                .0
                .len(),
            2
        );
    }
}
