//! Mitsuba 3 XML scenes, imported into caustic's scene format (Mitsuba 0.x files are
//! first brought to Mitsuba 3's form by module `upgrade`). What caustic cannot
//! represent is an error naming the element and its line; where an approximation is
//! honest (a `plastic` BSDF drawn as its diffuse base, a Gaussian pixel filter as a
//! box), it is made and a warning says exactly what changed. Nothing changes the
//! image silently.

mod bsdf;
mod budget;
mod emitters;
mod integrator;
mod media;
mod node;
mod params;
mod sensor;
mod serialized;
mod shapes;
mod stand_in;
mod texture;
mod upgrade;
mod xml;

use super::error::Result;
use super::format::{MaterialDesc, MediumDesc, SceneFile};
use budget::{Budget, Work};
use node::Node;
use std::collections::{BTreeMap, HashMap};
use std::path::{Component, Path, PathBuf};

/// An imported scene, what the import changed, and Mitsuba's sample count.
#[derive(Clone, Debug)]
pub struct Import {
    pub scene: SceneFile,
    /// One line per approximation or ignored setting, naming the element and its line.
    pub warnings: Vec<String>,
    /// The sampler's `sample_count`: samples per pixel, the render's default length.
    pub spp: Option<u32>,
    /// The files the import read and the scene no longer needs (the XML files, the
    /// `serialized` files now inline), relative to the main file's folder.
    pub sources: Vec<String>,
}

/// Does this file content look like XML (rather than a JSON scene or an archive)?
pub fn is_xml(bytes: &[u8]) -> bool {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let start = bytes.iter().position(|b| !b.is_ascii_whitespace());
    start.is_some_and(|i| {
        let rest = &bytes[i..];
        rest.starts_with(b"<?xml") || rest.starts_with(b"<scene") || rest.starts_with(b"<!--")
    })
}

/// Is this path a Mitsuba scene by its name (`.xml`)?
pub fn is_xml_path(path: &Path) -> bool {
    path.extension()
        .is_some_and(|x| x.eq_ignore_ascii_case("xml"))
}

/// Imports a Mitsuba 3 (or 0.x) XML scene file; the files it names resolve next to it (or next
/// to the file that includes them) and end up relative to its folder.
pub fn import_file(path: &Path) -> Result<Import> {
    let xml::Read {
        root,
        files: mut sources,
        warnings,
    } = xml::read(path)?;
    let main_dir = path.parent().unwrap_or(Path::new("")).to_path_buf();
    let mut ctx = Ctx::new(&root, main_dir)?;
    ctx.warnings = warnings;
    let mut camera = None;
    let mut integrator = None;
    let mut shapes = Vec::new();
    let mut lights = Vec::new();
    for n in &root.children {
        match n.tag.as_str() {
            "sensor" if camera.is_some() => {
                return Err(n.err("a second sensor: caustic scenes have one camera; remove it"))
            }
            "sensor" => camera = Some(sensor::sensor(n, &mut ctx)?),
            "integrator" if integrator.is_some() => {
                return Err(n.err("a second integrator; remove it"))
            }
            // Converted after the sensor; its warnings go here, in document order.
            "integrator" => integrator = Some((n, ctx.warnings.len())),
            "shape" => {
                (ctx.budget).spend(Work::Shapes, 1).map_err(|m| n.err(m))?;
                shapes.push(shapes::shape(n, &mut ctx)?)
            }
            "emitter" => lights.push(emitters::emitter(n, &mut ctx)?),
            "bsdf" | "medium" | "texture" | "volume" | "phase" if n.attr("id").is_some() => {}
            "bsdf" | "medium" | "texture" | "volume" | "phase" => ctx.warn(
                n,
                "defined at the top level without an id, so nothing can use it; ignored",
            ),
            _ => {
                return Err(n.err(
                    "not allowed at the top level of a scene (expected sensor, integrator, \
                     shape, emitter, or a bsdf / medium with an id)",
                ))
            }
        }
    }
    let Some((camera, film, spp)) = camera else {
        return Err(root.err("the scene has no <sensor>: caustic needs a camera; add one"));
    };
    // After the sensor: photon counts per pass become counts per pixel.
    let pixels = u64::from(film.width) * u64::from(film.height);
    let integrator = match integrator {
        Some((n, at)) => {
            let before = ctx.warnings.len();
            let v = integrator::integrator(n, &mut ctx, pixels)?;
            let new: Vec<String> = ctx.warnings.drain(before..).collect();
            ctx.warnings.splice(at..at, new);
            if n.kind() == "path" && !ctx.media.is_empty() {
                ctx.warn(
                    n,
                    "Mitsuba's path integrator ignores media; caustic renders them (as volpath)",
                );
            }
            v
        }
        None => integrator::default(&root, &mut ctx),
    };
    let scene = SceneFile {
        format: 1,
        camera,
        film,
        materials: std::mem::take(&mut ctx.materials),
        media: std::mem::take(&mut ctx.media),
        shapes,
        lights,
        light_selection: Default::default(),
        integrator: Some(integrator),
    };
    sources.extend(ctx.serialized.into_keys());
    sources.sort();
    sources.dedup();
    Ok(Import {
        scene,
        warnings: ctx.warnings,
        spp,
        sources,
    })
}

/// What the conversion keeps as it goes: ids, named materials and media, warnings.
pub struct Ctx<'a> {
    pub ids: HashMap<&'a str, &'a Node>,
    pub warnings: Vec<String>,
    main_dir: PathBuf,
    pub materials: BTreeMap<String, MaterialDesc>,
    pub media: BTreeMap<String, MediumDesc>,
    /// The name given to each converted bsdf or medium element (by address).
    names: HashMap<*const Node, String>,
    /// The next `#k` suffix to try for each base name: an element in a file included
    /// many times has the same base name in every copy, and trying every suffix
    /// from 2 again for each would be quadratic.
    suffixes: HashMap<String, u32>,
    /// Whether each mesh file read so far (by plugin and name) has vertex normals:
    /// read once, however many shapes name it.
    has_normals: HashMap<(String, String), bool>,
    /// The serialized files read so far: read once, however many shapes name them.
    serialized: HashMap<String, std::rc::Rc<Vec<u8>>>,
    /// Shapes and mesh data produced so far (see `budget`).
    pub budget: Budget,
}

impl<'a> Ctx<'a> {
    fn new(root: &'a Node, main_dir: PathBuf) -> Result<Self> {
        let mut ids = HashMap::new();
        collect_ids(root, &mut ids)?;
        Ok(Ctx {
            ids,
            warnings: Vec::new(),
            main_dir,
            materials: BTreeMap::new(),
            media: BTreeMap::new(),
            names: HashMap::new(),
            suffixes: HashMap::new(),
            has_normals: HashMap::new(),
            serialized: HashMap::new(),
            budget: Budget::default(),
        })
    }

    pub fn warn(&mut self, n: &Node, message: impl std::fmt::Display) {
        self.warnings.push(n.warning(message));
    }

    /// The name of an already converted element, if it was.
    pub fn name_of(&self, n: &Node) -> Option<String> {
        self.names.get(&(n as *const Node)).cloned()
    }

    /// A fresh name for element `n`: its id, or its kind and position.
    pub fn name_for(&mut self, n: &Node, kind: &str) -> String {
        let base = n.attr("id").map_or_else(
            || format!("{kind}@{}:{}", n.loc.file.name, n.loc.line),
            str::to_string,
        );
        let taken = |ctx: &Self, name: &str| {
            ctx.materials.contains_key(name) || ctx.media.contains_key(name)
        };
        let candidate = |k: u32| match k {
            1 => base.clone(),
            k => format!("{base}#{k}"),
        };
        let mut k = self.suffixes.get(&base).copied().unwrap_or(1);
        let mut name = candidate(k);
        while taken(self, &name) {
            k += 1;
            name = candidate(k);
        }
        self.suffixes.insert(base, k + 1);
        self.names.insert(n as *const Node, name.clone());
        name
    }

    /// A file the element names, relative to the main file's folder; it must exist.
    pub fn file_ref(&self, n: &Node, name: &str) -> Result<String> {
        let rel = join_relative(&n.loc.file.dir, name).map_err(|m| n.err(m))?;
        if !self.main_dir.join(&rel).is_file() {
            return Err(n.err(format!(
                "file \"{name}\" not found (looked for {}); put it next to the scene",
                rel.display()
            )));
        }
        Ok(crate::scene::files::slashed(&rel))
    }

    pub fn path_of(&self, rel: &str) -> PathBuf {
        self.main_dir.join(rel)
    }
}

fn collect_ids<'a>(n: &'a Node, ids: &mut HashMap<&'a str, &'a Node>) -> Result<()> {
    if n.tag != "ref" {
        if let Some(id) = n.attr("id") {
            if let Some(first) = ids.insert(id, n) {
                return Err(n.err(format!(
                    "id \"{id}\" is already used at {}; rename one of them",
                    first.loc
                )));
            }
        }
    }
    n.children.iter().try_for_each(|c| collect_ids(c, ids))
}

/// `name` relative to `dir` (both inside the main folder), without `..` leaving it.
pub fn join_relative(dir: &Path, name: &str) -> std::result::Result<PathBuf, String> {
    let mut out = dir.to_path_buf();
    for c in Path::new(name).components() {
        match c {
            Component::Normal(p) => out.push(p),
            Component::CurDir => {}
            Component::ParentDir if out.pop() => {}
            _ => {
                return Err(format!(
                    "\"{name}\" must be a relative path inside the scene's folder"
                ))
            }
        }
    }
    if out.as_os_str().is_empty() {
        return Err("empty file name".into());
    }
    Ok(out)
}
