//! Shapes to world-space primitives: meshes (inline, files, the built-in rectangle and
//! cube) as triangles, parallelograms merged into quads, analytic spheres and disks,
//! with their shading normals and texture coordinates. Imports `format`, `meshes`,
//! `cube`, `files` and `load` (transforms).

use super::cube;
use super::error::{Result, SceneError};
use super::files::resolve;
use super::format::*;
use super::load::transform_matrix;
use super::meshes::{load_obj, load_ply, MeshData};
use super::{CompileBudget, SceneStats};
use crate::geometry::uv::corner_map;
use crate::geometry::{Prim, PrimMeta, TexCoords};
use crate::math::{Mat3, Mat4, Vec2, Vec3};
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

/// One shape's primitives with what hits on them need.
pub(super) struct BuiltShape {
    pub(super) prims: Vec<Prim>,
    pub(super) shading: Option<ShadingNormals>,
    pub(super) uvs: Option<TexCoords>,
}

/// Builds the primitives of every shape; returns them with the per-shape info.
pub(super) struct Builder<'a> {
    pub(super) base: Option<&'a Path>,
    pub(super) budget: &'a CompileBudget,
    pub(super) prims: Vec<Prim>,
    pub(super) meta: Vec<PrimMeta>,
    pub(super) stats: SceneStats,
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
    pub(super) fn shape(
        &mut self,
        index: u32,
        path: &str,
        s: &ShapeDesc,
        uv: bool,
    ) -> Result<BuiltShape> {
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
pub(super) fn similarity_scale(l: Mat3) -> Option<f32> {
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
        assert_eq!(
            merge_parallelograms(&cube.indices, &cube.positions, None)
                .0
                .len(),
            6
        );
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
