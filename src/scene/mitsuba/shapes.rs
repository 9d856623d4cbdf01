//! `<shape>` plugins, with their BSDF, area emitter and media.

use super::node::Node;
use super::params::{f3, Params, Xf};
use super::{bsdf, media, serialized, Ctx};
use crate::scene::error::Result;
use crate::scene::format::{EmissionDesc, GeometryDesc, ShapeCommon, ShapeDesc};
use glam::DVec3;

pub fn shape<'a>(n: &'a Node, ctx: &mut Ctx<'a>) -> Result<ShapeDesc> {
    let p = Params::new(n, ctx)?;
    let xf = p.transform("to_world")?.unwrap_or_else(Xf::identity);
    let mut transform = xf.desc();
    let geometry = match n.kind() {
        "rectangle" => {
            // The corners themselves, computed in f64 with exact right angles: the
            // same numbers a hand-written scene would give. A mirroring transform
            // reverses their order so that the normal is still the transformed +z.
            let mut corners = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
                .map(|(x, y)| f3(xf.point(DVec3::new(x, y, 0.0))));
            if xf.det() < 0.0 {
                corners.reverse();
                corners.rotate_right(1);
            }
            transform = None;
            GeometryDesc::Rectangle {
                corners: Some(corners),
            }
        }
        "cube" => GeometryDesc::Cube {},
        "disk" => GeometryDesc::Disk {},
        "sphere" => GeometryDesc::Sphere {
            center: f3(p.point("center")?.unwrap_or(DVec3::ZERO)),
            radius: p.float("radius")?.unwrap_or(1.0) as f32,
        },
        "obj" | "ply" => {
            let (fnode, name) = p
                .string("filename")?
                .ok_or_else(|| n.err("needs a filename"))?;
            let filename = ctx.file_ref(fnode, name)?;
            mesh_normals(n, &p, ctx, &filename)?;
            p.ignore(&["flip_tex_coords"]);
            if n.kind() == "obj" {
                GeometryDesc::Obj { filename }
            } else {
                GeometryDesc::Ply { filename }
            }
        }
        "serialized" => serialized::shape(n, &p, ctx)?,
        other => {
            return Err(n.err(format!(
                "unknown or unsupported shape plugin \"{other}\": caustic imports obj, ply, \
                 serialized, rectangle, cube, sphere and disk"
            )))
        }
    };
    let flip_normals = p.boolean("flip_normals")?.unwrap_or(false);
    let emitter = p.object(&["emitter"], None)?;
    let material = match p.object(&["bsdf"], None)? {
        Some(b) => bsdf::material(b, ctx)?,
        None => bsdf::default_material(ctx, emitter.is_some()),
    };
    let emission = match emitter {
        Some(e) => Some(area(e, ctx)?),
        None => None,
    };
    let mut side = |slot: &str| -> Result<Option<String>> {
        match p.object(&["medium"], Some(slot))? {
            Some(m) => media::medium(m, ctx).map(Some),
            None => Ok(None),
        }
    };
    let interior = side("interior")?;
    let exterior = side("exterior")?;
    p.finish(&format!("the {} shape", n.kind()))?;
    Ok(ShapeDesc {
        geometry,
        common: ShapeCommon {
            material,
            transform,
            emission,
            flip_normals,
            interior,
            exterior,
            name: n.attr("id").map(str::to_string),
        },
    })
}

/// Mitsuba computes smooth vertex normals for a mesh file without them (unless
/// `face_normals`), caustic shades such a mesh flat; and caustic cannot drop the
/// normals a file has. Each file is read once, however many shapes name it.
fn mesh_normals(n: &Node, p: &Params, ctx: &mut Ctx, filename: &str) -> Result<()> {
    let face_normals = p.boolean("face_normals")?.unwrap_or(false);
    let key = (n.kind().to_string(), filename.to_string());
    let has_normals = match ctx.has_normals.get(&key) {
        Some(&known) => known,
        None => {
            let path = ctx.path_of(filename);
            let mesh = match n.kind() {
                "obj" => crate::scene::meshes::load_obj(&path, "filename", filename),
                _ => crate::scene::meshes::load_ply(&path, "filename", filename),
            }
            .map_err(|e| n.err(e.message))?;
            let known = mesh.normals.is_some();
            ctx.has_normals.insert(key, known);
            known
        }
    };
    match (has_normals, face_normals) {
        (true, true) => Err(n.err(
            "face_normals=\"true\" with a file that has vertex normals: caustic would use \
             them; remove the normals from the file",
        )),
        (false, false) => {
            ctx.warn(
                n,
                "the file has no vertex normals: Mitsuba would compute smooth normals, caustic \
                 shades it flat (set face_normals=\"true\" to make Mitsuba agree)",
            );
            Ok(())
        }
        _ => Ok(()),
    }
}

fn area<'a>(n: &'a Node, ctx: &mut Ctx<'a>) -> Result<EmissionDesc> {
    if n.kind() != "area" {
        return Err(
            n.err("a shape's emitter must be type=\"area\"; put other emitters at the top level")
        );
    }
    let p = Params::new(n, ctx)?;
    // A colour or a texture over the shape's (u, v).
    let radiance = p
        .param("radiance", ctx)?
        .ok_or_else(|| n.err("needs a radiance"))?;
    p.finish("an area light")?;
    Ok(EmissionDesc {
        radiance,
        two_sided: false,
    })
}
