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
        let parts: Vec<&str> = text.split(',').collect();
        let mut out = Vec::new();
        for part in &parts {
            // "0.1,,0.2" is a typo, not two numbers: counting it as such
            // would hide a missing value behind a plausible count.
            if parts.len() > 1 && part.trim().is_empty() {
                return Err(self.error(
                    node,
                    format!("empty entry in the number list '{}'", text.trim()),
                ));
            }
            for s in part.split_whitespace() {
                out.push(self.number(node, s)?);
            }
        }
        Ok(out)
    }

    /// Children other than properties (and the `extra` tags the caller
    /// handles itself) are outside the subset: refused rather than skipped,
    /// since skipping one would silently change the scene.
    pub fn only_properties(
        &self,
        node: Node,
        inside: &str,
        extra: &[&str],
    ) -> Result<(), SceneError> {
        for child in node.children().filter(|c| c.is_element()) {
            let tag = child.tag_name().name();
            if !PROPERTY_TAGS.contains(&tag) && !extra.contains(&tag) {
                return Err(self.error(child, format!("unexpected <{tag}> inside {inside}")));
            }
        }
        Ok(())
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

    /// A transform whose operation must be one of `ops`: the subset fixes
    /// which operations each plugin takes.
    pub fn transform(
        &self,
        name: &str,
        ops: &[&str],
    ) -> Result<Option<(Mat4, Node<'n, 'n>)>, SceneError> {
        match self.typed(name, "transform")? {
            None => Ok(None),
            Some(n) => Ok(Some((parse_transform(self.ctx, n, name, ops)?, n))),
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

/// A `<transform>` holds exactly one operation of the subset, one of `ops`.
pub fn parse_transform(
    ctx: &XmlContext,
    node: Node,
    name: &str,
    ops_allowed: &[&str],
) -> Result<Mat4, SceneError> {
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
    let tag = op.tag_name().name();
    if !ops_allowed.contains(&tag) {
        let list: Vec<String> = ops_allowed.iter().map(|o| format!("<{o}>")).collect();
        return Err(ctx.error(
            op,
            format!("'{name}' must be a {}, not <{tag}>", list.join(" or ")),
        ));
    }
    let m = match tag {
        "matrix" => {
            let v = ctx.numbers(op, ctx.required_attr(op, "value")?)?;
            if v.len() != 16 {
                return Err(ctx.error(op, format!("a matrix needs 16 numbers, got {}", v.len())));
            }
            // A projective last row would be dropped by every point and
            // normal transform below, so the scene would not be the one given.
            if v[12..] != [0.0, 0.0, 0.0, 1.0] {
                return Err(ctx.error(
                    op,
                    format!(
                        "the last row of a matrix must be 0 0 0 1, got {} {} {} {}",
                        v[12], v[13], v[14], v[15]
                    ),
                ));
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
            // Mitsuba 3.9.1 uses the axis as given, and Rodrigues' formula
            // with a non-unit axis is no rotation (nor defined by the scene
            // format), so only unit axes have a meaning both agree on.
            let len = axis.length();
            if !((len - 1.0).abs() <= 1e-4) {
                return Err(ctx.error(
                    op,
                    format!("rotation axis must have unit length (Mitsuba does not normalise it), got length {len}"),
                ));
            }
            // Within the tolerance: keeps the matrix a rotation.
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

/// The attributes each element of the subset may carry. Anything else (a
/// `value` on a `<point>`, `units="cm"`) would otherwise be read as absent.
fn allowed_attributes(tag: &str) -> Option<&'static [&'static str]> {
    Some(match tag {
        "scene" => &["version"],
        // An `id` on these only names them (exporters write one on every
        // shape); only a bsdf's is referred to.
        "integrator" | "sensor" | "film" | "sampler" | "emitter" | "shape" | "rfilter" => {
            &["type", "id"]
        }
        "bsdf" => &["type", "id"],
        "texture" => &["type", "name", "id"],
        "ref" => &["id"],
        "float" | "integer" | "boolean" | "string" | "rgb" => &["name", "value"],
        "point" => &["name", "x", "y", "z"],
        "transform" => &["name"],
        "matrix" => &["value"],
        "lookat" => &["origin", "target", "up"],
        "rotate" => &["x", "y", "z", "angle"],
        "scale" => &["x", "y", "z"],
        // Unknown elements are refused where they occur, naming their parent.
        _ => return None,
    })
}

/// Checks the whole document before it is interpreted: unknown attributes,
/// properties without a name (which no lookup can reach) and properties
/// given twice (where only one could win) are refused.
pub fn check_document(ctx: &XmlContext, root: Node) -> Result<(), SceneError> {
    for node in root.descendants().filter(|n| n.is_element()) {
        let tag = node.tag_name().name();
        if let Some(allowed) = allowed_attributes(tag) {
            for a in node.attributes() {
                if !allowed.contains(&a.name()) {
                    return Err(ctx.error(
                        node,
                        format!(
                            "attribute '{}' is not part of the scene format on <{tag}> (allowed: {})",
                            a.name(),
                            allowed.join(", ")
                        ),
                    ));
                }
            }
        }
        let mut seen: Vec<(&str, u32)> = Vec::new();
        for prop in node
            .children()
            .filter(|c| c.is_element() && PROPERTY_TAGS.contains(&c.tag_name().name()))
        {
            let name = ctx.required_attr(prop, "name")?;
            if let Some((_, line)) = seen.iter().find(|(n, _)| *n == name) {
                return Err(ctx.error(
                    prop,
                    format!("property '{name}' is given twice (first on line {line})"),
                ));
            }
            seen.push((name, ctx.line(prop)));
        }
    }
    Ok(())
}
