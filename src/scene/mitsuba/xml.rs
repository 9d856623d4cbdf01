//! Reading Mitsuba XML into a tree of owned nodes (module `node`): `<include>`s
//! expanded in place, `<default>`s collected and `$name` references substituted, the
//! elements of Mitsuba 0.x files upgraded to Mitsuba 3's form (module `upgrade`),
//! every node with its file, line and column for messages.

use super::super::error::{Result, SceneError};
use super::budget::{Budget, Work};
use super::node::{Loc, Node, SrcFile};
use super::upgrade;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Attributes each element may carry; anything else is an error. A 0.x file also has
/// elements and attributes that its upgrade rewrites or refuses.
fn allowed_attrs(tag: &str, legacy: bool) -> Option<&'static [&'static str]> {
    if legacy {
        match tag {
            "rgb" | "srgb" => return Some(&["name", "value", "intent"]),
            "spectrum" => return Some(&["name", "value", "filename", "intent"]),
            "lookAt" => return Some(&["origin", "target", "up"]),
            "blackbody" => return Some(&["name", "temperature", "scale"]),
            "animation" => return Some(&["name"]),
            "subsurface" => return Some(&["type", "id", "name"]),
            "alias" => return Some(&["id", "as"]),
            _ => {}
        }
    }
    Some(match tag {
        "scene" => &["version"],
        "default" => &["name", "value"],
        "include" => &["filename"],
        "ref" => &["id", "name"],
        "float" | "integer" | "boolean" | "string" | "rgb" => &["name", "value"],
        "spectrum" => &["name", "value", "filename"],
        "point" | "vector" => &["name", "value", "x", "y", "z"],
        "transform" => &["name"],
        "translate" | "scale" => &["value", "x", "y", "z"],
        "rotate" => &["value", "x", "y", "z", "angle"],
        "matrix" => &["value"],
        "lookat" => &["origin", "target", "up"],
        "integrator" | "sensor" | "film" | "sampler" | "rfilter" | "shape" | "bsdf" | "emitter"
        | "medium" | "phase" | "volume" | "texture" => &["type", "id", "name"],
        _ => return None,
    })
}

/// A scene file read with everything it includes.
pub struct Read {
    pub root: Node,
    /// The names (relative to the main file's folder) of the files read, the main
    /// one first.
    pub files: Vec<String>,
    /// What upgrading 0.x elements changed in the image, one line each.
    pub warnings: Vec<String>,
}

/// Reads the main scene file and everything it includes.
pub fn read(path: &Path) -> Result<Read> {
    let name = path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    let main_dir = path.parent().unwrap_or(Path::new("")).to_path_buf();
    let mut reader = Reader {
        main_dir,
        defaults: HashMap::new(),
        stack: Vec::new(),
        depth: 0,
        substituted: 0,
        budget: Budget::default(),
        read: vec![name.clone()],
        warnings: Vec::new(),
    };
    let text = std::fs::read_to_string(path).map_err(|e| SceneError::new(&name, e.to_string()))?;
    (reader.budget)
        .spend(Work::XmlBytes, text.len() as u64)
        .map_err(|m| SceneError::new(&name, m))?;
    let root = reader.file(&text, name, PathBuf::new(), path)?;
    Ok(Read {
        root,
        files: reader.read,
        warnings: reader.warnings,
    })
}

struct Reader {
    main_dir: PathBuf,
    defaults: HashMap<String, String>,
    /// Canonical paths of the files being read, for include cycles.
    stack: Vec<PathBuf>,
    /// Elements open now, across includes: bounded so that a hostile upload cannot
    /// exhaust the stack of the recursive reader (and of the conversion after it).
    depth: usize,
    /// Bytes `$name` references have put in so far: bounded, since a small file with
    /// many references to one long default could otherwise ask for terabytes.
    substituted: usize,
    /// Elements, includes and bytes read so far, across includes (see `budget`).
    budget: Budget,
    /// The files read, by their names relative to the main file's folder.
    read: Vec<String>,
    /// What the upgrades of 0.x elements changed.
    warnings: Vec<String>,
}

/// Far more than any real scene substitutes.
const MAX_SUBSTITUTED: usize = 1 << 24;

/// Deeper than any real scene (Mitsuba's nest about six levels: scene, shape, bsdf,
/// nested bsdf, texture, value).
const MAX_DEPTH: usize = 64;

impl Reader {
    /// Reads file `name` (relative to the main file's folder, in `dir`), at `path`.
    fn file(&mut self, text: &str, name: String, dir: PathBuf, path: &Path) -> Result<Node> {
        let canon = path.canonicalize().unwrap_or_else(|_| path.to_path_buf());
        self.stack.push(canon);
        let doc = roxmltree::Document::parse(text).map_err(|e| {
            let pos = e.pos();
            SceneError::new(
                format!("{name}:{}:{}", pos.row, pos.col),
                format!("not well-formed XML: {e}"),
            )
        })?;
        let root = doc.root_element();
        // Mitsuba 2 and 3 require a version: a file without one is from 0.x.
        let legacy = match root.attribute("version") {
            None => true,
            Some(v) => upgrade::is_legacy(v).ok_or_else(|| {
                let pos = doc.text_pos_at(root.range().start);
                SceneError::new(
                    format!("{name}:{}:{}", pos.row, pos.col),
                    format!(
                        "<{}>: version \"{v}\" is not a version number (such as 3.0.0)",
                        root.tag_name().name()
                    ),
                )
            })?,
        };
        let file = Arc::new(SrcFile { name, dir, legacy });
        let at = |n: roxmltree::Node| {
            let pos = doc.text_pos_at(n.range().start);
            Loc {
                file: file.clone(),
                line: pos.row,
                col: pos.col,
            }
        };
        if root.tag_name().name() != "scene" {
            return Err(SceneError::new(
                at(root).to_string(),
                format!(
                    "<{}>: the root element must be <scene>",
                    root.tag_name().name()
                ),
            ));
        }
        // Defaults first, wherever they stand; an include's never override the
        // including file's.
        for n in root.children().filter(|n| n.has_tag_name("default")) {
            let (Some(k), Some(v)) = (n.attribute("name"), n.attribute("value")) else {
                return Err(SceneError::new(
                    at(n).to_string(),
                    "<default>: needs name and value attributes",
                ));
            };
            self.defaults.entry(k.to_string()).or_insert(v.to_string());
        }
        let node = self.node(root, &at)?;
        self.stack.pop();
        Ok(node)
    }

    fn node(&mut self, n: roxmltree::Node, at: &dyn Fn(roxmltree::Node) -> Loc) -> Result<Node> {
        if self.depth >= MAX_DEPTH {
            return Err(SceneError::new(
                at(n).to_string(),
                format!(
                    "<{}>: elements nested more than {MAX_DEPTH} deep (includes count too); \
                     flatten the scene",
                    n.tag_name().name()
                ),
            ));
        }
        self.depth += 1;
        let node = self.element(n, at);
        self.depth -= 1;
        node
    }

    fn element(&mut self, n: roxmltree::Node, at: &dyn Fn(roxmltree::Node) -> Loc) -> Result<Node> {
        let tag = n.tag_name().name().to_string();
        let loc = at(n);
        let mut node = Node {
            tag,
            attrs: Vec::new(),
            children: Vec::new(),
            loc,
        };
        (self.budget)
            .spend(Work::Elements, 1)
            .map_err(|m| node.err(m))?;
        let Some(allowed) = allowed_attrs(&node.tag, node.legacy()) else {
            return Err(node.err(
                "unknown element: caustic imports Mitsuba 3 scene elements (shape, bsdf, emitter, \
                 sensor, medium, ...); remove it or convert it by hand",
            ));
        };
        for a in n.attributes() {
            let value = self.substitute(&node, a.value())?;
            node.attrs.push((a.name().to_string(), value));
        }
        if let Some((bad, _)) = node
            .attrs
            .iter()
            .find(|(k, _)| !allowed.contains(&k.as_str()))
        {
            return Err(node.err(format!(
                "unsupported attribute \"{bad}\" (this element takes {}); remove it",
                allowed.join(", ")
            )));
        }
        for c in n.children().filter(|c| c.is_element()) {
            match c.tag_name().name() {
                "default" if node.tag == "scene" => {}
                "include" => {
                    let inc = self.node(c, at)?;
                    let scene = self.include(&inc)?;
                    node.children.extend(scene.children);
                }
                _ => node.children.push(self.node(c, at)?),
            }
        }
        if node.legacy() {
            upgrade::node(&mut node, &mut self.warnings)?;
        }
        Ok(node)
    }

    /// `$name` and `${name}` references replaced by the defaults' values.
    fn substitute(&mut self, node: &Node, value: &str) -> Result<String> {
        let mut out = String::new();
        let mut rest = value;
        while let Some(i) = rest.find('$') {
            out += &rest[..i];
            let after = &rest[i + 1..];
            let (name, tail) = if let Some(inner) = after.strip_prefix('{') {
                let end = inner.find('}').ok_or_else(|| node.err("unclosed \"${\""))?;
                (&inner[..end], &inner[end + 1..])
            } else {
                let end = after
                    .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                    .unwrap_or(after.len());
                (&after[..end], &after[end..])
            };
            let v = self.defaults.get(name).ok_or_else(|| {
                node.err(format!(
                    "\"${name}\" has no value: declare <default name=\"{name}\" value=\"...\"/>"
                ))
            })?;
            self.substituted += v.len();
            if self.substituted > MAX_SUBSTITUTED {
                return Err(node.err(format!(
                    "$name references expand to more than {MAX_SUBSTITUTED} bytes in all; \
                     use shorter defaults or fewer references"
                )));
            }
            out += v;
            rest = tail;
        }
        Ok(out + rest)
    }

    fn include(&mut self, inc: &Node) -> Result<Node> {
        let name = inc
            .attr("filename")
            .ok_or_else(|| inc.err("needs a filename attribute"))?;
        let rel = super::join_relative(&inc.loc.file.dir, name).map_err(|m| inc.err(m))?;
        let path = self.main_dir.join(&rel);
        let canon = path
            .canonicalize()
            .map_err(|e| inc.err(format!("\"{name}\": {e}")))?;
        if self.stack.contains(&canon) {
            return Err(inc.err(format!(
                "\"{name}\" includes itself (an include cycle); remove one of the includes"
            )));
        }
        self.budget
            .spend(Work::Includes, 1)
            .map_err(|m| inc.err(m))?;
        let text =
            std::fs::read_to_string(&path).map_err(|e| inc.err(format!("\"{name}\": {e}")))?;
        self.budget
            .spend(Work::XmlBytes, text.len() as u64)
            .map_err(|m| inc.err(m))?;
        let name = rel.to_string_lossy().into_owned();
        self.read.push(name.clone());
        let dir = rel.parent().map(Path::to_path_buf).unwrap_or_default();
        self.file(&text, name, dir, &path)
    }
}
