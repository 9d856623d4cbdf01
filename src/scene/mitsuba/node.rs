//! The Mitsuba XML tree: elements with their attributes, children and where each
//! starts (file, line, column), and the errors and warnings that name them. Below the
//! reader (`xml`), the upgrade and every converter; imports only the scene's errors.

use crate::scene::error::SceneError;
use std::path::PathBuf;
use std::sync::Arc;

/// A file of the scene: its name relative to the main file's folder (as messages show
/// it) and that folder's path to it.
#[derive(Debug)]
pub struct SrcFile {
    pub name: String,
    /// The file's folder, relative to the main file's folder.
    pub dir: PathBuf,
    /// A Mitsuba 0.x file (its elements were upgraded).
    pub legacy: bool,
}

/// Where a node starts.
#[derive(Clone, Debug)]
pub struct Loc {
    pub file: Arc<SrcFile>,
    pub line: u32,
    pub col: u32,
}

impl std::fmt::Display for Loc {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}:{}:{}", self.file.name, self.line, self.col)
    }
}

#[derive(Debug)]
pub struct Node {
    pub tag: String,
    /// Attributes in document order, `$name`s substituted.
    pub attrs: Vec<(String, String)>,
    pub children: Vec<Node>,
    pub loc: Loc,
}

impl Node {
    pub fn attr(&self, key: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }

    /// `<bsdf type="plastic" id="x">`, as messages name the element.
    pub fn label(&self) -> String {
        let mut s = format!("<{}", self.tag);
        for key in ["type", "name", "id"] {
            if let Some(v) = self.attr(key) {
                s += &format!(" {key}=\"{v}\"");
            }
        }
        s + ">"
    }

    /// An error at this element: `file:line:col: <element>: message`.
    pub fn err(&self, message: impl std::fmt::Display) -> SceneError {
        SceneError::new(self.loc.to_string(), format!("{}: {message}", self.label()))
    }

    /// A warning at this element, in the same form as an error.
    pub fn warning(&self, message: impl std::fmt::Display) -> String {
        format!("{}: {}: {message}", self.loc, self.label())
    }

    pub fn kind(&self) -> &str {
        self.attr("type").unwrap_or("")
    }

    /// Sets attribute `key`, adding it if it is missing.
    pub fn set_attr(&mut self, key: &str, value: &str) {
        match self.attrs.iter_mut().find(|(k, _)| k == key) {
            Some((_, v)) => *v = value.to_string(),
            None => self.attrs.push((key.to_string(), value.to_string())),
        }
    }

    /// Whether the element comes from a Mitsuba 0.x file.
    pub fn legacy(&self) -> bool {
        self.loc.file.legacy
    }
}
