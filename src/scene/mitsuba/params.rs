//! A plugin element's parameters (`<float name=..>`, `<rgb>`, `<transform>`, ...) and
//! nested objects, each taken at most once; what no converter took is an error.

use super::node::Node;
use super::Ctx;
use crate::scene::error::Result;
use crate::scene::format::{Rotation, Scale, TransformDesc, V3};
use glam::{DMat4, DVec3, DVec4};
use std::cell::Cell;

/// Object elements (everything else inside a plugin is a parameter).
const OBJECTS: &[&str] = &[
    "integrator",
    "sensor",
    "film",
    "sampler",
    "rfilter",
    "shape",
    "bsdf",
    "emitter",
    "medium",
    "phase",
    "volume",
    "texture",
];

pub struct Params<'a> {
    pub node: &'a Node,
    props: Vec<(&'a Node, Cell<bool>)>,
    /// Nested objects (a `<ref>` replaced by what it names) with the slot name the
    /// element or the reference gave.
    objects: Vec<(Option<&'a str>, &'a Node, Cell<bool>)>,
}

impl<'a> Params<'a> {
    pub fn new(node: &'a Node, ctx: &Ctx<'a>) -> Result<Self> {
        let mut props = Vec::new();
        let mut objects = Vec::new();
        for c in &node.children {
            if c.tag == "ref" {
                let id = c.attr("id").ok_or_else(|| c.err("needs an id attribute"))?;
                let target = ctx.ids.get(id).ok_or_else(|| {
                    c.err(format!(
                        "unknown reference \"{id}\": no element has id=\"{id}\"; define one or fix the id"
                    ))
                })?;
                objects.push((c.attr("name"), *target, Cell::new(false)));
            } else if OBJECTS.contains(&c.tag.as_str()) {
                objects.push((c.attr("name"), c, Cell::new(false)));
            } else {
                if c.attr("name").is_none() {
                    return Err(c.err("a parameter needs a name attribute"));
                }
                props.push((c, Cell::new(false)));
            }
        }
        Ok(Params {
            node,
            props,
            objects,
        })
    }

    fn prop(&self, name: &str) -> Option<&'a Node> {
        let (n, used) = self
            .props
            .iter()
            .find(|(n, _)| n.attr("name") == Some(name))?;
        used.set(true);
        Some(n)
    }

    /// Marks parameters that do not change the image as read.
    pub fn ignore(&self, names: &[&str]) {
        for name in names {
            self.prop(name);
        }
    }

    /// A `<texture>` or `<volume>` given where a value is expected.
    fn texture_in(&self, name: &str) -> Result<()> {
        if let Some((_, n, _)) = self
            .objects
            .iter()
            .find(|(slot, n, _)| *slot == Some(name) && n.tag == "texture")
        {
            return Err(n.err(format!(
                "textures are not supported: give \"{name}\" as an <rgb> or <float>"
            )));
        }
        Ok(())
    }

    pub fn float(&self, name: &str) -> Result<Option<f64>> {
        self.texture_in(name)?;
        let Some(n) = self.prop(name) else {
            return Ok(None);
        };
        match n.tag.as_str() {
            "float" | "integer" => number(n, value(n)?).map(Some),
            _ => Err(n.err(format!("\"{name}\" must be a <float>"))),
        }
    }

    pub fn int(&self, name: &str) -> Result<Option<i64>> {
        let Some(n) = self.prop(name) else {
            return Ok(None);
        };
        let v = value(n)?;
        match n.tag.as_str() {
            "integer" => v
                .trim()
                .parse()
                .map(Some)
                .map_err(|_| n.err(format!("\"{v}\" is not an integer"))),
            _ => Err(n.err(format!("\"{name}\" must be an <integer>"))),
        }
    }

    pub fn boolean(&self, name: &str) -> Result<Option<bool>> {
        let Some(n) = self.prop(name) else {
            return Ok(None);
        };
        let v = value(n)?;
        match (n.tag.as_str(), v.trim()) {
            ("boolean", "true") => Ok(Some(true)),
            ("boolean", "false") => Ok(Some(false)),
            ("boolean", _) => Err(n.err(format!("\"{v}\" is not true or false"))),
            _ => Err(n.err(format!("\"{name}\" must be a <boolean>"))),
        }
    }

    pub fn string(&self, name: &str) -> Result<Option<(&'a Node, &'a str)>> {
        let Some(n) = self.prop(name) else {
            return Ok(None);
        };
        match n.tag.as_str() {
            "string" => Ok(Some((n, value(n)?))),
            _ => Err(n.err(format!("\"{name}\" must be a <string>"))),
        }
    }

    /// The texture in slot `name` (nested, or a reference), marked read: what
    /// [`param`](Self::param) and [`scalar`](Self::scalar) (module `texture`) convert.
    pub fn texture_node(&self, name: &str) -> Option<&'a Node> {
        let (_, n, used) =
            (self.objects.iter()).find(|(slot, n, _)| *slot == Some(name) && n.tag == "texture")?;
        used.set(true);
        Some(*n)
    }

    /// Every nested object of `tag`, in document order.
    pub fn objects(&self, tag: &str) -> Vec<&'a Node> {
        (self.objects.iter())
            .filter(|(_, n, _)| n.tag == tag)
            .map(|(_, n, used)| {
                used.set(true);
                *n
            })
            .collect()
    }

    pub fn color(&self, name: &str) -> Result<Option<V3>> {
        self.texture_in(name)?;
        let Some(n) = self.prop(name) else {
            return Ok(None);
        };
        color(n).map(Some)
    }

    pub fn point(&self, name: &str) -> Result<Option<DVec3>> {
        let Some(n) = self.prop(name) else {
            return Ok(None);
        };
        if n.tag != "point" && n.tag != "vector" {
            return Err(n.err(format!("\"{name}\" must be a <point> or <vector>")));
        }
        xyz(n, 0.0).map(Some)
    }

    pub fn transform(&self, name: &str) -> Result<Option<Xf>> {
        let Some(n) = self.prop(name) else {
            return Ok(None);
        };
        if n.tag != "transform" {
            return Err(n.err(format!("\"{name}\" must be a <transform>")));
        }
        Xf::parse(n).map(Some)
    }

    /// The nested object of one of `tags` (with slot `name` when given), if any;
    /// two of them are an error.
    pub fn object(&self, tags: &[&str], name: Option<&str>) -> Result<Option<&'a Node>> {
        let mut found = None;
        for (slot, n, used) in &self.objects {
            let slot_ok = name.is_none_or(|want| *slot == Some(want));
            if tags.contains(&n.tag.as_str()) && slot_ok {
                if found.is_some() {
                    return Err(n.err(format!(
                        "{} takes one <{}> here; remove the others",
                        self.node.label(),
                        n.tag
                    )));
                }
                used.set(true);
                found = Some(*n);
            }
        }
        Ok(found)
    }

    /// Whether slot `name` holds a texture.
    pub fn has_texture(&self, name: &str) -> bool {
        (self.objects.iter()).any(|(slot, n, _)| *slot == Some(name) && n.tag == "texture")
    }

    /// Marks every parameter and object nothing has taken as read, and names them
    /// (for a converter that knowingly leaves them out).
    pub fn take_unread(&self) -> Vec<String> {
        let props = (self.props.iter()).filter(|(_, used)| !used.get());
        let props = props.map(|(n, used)| {
            used.set(true);
            n.attr("name").unwrap_or("?").to_string()
        });
        let objects = (self.objects.iter()).filter(|(_, _, used)| !used.get());
        let objects = objects.map(|(slot, n, used)| {
            used.set(true);
            slot.map_or_else(|| format!("<{}>", n.tag), str::to_string)
        });
        props.chain(objects).collect()
    }

    /// The parameters and objects nothing has taken (yet).
    pub fn unread(&self) -> Vec<&'a Node> {
        let props = (self.props.iter())
            .filter(|(_, used)| !used.get())
            .map(|(n, _)| *n);
        let objects = (self.objects.iter())
            .filter(|(_, _, used)| !used.get())
            .map(|(_, n, _)| *n);
        props.chain(objects).collect()
    }

    /// Every parameter and object must have been taken by the converter.
    pub fn finish(&self, what: &str) -> Result<()> {
        if let Some((n, _)) = self.props.iter().find(|(_, used)| !used.get()) {
            return Err(n.err(format!(
                "unsupported parameter of {}: {what} in caustic has no equivalent; remove it",
                self.node.label()
            )));
        }
        if let Some((_, n, _)) = self.objects.iter().find(|(_, _, used)| !used.get()) {
            return Err(n.err(format!(
                "unexpected inside {}: {what} in caustic takes no such object; remove it",
                self.node.label()
            )));
        }
        Ok(())
    }
}

fn value(n: &Node) -> Result<&str> {
    n.attr("value")
        .ok_or_else(|| n.err("needs a value attribute"))
}

fn number(n: &Node, s: &str) -> Result<f64> {
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| n.err(format!("\"{s}\" is not a number")))?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(n.err(format!("\"{s}\" is not a finite number")))
    }
}

/// Numbers separated by commas and/or white space.
fn numbers(n: &Node, s: &str) -> Result<Vec<f64>> {
    s.split(|c: char| c == ',' || c.is_whitespace())
        .filter(|t| !t.is_empty())
        .map(|t| number(n, t))
        .collect()
}

fn color(n: &Node) -> Result<V3> {
    let v = value(n)?;
    match n.tag.as_str() {
        "float" => {
            let x = number(n, v)? as f32;
            Ok([x; 3])
        }
        "rgb" | "spectrum" => {
            if n.tag == "spectrum" && (v.contains(':') || n.attr("filename").is_some()) {
                return Err(n.err(
                    "spectra given by wavelength are not supported (caustic renders RGB): \
                     give an <rgb> or one value",
                ));
            }
            match numbers(n, v)?.as_slice() {
                [x] => Ok([*x as f32; 3]),
                [r, g, b] => Ok([*r as f32, *g as f32, *b as f32]),
                _ => Err(n.err(format!("\"{v}\" is not one value or three (r, g, b)"))),
            }
        }
        _ => Err(n.err("expected a colour: <rgb>, <spectrum> or <float>")),
    }
}

/// `x`, `y`, `z` attributes (missing ones `default`) or a `value` of three numbers.
pub fn xyz(n: &Node, default: f64) -> Result<DVec3> {
    if let Some(v) = n.attr("value") {
        return match numbers(n, v)?.as_slice() {
            [x, y, z] => Ok(DVec3::new(*x, *y, *z)),
            _ => Err(n.err(format!("\"{v}\" is not three numbers"))),
        };
    }
    let get = |k: &str| n.attr(k).map_or(Ok(default), |s| number(n, s));
    Ok(DVec3::new(get("x")?, get("y")?, get("z")?))
}

fn triple(n: &Node, key: &str) -> Result<DVec3> {
    let s = n
        .attr(key)
        .ok_or_else(|| n.err(format!("needs a \"{key}\" attribute")))?;
    match numbers(n, s)?.as_slice() {
        [x, y, z] => Ok(DVec3::new(*x, *y, *z)),
        _ => Err(n.err(format!("{key} \"{s}\" is not three numbers"))),
    }
}

/// One element of a `<transform>`, kept so that a transform written as scale, then
/// rotations, then a translation becomes caustic's own translate/rotate/scale form
/// (the same floating-point steps as a hand-written scene).
#[derive(Clone, Debug)]
pub enum Part {
    Translate(DVec3),
    Rotate(DVec3, f64),
    Scale(DVec3),
    Matrix,
    LookAt {
        origin: DVec3,
        target: DVec3,
        up: DVec3,
    },
}

/// A transform: the composed matrix (f64) and its elements.
#[derive(Clone, Debug)]
pub struct Xf {
    pub m: DMat4,
    pub parts: Vec<Part>,
}

/// sin and cos of an angle in degrees, exact at multiples of 90 degrees.
fn sin_cos_deg(deg: f64) -> (f64, f64) {
    let q = deg / 90.0;
    if q == q.round() {
        return match (q.round() as i64).rem_euclid(4) {
            0 => (0.0, 1.0),
            1 => (1.0, 0.0),
            2 => (0.0, -1.0),
            _ => (-1.0, 0.0),
        };
    }
    deg.to_radians().sin_cos()
}

/// A right-handed rotation about `axis` (Rodrigues).
pub fn rotation(axis: DVec3, deg: f64) -> DMat4 {
    let k = axis.normalize();
    let (s, c) = sin_cos_deg(deg);
    let t = 1.0 - c;
    DMat4::from_cols(
        DVec4::new(
            t * k.x * k.x + c,
            t * k.x * k.y + s * k.z,
            t * k.x * k.z - s * k.y,
            0.0,
        ),
        DVec4::new(
            t * k.x * k.y - s * k.z,
            t * k.y * k.y + c,
            t * k.y * k.z + s * k.x,
            0.0,
        ),
        DVec4::new(
            t * k.x * k.z + s * k.y,
            t * k.y * k.z - s * k.x,
            t * k.z * k.z + c,
            0.0,
        ),
        DVec4::W,
    )
}

impl Xf {
    pub fn identity() -> Self {
        Xf {
            m: DMat4::IDENTITY,
            parts: Vec::new(),
        }
    }

    fn parse(n: &Node) -> Result<Xf> {
        let mut xf = Xf::identity();
        for c in &n.children {
            let (m, part) = match c.tag.as_str() {
                "translate" => {
                    let v = xyz(c, 0.0)?;
                    (DMat4::from_translation(v), Part::Translate(v))
                }
                "scale" => {
                    let uniform = c.attr("value").map(|v| numbers(c, v)).transpose()?;
                    let v = match uniform.as_deref() {
                        Some([s]) => DVec3::splat(*s),
                        _ => xyz(c, 1.0)?,
                    };
                    if v.x * v.y * v.z == 0.0 {
                        return Err(c.err("a scale factor of 0 flattens the shape"));
                    }
                    (DMat4::from_scale(v), Part::Scale(v))
                }
                "rotate" => {
                    let axis = xyz(c, 0.0)?;
                    let angle = c.attr("angle").map_or(Ok(0.0), |s| number(c, s))?;
                    if axis.length_squared() == 0.0 {
                        return Err(c.err("the rotation axis is zero: give x, y or z"));
                    }
                    (rotation(axis, angle), Part::Rotate(axis, angle))
                }
                "matrix" => {
                    let v = numbers(c, value(c)?)?;
                    let m = match v.as_slice() {
                        s if s.len() == 16 => DMat4::from_cols_slice(s).transpose(),
                        [a, b, cc, d, e, f, g, h, i] => DMat4::from_cols(
                            DVec4::new(*a, *d, *g, 0.0),
                            DVec4::new(*b, *e, *h, 0.0),
                            DVec4::new(*cc, *f, *i, 0.0),
                            DVec4::W,
                        ),
                        _ => return Err(c.err("a matrix has 16 (or 9) numbers, row by row")),
                    };
                    (m, Part::Matrix)
                }
                "lookat" => {
                    let origin = triple(c, "origin")?;
                    let target = triple(c, "target")?;
                    let up = c.attr("up").map_or(Ok(DVec3::Y), |_| triple(c, "up"))?;
                    let dir = (target - origin).normalize();
                    let left = up.cross(dir).normalize();
                    if !(dir.is_finite() && left.is_finite()) {
                        return Err(
                            c.err("origin equals target, or up is parallel to the view direction")
                        );
                    }
                    let new_up = dir.cross(left);
                    let m = DMat4::from_cols(
                        left.extend(0.0),
                        new_up.extend(0.0),
                        dir.extend(0.0),
                        origin.extend(1.0),
                    );
                    (m, Part::LookAt { origin, target, up })
                }
                _ => {
                    return Err(
                        c.err("not a transform element (translate, rotate, scale, matrix, lookat)")
                    )
                }
            };
            // Mitsuba: each element is applied after the ones before it.
            xf.m = m * xf.m;
            xf.parts.push(part);
        }
        Ok(xf)
    }

    pub fn point(&self, p: DVec3) -> DVec3 {
        self.m.transform_point3(p)
    }

    pub fn vector(&self, v: DVec3) -> DVec3 {
        self.m.transform_vector3(v)
    }

    pub fn det(&self) -> f64 {
        glam::DMat3::from_mat4(self.m).determinant()
    }

    /// The transform in caustic's form: translate/rotate/scale when the elements were
    /// a scale, then rotations, then a translation (each optional); else the matrix.
    pub fn desc(&self) -> Option<TransformDesc> {
        if self.parts.is_empty() {
            return None;
        }
        let mut t = TransformDesc::default();
        let mut stage = 0;
        for p in &self.parts {
            match p {
                Part::Scale(v) if stage == 0 => {
                    t.scale = Some(Scale::PerAxis(f3(*v)));
                    stage = 1;
                }
                Part::Rotate(axis, angle) if stage <= 1 => {
                    t.rotate.insert(
                        0,
                        Rotation {
                            axis: f3(*axis),
                            angle: *angle as f32,
                        },
                    );
                    stage = 1;
                }
                Part::Translate(v) if stage <= 1 => {
                    t.translate = Some(f3(*v));
                    stage = 2;
                }
                _ => return Some(self.matrix_desc()),
            }
        }
        Some(t)
    }

    pub fn matrix_desc(&self) -> TransformDesc {
        let rows = self.m.transpose().to_cols_array();
        TransformDesc {
            matrix: Some(rows.map(|x| x as f32)),
            ..Default::default()
        }
    }
}

pub fn f3(v: DVec3) -> V3 {
    [v.x as f32, v.y as f32, v.z as f32]
}
