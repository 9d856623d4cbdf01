//! Compiling the scene file's texture parameters: each image file is read and
//! decoded once per scene (and once per `raw` flag), however many materials use it,
//! and the decoded texels count against the compile budget.

use super::budget::CompileBudget;
use super::error::{Result, SceneError};
use super::files::resolve;
use super::format::{MaterialDesc, Param, TextureDesc};
use crate::material::normal_map::{NormalSource, Perturb};
use crate::material::texture::{decode_within, Bitmap, Texels, Texture, UvTransform};
use crate::material::textured::{Slot, Textured};
use crate::math::Rgb;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

pub struct Textures<'a> {
    base: Option<&'a Path>,
    budget: &'a CompileBudget,
    images: HashMap<(PathBuf, bool), Arc<Texels>>,
    /// Bytes of decoded texels held by the scene.
    pub bytes: usize,
}

impl<'a> Textures<'a> {
    pub fn new(base: Option<&'a Path>, budget: &'a CompileBudget) -> Self {
        Textures {
            base,
            budget,
            images: HashMap::new(),
            bytes: 0,
        }
    }

    /// The textured parameters of material `name` (None when all are constants).
    pub fn material(&mut self, name: &str, m: &MaterialDesc) -> Result<Option<Textured>> {
        let (path, m) = nested(name, m);
        self.textured(&path, m)
    }

    /// The textures of `m` (at `path`) and of the materials it holds.
    fn textured(&mut self, path: &str, m: &MaterialDesc) -> Result<Option<Textured>> {
        let mut params = Vec::new();
        for (field, p) in m.params() {
            if p.is_texture() {
                let t = self.texture(&format!("{path}.{field}"), p)?;
                params.push((Slot::from_field(field), t));
            }
        }
        let mut nested = Vec::new();
        for (k, c) in m.components().iter().enumerate() {
            if let Some(t) = self.textured(&format!("{path}.materials[{k}]"), c)? {
                nested.push((k, t));
            }
        }
        Ok((!params.is_empty() || !nested.is_empty()).then_some(Textured { params, nested }))
    }

    /// The opacity of a mask (None for other materials).
    pub fn opacity(&mut self, name: &str, m: &MaterialDesc) -> Result<Option<Texture>> {
        match m {
            MaterialDesc::Mask { opacity, .. } => self
                .texture(&format!("materials.{name}.opacity"), opacity)
                .map(Some),
            _ => Ok(None),
        }
    }

    /// The normal or bump map of a material (None for materials without one).
    pub fn perturb(&mut self, name: &str, m: &MaterialDesc) -> Result<Option<Perturb>> {
        let (prefix, m) = match m {
            MaterialDesc::Mask { material, .. } => {
                (format!("materials.{name}.material"), &**material)
            }
            m => (format!("materials.{name}"), m),
        };
        let path = |field: &str| format!("{prefix}.{field}");
        let (source, flip, shadowing) = match m {
            MaterialDesc::NormalMap {
                normalmap,
                flip_invalid_normals,
                use_shadowing_function,
                ..
            } => (
                NormalSource::Map(self.texture(&path("normalmap"), normalmap)?),
                flip_invalid_normals,
                use_shadowing_function,
            ),
            MaterialDesc::BumpMap {
                texture,
                scale,
                flip_invalid_normals,
                use_shadowing_function,
                ..
            } => (
                NormalSource::Bump {
                    height: self.texture(&path("texture"), texture)?,
                    scale: *scale,
                },
                flip_invalid_normals,
                use_shadowing_function,
            ),
            _ => return Ok(None),
        };
        Ok(Some(Perturb {
            source,
            flip_invalid_normals: *flip,
            use_shadowing_function: *shadowing,
        }))
    }

    pub fn texture(&mut self, field: &str, p: &Param) -> Result<Texture> {
        let t = match p {
            Param::Value(v) => return Ok(Texture::Constant(Rgb::from(*v))),
            Param::Texture(t) => &**t,
        };
        Ok(match t {
            TextureDesc::Bitmap {
                filename,
                raw,
                filter,
                wrap,
                to_uv,
            } => Texture::Bitmap(Bitmap {
                texels: self.image(&format!("{field}.filename"), filename, *raw)?,
                filter: *filter,
                wrap: *wrap,
                to_uv: uv_transform(to_uv),
            }),
            TextureDesc::Checkerboard {
                color0,
                color1,
                to_uv,
            } => Texture::Checkerboard {
                color0: Box::new(self.texture(&format!("{field}.color0"), color0)?),
                color1: Box::new(self.texture(&format!("{field}.color1"), color1)?),
                to_uv: uv_transform(to_uv),
            },
            TextureDesc::Scale { texture, scale } => {
                let inner = self.texture(&format!("{field}.texture"), texture)?;
                match self.texture(&format!("{field}.scale"), scale)? {
                    Texture::Constant(s) => Texture::Scale {
                        inner: Box::new(inner),
                        scale: s,
                    },
                    _ => {
                        return Err(SceneError::new(
                            format!("{field}.scale"),
                            "must be a number or an [r, g, b] array",
                        ))
                    }
                }
            }
        })
    }

    fn image(&mut self, field: &str, name: &str, raw: bool) -> Result<Arc<Texels>> {
        let base = (self.base)
            .ok_or_else(|| SceneError::new(field, "file references need a scene folder"))?;
        let path = resolve(base, field, name)?;
        if let Some(t) = self.images.get(&(path.clone(), raw)) {
            return Ok(t.clone());
        }
        let bytes =
            std::fs::read(&path).map_err(|e| SceneError::new(field, format!("\"{name}\": {e}")))?;
        let left = self.budget.max_texture_bytes.saturating_sub(self.bytes);
        let texels = decode_within(&bytes, name, raw, left)
            .map_err(|e| SceneError::new(field, e.to_string()))?;
        self.bytes += texels.bytes();
        self.budget.check_texture_bytes(field, self.bytes)?;
        let texels = Arc::new(texels);
        self.images.insert((path, raw), texels.clone());
        Ok(texels)
    }
}

/// The material that scatters inside masks and normal maps, with its JSON path.
fn nested<'m>(name: &str, m: &'m MaterialDesc) -> (String, &'m MaterialDesc) {
    let mut path = format!("materials.{name}");
    let mut m = m;
    while let MaterialDesc::Mask { material, .. }
    | MaterialDesc::NormalMap { material, .. }
    | MaterialDesc::BumpMap { material, .. } = m
    {
        path.push_str(".material");
        m = material;
    }
    (path, m)
}

fn uv_transform(rows: &Option<[[f32; 3]; 2]>) -> UvTransform {
    rows.map_or(UvTransform::IDENTITY, |rows| UvTransform { rows })
}
