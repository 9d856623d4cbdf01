//! Bounds on the work of compiling one scene. The BVH build is O(n log n) in the
//! primitive count whatever the geometry (`geometry::bvh`), and the light
//! distributions are linear in it, so the count bounds a compile's time and memory
//! (at its peak about 1 KiB a primitive, most of it the binary tree, its flattening
//! and the primitives' copies). Meshes are read before they are counted, but one mesh
//! is bounded by the upload; the count catches the amplification, many shapes naming
//! one file.

use super::error::{Result, SceneError};
use crate::geometry::Accel;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CompileBudget {
    /// Triangles, parallelograms, spheres and disks in the whole scene.
    pub max_primitives: usize,
    /// Decoded texture images, in bytes (8-bit images are kept as bytes, others as
    /// f32).
    pub max_texture_bytes: usize,
}

impl CompileBudget {
    /// As much as the BVH can hold: for scenes a user compiles on their own machine.
    pub const LOCAL: CompileBudget = CompileBudget {
        max_primitives: Accel::MAX_PRIMITIVES,
        max_texture_bytes: usize::MAX,
    };

    /// For scenes a server compiles for its clients: 2^21 primitives (a 2M-triangle
    /// mesh), about 2 GiB at the compile's peak and 10 s of this 2-core machine.
    pub const SERVER: CompileBudget = CompileBudget {
        max_primitives: 1 << 21,
        max_texture_bytes: 1 << 30,
    };

    /// Refuses the shape at `path` when it brings the scene to `total` primitives
    /// beyond the budget.
    pub fn check_primitives(&self, path: &str, total: usize) -> Result<()> {
        if total <= self.max_primitives {
            return Ok(());
        }
        Err(SceneError::new(
            path,
            format!(
                "brings the scene to {total} primitives (triangles, parallelograms, spheres \
                 and disks), above the limit of {}",
                self.max_primitives
            ),
        ))
    }
}

impl CompileBudget {
    /// Refuses the texture at `field` when it brings the scene's decoded images to
    /// `total` bytes beyond the budget.
    pub fn check_texture_bytes(&self, field: &str, total: usize) -> Result<()> {
        if total <= self.max_texture_bytes {
            return Ok(());
        }
        Err(SceneError::new(
            field,
            format!(
                "brings the scene's decoded textures to {} MiB, above the limit of {} MiB",
                total.div_ceil(1 << 20),
                self.max_texture_bytes >> 20
            ),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{load::parse_scene, Scene};

    /// A sphere, then a cube (six parallelograms), then a sphere.
    const SCENE: &str = r#"{"format":1,
        "camera":{"look_at":{"origin":[0,1,4],"target":[0,0,0],"up":[0,1,0]},"fov":45},
        "film":{"width":8,"height":8},
        "materials":{"m":{"type":"diffuse","reflectance":[0.5,0.5,0.5]}},
        "shapes":[{"type":"sphere","radius":0.5,"material":"m"},
                  {"type":"cube","material":"m"},
                  {"type":"sphere","radius":0.2,"material":"m"}],
        "lights":[{"type":"point","position":[1,3,2],"intensity":[8,8,8]}]}"#;

    fn compile(max_primitives: usize) -> crate::scene::error::Result<Scene> {
        let file = parse_scene(SCENE).unwrap();
        Scene::compile_within(
            &file,
            None,
            &CompileBudget {
                max_primitives,
                ..CompileBudget::LOCAL
            },
        )
    }

    /// The shape that crosses the limit is named, with the count and the limit.
    #[test]
    fn the_shape_past_the_limit_is_refused() {
        assert_eq!(compile(8).unwrap().accel.prim_count(), 8);
        let e = compile(7).err().expect("past the limit");
        assert_eq!(e.path, "shapes[2]");
        assert!(e.message.contains("to 8 primitives"), "{e}");
        assert!(e.message.contains("limit of 7"), "{e}");
        assert_eq!(compile(6).err().expect("past the limit").path, "shapes[1]");
    }
}
