//! Typed access to the Mitsuba 3 XML subset (`../shared/scenes/README.md`):
//! property lookup by name with type checking, numbers that must be finite,
//! and transforms. Every failure becomes a [`SceneError`] that names the
//! file, the line and the element.

use super::error::SceneError;
use crate::math::Spectrum;
use glam::{Mat4, Vec3, Vec4};
use roxmltree::Node;
use std::cell::RefCell;
use std::path::{Path, PathBuf};

/// The parsing context of one scene file: turns node positions into lines
/// and collects warnings for elements that can safely be ignored.
pub struct XmlContext<'a> {
    pub file: PathBuf,
    pub dir: PathBuf,
    pub doc: &'a roxmltree::Document<'a>,
    pub warnings: RefCell<Vec<String>>,
}

impl<'a> XmlContext<'a> {
    pub fn new(file: &Path, doc: &'a roxmltree::Document<'a>) -> Self {
        XmlContext {
            file: file.to_path_buf(),
            dir: file.parent().map(Path::to_path_buf).unwrap_or_default(),
            doc,
            warnings: RefCell::new(Vec::new()),
        }
    }

    pub fn line(&self, node: Node) -> u32 {
        self.doc.text_pos_at(node.range().start).row
    }

    /// `<tag type=".." name=".." id="..">`, the way the user wrote it.
    pub fn describe(node: Node) -> String {
        let mut s = format!("<{}", node.tag_name().name());
        for key in ["type", "name", "id"] {
            if let Some(v) = node.attribute(key) {
                s.push_str(&format!(" {key}=\"{v}\""));
            }
        }
        s.push('>');
        s
    }

    pub fn error(&self, node: Node, message: impl Into<String>) -> SceneError {
        SceneError::new(&self.file, self.line(node), Self::describe(node), message)
    }

    pub fn warn(&self, node: Node, message: impl Into<String>) {
        self.warnings.borrow_mut().push(format!(
            "{}:{}: {}: {}",
            self.file.display(),
            self.line(node),
            Self::describe(node),
            message.into()
        ));
    }

    pub fn required_attr<'n>(&self, node: Node<'n, 'n>, key: &str) -> Result<&'n str, SceneError> {
        node.attribute(key)
            .ok_or_else(|| self.error(node, format!("missing attribute '{key}'")))
    }

    pub fn resolve_path(&self, node: Node, relative: &str) -> Result<PathBuf, SceneError> {
        if relative.is_empty() {
            return Err(self.error(node, "empty filename"));
        }
        Ok(self.dir.join(relative))
    }

    /// Parses one finite number; NaN and ±Inf are bad input.
    pub fn number(&self, node: Node, text: &str) -> Result<f32, SceneError> {
        let t = text.trim();
        match t.parse::<f32>() {
            Ok(v) if v.is_finite() => Ok(v),
            Ok(_) => Err(self.error(node, format!("non-finite number '{t}'"))),
            Err(_) => Err(self.error(node, format!("'{t}' is not a number"))),
        }
    }

    /// A list of numbers separated by commas and/or white space.
    pub fn numbers(&self, node: Node, text: &str) -> Result<Vec<f32>, SceneError> {
        text.split(|c: char| c == ',' || c.is_whitespace())
            .filter(|s| !s.is_empty())
            .map(|s| self.number(node, s))
            .collect()
    }

    pub fn vec3_attr(&self, node: Node, key: &str) -> Result<Vec3, SceneError> {
        let v = self.numbers(node, self.required_attr(node, key)?)?;
        if v.len() != 3 {
            return Err(self.error(
                node,
                format!("attribute '{key}' needs 3 numbers, got {}", v.len()),
            ));
        }
        Ok(Vec3::new(v[0], v[1], v[2]))
    }

    pub fn xyz_attrs(&self, node: Node, default: f32) -> Result<Vec3, SceneError> {
        let mut out = [default; 3];
        for (i, key) in ["x", "y", "z"].iter().enumerate() {
            if let Some(t) = node.attribute(*key) {
                out[i] = self.number(node, t)?;
            }
        }
        Ok(Vec3::from(out))
    }
}

/// The properties (named child elements) of a plugin element.
pub struct Properties<'a, 'n> {
    pub ctx: &'a XmlContext<'a>,
    pub node: Node<'n, 'n>,
    used: RefCell<Vec<String>>,
}

/// The property element tags of the subset.
pub const PROPERTY_TAGS: [&str; 8] = [
    "float",
    "integer",
    "boolean",
    "string",
    "rgb",
    "point",
    "transform",
    "texture",
];

impl<'a, 'n> Properties<'a, 'n> {
    pub fn new(ctx: &'a XmlContext<'a>, node: Node<'n, 'n>) -> Self {
        Properties {
            ctx,
            node,
            used: RefCell::new(Vec::new()),
        }
    }

    fn find(&self, name: &str) -> Option<Node<'n, 'n>> {
        let found = self
            .node
            .children()
            .filter(|c| c.is_element() && PROPERTY_TAGS.contains(&c.tag_name().name()))
            .find(|c| c.attribute("name") == Some(name));
        if found.is_some() {
            self.used.borrow_mut().push(name.to_string());
        }
        found
    }

    fn typed(&self, name: &str, tag: &str) -> Result<Option<Node<'n, 'n>>, SceneError> {
        match self.find(name) {
            None => Ok(None),
            Some(n) if n.tag_name().name() == tag => Ok(Some(n)),
            Some(n) => Err(self.ctx.error(
                n,
                format!(
                    "property '{name}' must be <{tag}>, not <{}>",
                    n.tag_name().name()
                ),
            )),
        }
    }

    pub fn float(&self, name: &str, default: f32) -> Result<f32, SceneError> {
        match self.typed(name, "float")? {
            None => Ok(default),
            Some(n) => self.ctx.number(n, self.ctx.required_attr(n, "value")?),
        }
    }

    pub fn float_opt(&self, name: &str) -> Result<Option<f32>, SceneError> {
        match self.typed(name, "float")? {
            None => Ok(None),
            Some(n) => Ok(Some(
                self.ctx.number(n, self.ctx.required_attr(n, "value")?)?,
            )),
        }
    }

    pub fn integer(&self, name: &str, default: i64) -> Result<i64, SceneError> {
        match self.typed(name, "integer")? {
            None => Ok(default),
            Some(n) => {
                let t = self.ctx.required_attr(n, "value")?.trim();
                t.parse::<i64>()
                    .map_err(|_| self.ctx.error(n, format!("'{t}' is not an integer")))
            }
        }
    }

    pub fn boolean(&self, name: &str, default: bool) -> Result<bool, SceneError> {
        match self.typed(name, "boolean")? {
            None => Ok(default),
            Some(n) => match self.ctx.required_attr(n, "value")?.trim() {
                "true" => Ok(true),
                "false" => Ok(false),
                t => Err(self.ctx.error(n, format!("'{t}' is not 'true' or 'false'"))),
            },
        }
    }

    pub fn string(&self, name: &str) -> Result<Option<(String, Node<'n, 'n>)>, SceneError> {
        match self.typed(name, "string")? {
            None => Ok(None),
            Some(n) => Ok(Some((self.ctx.required_attr(n, "value")?.to_string(), n))),
        }
    }

    pub fn rgb(&self, name: &str) -> Result<Option<Spectrum>, SceneError> {
        match self.typed(name, "rgb")? {
            None => Ok(None),
            Some(n) => Ok(Some(self.ctx.vec3_attr(n, "value")?)),
        }
    }

    pub fn point(&self, name: &str) -> Result<Option<Vec3>, SceneError> {
        match self.typed(name, "point")? {
            None => Ok(None),
            Some(n) => Ok(Some(self.ctx.xyz_attrs(n, 0.0)?)),
        }
    }

    /// A `<texture>` or an `<rgb>` under the same name.
    pub fn rgb_or_texture(&self, name: &str) -> Option<Node<'n, 'n>> {
        self.find(name)
    }

    pub fn transform(&self, name: &str) -> Result<Option<(Mat4, Node<'n, 'n>)>, SceneError> {
        match self.typed(name, "transform")? {
            None => Ok(None),
            Some(n) => Ok(Some((parse_transform(self.ctx, n)?, n))),
        }
    }

    /// Warns about properties that were present but never read: they are
    /// outside the subset, and ignoring them must not be silent.
    pub fn warn_unused(&self) {
        let used = self.used.borrow();
        for c in self.node.children().filter(|c| c.is_element()) {
            if !PROPERTY_TAGS.contains(&c.tag_name().name()) {
                continue;
            }
            if let Some(name) = c.attribute("name")
                && !used.iter().any(|u| u == name)
            {
                self.ctx.warn(
                    c,
                    format!("property '{name}' is not used by ltcguide; ignored"),
                );
            }
        }
    }
}

/// A `<transform>` holds exactly one operation of the subset.
pub fn parse_transform(ctx: &XmlContext, node: Node) -> Result<Mat4, SceneError> {
    let ops: Vec<Node> = node.children().filter(|c| c.is_element()).collect();
    if ops.len() != 1 {
        return Err(ctx.error(
            node,
            format!(
                "expected exactly one transform operation, found {}",
                ops.len()
            ),
        ));
    }
    let op = ops[0];
    let m = match op.tag_name().name() {
        "matrix" => {
            let v = ctx.numbers(op, ctx.required_attr(op, "value")?)?;
            if v.len() != 16 {
                return Err(ctx.error(op, format!("a matrix needs 16 numbers, got {}", v.len())));
            }
            // Row-major in the file, column-major in glam.
            Mat4::from_cols(
                Vec4::new(v[0], v[4], v[8], v[12]),
                Vec4::new(v[1], v[5], v[9], v[13]),
                Vec4::new(v[2], v[6], v[10], v[14]),
                Vec4::new(v[3], v[7], v[11], v[15]),
            )
        }
        "lookat" => {
            let origin = ctx.vec3_attr(op, "origin")?;
            let target = ctx.vec3_attr(op, "target")?;
            let up = ctx.vec3_attr(op, "up")?;
            let d = (target - origin).normalize_or_zero();
            let left = up.cross(d).normalize_or_zero();
            if d == Vec3::ZERO || left == Vec3::ZERO {
                return Err(ctx.error(
                    op,
                    "degenerate lookat: origin = target or up parallel to the view direction",
                ));
            }
            let new_up = d.cross(left);
            Mat4::from_cols(
                left.extend(0.0),
                new_up.extend(0.0),
                d.extend(0.0),
                origin.extend(1.0),
            )
        }
        "rotate" => {
            let axis = ctx.xyz_attrs(op, 0.0)?;
            let angle = ctx.number(op, ctx.required_attr(op, "angle")?)?;
            if axis.length_squared() == 0.0 {
                return Err(ctx.error(op, "rotation axis is zero"));
            }
            Mat4::from_axis_angle(axis.normalize(), angle.to_radians())
        }
        "scale" => {
            let s = ctx.xyz_attrs(op, 1.0)?;
            Mat4::from_scale(s)
        }
        other => return Err(ctx.error(op, format!("unsupported transform operation '{other}'"))),
    };
    let det = m.determinant();
    if !det.is_finite() || det.abs() < 1e-20 {
        return Err(ctx.error(op, "transform is singular"));
    }
    Ok(m)
}
