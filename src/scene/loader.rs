//! Walks a Mitsuba 3 XML scene (the subset of `../shared/scenes/README.md`)
//! and builds a [`Scene`]. Unsupported plugins, wrong property types, missing
//! files, non-finite numbers and degenerate geometry are errors naming the
//! file, line and element; elements that can safely be ignored are warnings.

use super::error::SceneError;
use super::obj::{ObjOptions, load_obj};
use super::shapes::{ShapeTriangle, cube, first_degenerate, rectangle};
use super::xml::{Properties, XmlContext, check_document};
use super::{Scene, Shape, TriangleShading};
use crate::accel::{Accel, PrimGeom};
use crate::bsdf::Material;
use crate::camera::{Camera, FovAxis};
use crate::emitter::{EmitterTriangle, EnvMap, Light, Lights};
use crate::huge::HugeSlice;
use crate::math::Spectrum;
use crate::texture::RgbImage;
use glam::{Mat3, Mat4, Vec3};
use roxmltree::Node;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Loads and validates a scene file, or the `scene.xml` of a folder (the
/// pack's layout: one folder per scene).
pub fn load_scene(path: &Path) -> Result<Scene, SceneError> {
    let path = &scene_file(path);
    let text = std::fs::read_to_string(path)
        .map_err(|e| SceneError::new(path, 0, "scene", format!("cannot read scene file: {e}")))?;
    load_scene_from_str(&text, path)
}

/// The file a scene argument names: itself, or `scene.xml` inside it when
/// it is a folder (a folder without one then fails to read, naming the
/// file that was looked for).
fn scene_file(path: &Path) -> PathBuf {
    if path.is_dir() {
        path.join("scene.xml")
    } else {
        path.to_path_buf()
    }
}

/// Loads a scene from XML text as if it had been read from `path`: errors
/// name `path`, and `filename` properties resolve against its folder. Lets
/// tools and the fuzzer skip writing the XML to disk.
pub fn load_scene_from_str(text: &str, path: &Path) -> Result<Scene, SceneError> {
    let doc = roxmltree::Document::parse(text).map_err(|e| {
        // A truncated file fails at its end, wherever the parser says.
        let row = match e {
            roxmltree::Error::UnexpectedEndOfStream => text.lines().count().max(1) as u32,
            _ => e.pos().row,
        };
        SceneError::new(path, row, "xml", format!("malformed XML: {e}"))
    })?;
    let ctx = XmlContext::new(path, &doc);
    check_document(&ctx, doc.root_element())?;
    let mut builder = Builder::new(&ctx);
    builder.scene(doc.root_element())?;
    builder.finish(path)
}

/// Largest world coordinate a shape may reach. Far beyond any sensible scene
/// (f32 spacing there is 64), yet small enough that the squares of squared
/// extents (|e1 × e2|² in triangle areas, BVH surface areas) stay finite.
const MAX_COORDINATE: f32 = 1e9;

pub(super) struct PendingShape {
    material: u32,
    triangles: Vec<ShapeTriangle>,
    sphere: Option<(Vec3, f32, bool)>,
    emitter: Option<Spectrum>,
}

pub(super) struct Builder<'a> {
    pub(super) ctx: &'a XmlContext<'a>,
    pub(super) camera: Option<Camera>,
    pub(super) max_depth: Option<u32>,
    pub(super) materials: Vec<Material>,
    pub(super) named_materials: HashMap<String, u32>,
    pub(super) shapes: Vec<PendingShape>,
    pub(super) infinite_lights: Vec<Light>,
    pub(super) image_cache: HashMap<(PathBuf, bool), Arc<RgbImage>>,
    pub(super) bitmap_cache: HashMap<(PathBuf, bool), crate::texture::Texture>,
    pub(super) has_integrator: bool,
}

impl<'a> Builder<'a> {
    fn new(ctx: &'a XmlContext<'a>) -> Self {
        Builder {
            ctx,
            camera: None,
            max_depth: None,
            materials: Vec::new(),
            named_materials: HashMap::new(),
            shapes: Vec::new(),
            infinite_lights: Vec::new(),
            image_cache: HashMap::new(),
            bitmap_cache: HashMap::new(),
            has_integrator: false,
        }
    }

    fn scene(&mut self, root: Node) -> Result<(), SceneError> {
        let ctx = self.ctx;
        if root.tag_name().name() != "scene" {
            return Err(ctx.error(root, "the root element must be <scene>"));
        }
        match root.attribute("version") {
            Some(v) if v.starts_with("3.") => {}
            Some(v) => ctx.warn(
                root,
                format!("scene version {v}; ltcguide reads the Mitsuba 3 subset"),
            ),
            None => ctx.warn(root, "no version attribute; assuming 3.0.0"),
        }
        for child in root.children().filter(|c| c.is_element()) {
            match child.tag_name().name() {
                "integrator" => self.integrator(child)?,
                "sensor" => {
                    if self.camera.is_some() {
                        return Err(ctx.error(child, "more than one <sensor>"));
                    }
                    self.camera = Some(self.sensor(child)?);
                }
                "bsdf" => {
                    let id = ctx.required_attr(child, "id")?.to_string();
                    if self.named_materials.contains_key(&id) {
                        return Err(ctx.error(child, format!("duplicate bsdf id '{id}'")));
                    }
                    let m = self.bsdf(child)?;
                    self.materials.push(m);
                    self.named_materials
                        .insert(id, self.materials.len() as u32 - 1);
                }
                "shape" => self.shape(child)?,
                "emitter" => self.top_level_emitter(child)?,
                other => return Err(ctx.error(child, format!("unsupported element <{other}>"))),
            }
        }
        if self.camera.is_none() {
            return Err(ctx.error(root, "the scene has no <sensor>"));
        }
        if self.shapes.is_empty() && self.infinite_lights.is_empty() {
            return Err(ctx.error(root, "the scene is empty: no shapes and no emitters"));
        }
        if self.infinite_lights.is_empty() && self.shapes.iter().all(|s| s.emitter.is_none()) {
            return Err(ctx.error(root, "the scene has no emitter: every image would be black"));
        }
        Ok(())
    }

    fn integrator(&mut self, node: Node) -> Result<(), SceneError> {
        let ctx = self.ctx;
        if self.has_integrator {
            return Err(ctx.error(node, "more than one <integrator>"));
        }
        self.has_integrator = true;
        let ty = ctx.required_attr(node, "type")?;
        if ty != "path" {
            ctx.warn(node, format!("integrator type '{ty}' ignored: ltcguide chooses its method on the command line"));
        }
        let props = Properties::new(ctx, node);
        let depth = props.integer("max_depth", -1)?;
        self.max_depth = match depth {
            -1 => None,
            d if d >= 1 && d <= u32::MAX as i64 => Some(d as u32),
            d => {
                return Err(ctx.error(
                    node,
                    format!("max_depth must be -1 (unlimited) or ≥ 1, got {d}"),
                ));
            }
        };
        props.warn_unused();
        ctx.only_properties(node, "an integrator", &[])?;
        Ok(())
    }

    fn sensor(&mut self, node: Node) -> Result<Camera, SceneError> {
        let ctx = self.ctx;
        let ty = ctx.required_attr(node, "type")?;
        if ty != "perspective" {
            return Err(ctx.error(
                node,
                format!("unsupported sensor type '{ty}' (only 'perspective')"),
            ));
        }
        let props = Properties::new(ctx, node);
        // The scene format gives no default; Mitsuba's (50 mm lens on the
        // 36×24 mm diagonal) depends on the aspect, so a guess could misframe.
        let fov = props.float_opt("fov")?.ok_or_else(|| {
            ctx.error(
                node,
                "a perspective sensor needs 'fov': the scene format defines no default",
            )
        })?;
        if !(fov > 0.0 && fov < 180.0) {
            return Err(ctx.error(node, format!("fov must be in (0, 180) degrees, got {fov}")));
        }
        let axis = match props.string("fov_axis")? {
            None => FovAxis::X,
            Some((s, n)) => match s.as_str() {
                "x" => FovAxis::X,
                "y" => FovAxis::Y,
                "smaller" => FovAxis::Smaller,
                "larger" => FovAxis::Larger,
                other => return Err(ctx.error(n, format!("unknown fov_axis '{other}'"))),
            },
        };
        let to_world = props
            // A scale would stretch the rays' directions, which Mitsuba
            // refuses for sensors too.
            .transform("to_world", &["matrix", "lookat", "rotate"])?
            .map(|t| t.0)
            .unwrap_or(Mat4::IDENTITY);
        props.warn_unused();
        let (mut width, mut height) = (768usize, 576usize);
        let mut seen: Vec<&str> = Vec::new();
        for child in node.children().filter(|c| c.is_element()) {
            let tag = child.tag_name().name();
            // A second film or sampler could only override the first one.
            if matches!(tag, "film" | "sampler") {
                if seen.contains(&tag) {
                    return Err(ctx.error(child, format!("more than one <{tag}> in <sensor>")));
                }
                seen.push(tag);
            }
            match tag {
                "film" => {
                    let ty = ctx.required_attr(child, "type")?;
                    if ty != "hdrfilm" {
                        return Err(ctx.error(
                            child,
                            format!("unsupported film type '{ty}' (only 'hdrfilm')"),
                        ));
                    }
                    let fp = Properties::new(ctx, child);
                    let w = fp.integer("width", 768)?;
                    let h = fp.integer("height", 576)?;
                    if !(1..=65536).contains(&w) || !(1..=65536).contains(&h) {
                        return Err(ctx.error(child, format!("film size {w}×{h} is out of range")));
                    }
                    (width, height) = (w as usize, h as usize);
                    fp.warn_unused();
                    ctx.only_properties(child, "a film", &["rfilter"])?;
                    for f in child
                        .children()
                        .filter(|c| c.is_element() && c.tag_name().name() == "rfilter")
                    {
                        ctx.warn(f, "reconstruction filter ignored: ltcguide uses a box filter, like the pack references");
                    }
                }
                "sampler" => {
                    // Another sampler changes the noise, not the image.
                    let ty = ctx.required_attr(child, "type")?;
                    if ty != "independent" {
                        ctx.warn(
                            child,
                            format!(
                                "sampler type '{ty}' ignored: ltcguide draws independent samples"
                            ),
                        );
                    }
                    // The sample count is informational: spp comes from the command line.
                    let sp = Properties::new(ctx, child);
                    sp.integer("sample_count", 4)?;
                    sp.warn_unused();
                    ctx.only_properties(child, "a sampler", &[])?;
                }
                tag if super::xml::PROPERTY_TAGS.contains(&tag) => {}
                other => {
                    return Err(
                        ctx.error(child, format!("unsupported element <{other}> in <sensor>"))
                    );
                }
            }
        }
        Ok(Camera::new(to_world, fov, axis, width, height))
    }

    fn shape(&mut self, node: Node) -> Result<(), SceneError> {
        let ctx = self.ctx;
        let ty = ctx.required_attr(node, "type")?;
        let props = Properties::new(ctx, node);
        // The pack's shapes use `matrix`; the other operations are exact
        // too, and Mitsuba's scenes use them on shapes.
        let to_world = props.transform("to_world", &["matrix", "lookat", "rotate", "scale"])?;
        let flip = props.boolean("flip_normals", false)?;
        let mut material = None;
        let mut emitter = None;
        for child in node.children().filter(|c| c.is_element()) {
            match child.tag_name().name() {
                "bsdf" | "ref" if material.is_some() => {
                    return Err(ctx.error(child, "a shape takes exactly one bsdf"));
                }
                "bsdf" => {
                    let m = self.bsdf(child)?;
                    self.materials.push(m);
                    material = Some(self.materials.len() as u32 - 1);
                }
                "ref" => {
                    let id = ctx.required_attr(child, "id")?;
                    let m = self.named_materials.get(id).ok_or_else(|| {
                        ctx.error(
                            child,
                            format!("unknown bsdf id '{id}' (bsdfs must be declared before use)"),
                        )
                    })?;
                    material = Some(*m);
                }
                "emitter" => {
                    if emitter.is_some() {
                        return Err(ctx.error(child, "a shape takes at most one emitter"));
                    }
                    let ety = ctx.required_attr(child, "type")?;
                    if ety != "area" {
                        return Err(ctx.error(
                            child,
                            format!("emitter '{ety}' cannot be attached to a shape (only 'area')"),
                        ));
                    }
                    let ep = Properties::new(ctx, child);
                    let radiance = ep
                        .rgb("radiance")?
                        .ok_or_else(|| ctx.error(child, "area emitter needs 'radiance'"))?;
                    if radiance.min_element() < 0.0 {
                        return Err(ctx.error(child, "radiance must not be negative"));
                    }
                    ep.warn_unused();
                    ctx.only_properties(child, "an emitter", &[])?;
                    emitter = Some(radiance);
                }
                tag if super::xml::PROPERTY_TAGS.contains(&tag) => {}
                other => {
                    return Err(ctx.error(child, format!("unexpected <{other}> inside a shape")));
                }
            }
        }
        let material = material.ok_or_else(|| ctx.error(node, "a shape needs a bsdf"))?;
        let mut sphere = None;
        let triangles = match ty {
            "obj" => {
                let (file, fnode) = props
                    .string("filename")?
                    .ok_or_else(|| ctx.error(node, "obj shape needs a 'filename'"))?;
                let face_normals = props.boolean("face_normals", false)?;
                let path = ctx.resolve_path(fnode, &file)?;
                if !path.exists() {
                    return Err(
                        ctx.error(fnode, format!("mesh file not found: '{}'", path.display()))
                    );
                }
                let mut tris = load_obj(
                    &path,
                    &ObjOptions {
                        face_normals,
                        flip_normals: flip,
                    },
                )
                .map_err(|mut e| {
                    e.message = format!(
                        "{} (mesh of {} at line {})",
                        e.message,
                        XmlContext::describe(node),
                        ctx.line(node)
                    );
                    e
                })?;
                if let Some((m, _)) = to_world {
                    let nm = Mat3::from_mat4(m).inverse().transpose();
                    for t in &mut tris {
                        t.p = t.p.map(|p| m.transform_point3(p));
                        t.n = t.n.map(|n| n.map(|v| (nm * v).normalize_or(v)));
                        if m.determinant() < 0.0 {
                            t.p.swap(1, 2);
                            t.uv.swap(1, 2);
                            if let Some(n) = &mut t.n {
                                n.swap(1, 2);
                            }
                        }
                    }
                }
                tris
            }
            "rectangle" | "cube" => {
                let m = to_world.map(|t| t.0).unwrap_or(Mat4::IDENTITY);
                let mut tris = if ty == "rectangle" {
                    rectangle(&m)
                } else {
                    cube(&m)
                };
                if flip {
                    for t in &mut tris {
                        t.p.swap(1, 2);
                        t.uv.swap(1, 2);
                    }
                }
                tris
            }
            "sphere" => {
                if to_world.is_some() {
                    return Err(ctx.error(
                        node,
                        "sphere to_world is not supported; use 'center' and 'radius'",
                    ));
                }
                let center = props.point("center")?.unwrap_or(Vec3::ZERO);
                let radius = props.float("radius", 1.0)?;
                if radius <= 0.0 {
                    return Err(ctx.error(
                        node,
                        format!("sphere radius must be positive, got {radius}"),
                    ));
                }
                sphere = Some((center, radius, flip));
                Vec::new()
            }
            other => return Err(ctx.error(node, format!("unsupported shape type '{other}'"))),
        };
        // The OBJ check runs before to_world, which can still flatten a triangle.
        if let Some(i) = first_degenerate(&triangles) {
            let msg =
                format!("triangle {i} has zero area in world space (degenerate after to_world)");
            return Err(ctx.error(node, msg));
        }
        // Finite numbers can still overflow f32 once transformed, and the
        // BVH build panics on infinite bounds or surface areas.
        let too_far = |v: Vec3| !(v.abs().max_element() <= MAX_COORDINATE);
        if let Some(i) = triangles.iter().position(|t| t.p.into_iter().any(too_far)) {
            return Err(ctx.error(
                node,
                format!("triangle {i} lies beyond ±{MAX_COORDINATE:e}: coordinates too large"),
            ));
        }
        if let Some((center, radius, _)) = sphere
            && too_far(center.abs() + radius)
        {
            return Err(ctx.error(
                node,
                format!("sphere reaches beyond ±{MAX_COORDINATE:e}: coordinates too large"),
            ));
        }
        props.warn_unused();
        self.shapes.push(PendingShape {
            material,
            triangles,
            sphere,
            emitter,
        });
        Ok(())
    }

    fn top_level_emitter(&mut self, node: Node) -> Result<(), SceneError> {
        let ctx = self.ctx;
        let ty = ctx.required_attr(node, "type")?;
        let props = Properties::new(ctx, node);
        let light = match ty {
            "envmap" => {
                let (file, fnode) = props
                    .string("filename")?
                    .ok_or_else(|| ctx.error(node, "envmap needs a 'filename'"))?;
                let scale = props.float("scale", 1.0)?;
                if scale < 0.0 {
                    return Err(ctx.error(node, "envmap scale must not be negative"));
                }
                let to_world = props
                    .transform("to_world", &["matrix", "rotate", "lookat"])?
                    .map(|t| t.0)
                    .unwrap_or(Mat4::IDENTITY);
                let path = ctx.resolve_path(fnode, &file)?;
                // Only EXR is linear: an 8-bit image would need a transfer
                // function the format does not define for envmaps.
                if !path
                    .extension()
                    .is_some_and(|e| e.eq_ignore_ascii_case("exr"))
                {
                    return Err(ctx.error(fnode, "an envmap must be an EXR file"));
                }
                let img = self.image(&path, true, fnode)?;
                Light::Env(EnvMap::new(
                    (*img).clone(),
                    scale,
                    Mat3::from_mat4(to_world),
                ))
            }
            "constant" => {
                let radiance = props
                    .rgb("radiance")?
                    .ok_or_else(|| ctx.error(node, "constant emitter needs 'radiance'"))?;
                if radiance.min_element() < 0.0 {
                    return Err(ctx.error(node, "radiance must not be negative"));
                }
                Light::Constant(radiance)
            }
            "area" => return Err(ctx.error(node, "an area emitter must be nested in a shape")),
            other => return Err(ctx.error(node, format!("unsupported emitter type '{other}'"))),
        };
        props.warn_unused();
        ctx.only_properties(node, "an emitter", &[])?;
        self.infinite_lights.push(light);
        Ok(())
    }

    fn finish(self, path: &Path) -> Result<Scene, SceneError> {
        let mut geometry = Vec::new();
        let mut triangle_shading = Vec::new();
        let mut triangle_normals = Vec::new();
        let mut prim_shape = Vec::new();
        let mut shapes = Vec::new();
        let mut lights = Vec::new();
        let mut spheres = Vec::new();
        let triangle_total: usize = self.shapes.iter().map(|s| s.triangles.len()).sum();
        for (si, s) in self.shapes.iter().enumerate() {
            let mut emitter_tris = Vec::new();
            for t in &s.triangles {
                let prim = geometry.len() as u32;
                let g = PrimGeom::triangle(t.p[0], t.p[1], t.p[2]);
                if s.emitter.is_some() {
                    emitter_tris.push(EmitterTriangle {
                        prim,
                        p0: g.p0,
                        e1: g.e1,
                        e2: g.e2,
                        n: t.n,
                    });
                }
                geometry.push(g);
                triangle_shading.push(TriangleShading { n: t.n, uv: t.uv });
                triangle_normals.push(Scene::triangle_normal(&g));
                prim_shape.push(si as u32);
            }
            let light = match (s.emitter, s.sphere) {
                (Some(radiance), Some((center, radius, flip))) => Some(Light::Sphere {
                    radiance,
                    center,
                    radius,
                    sign: if flip { -1.0 } else { 1.0 },
                    // Spheres follow all triangles in primitive order.
                    prim: (triangle_total + spheres.len()) as u32,
                }),
                (Some(radiance), None) => Light::mesh(radiance, emitter_tris),
                _ => None,
            };
            let light_index = light.map(|l| {
                lights.push(l);
                lights.len() as u32 - 1
            });
            if let Some(sph) = s.sphere {
                spheres.push((si as u32, sph));
            }
            shapes.push(Shape {
                material: s.material,
                light: light_index,
            });
        }
        // Spheres follow all triangles so that prim ids below the triangle
        // count index `triangle_shading` directly.
        for (si, (center, radius, flip)) in spheres {
            let mut g = PrimGeom::sphere(center, radius);
            g.e2.x = if flip { -1.0 } else { 1.0 };
            geometry.push(g);
            prim_shape.push(si);
        }
        lights.extend(self.infinite_lights);
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for g in &geometry {
            let b = g.aabb();
            lo = lo.min(b.min.into());
            hi = hi.max(b.max.into());
        }
        if geometry.is_empty() {
            (lo, hi) = (Vec3::splat(-1.0), Vec3::splat(1.0));
        }
        let accel = Accel::build(&geometry);
        let name = path
            .parent()
            .and_then(|p| p.file_name())
            .filter(|_| path.file_name().is_some_and(|f| f == "scene.xml"))
            .or_else(|| path.file_stem())
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "scene".into());
        Ok(Scene {
            file: path.to_path_buf(),
            name,
            camera: self.camera.expect("checked in scene()"),
            materials: self.materials,
            shapes,
            geometry: HugeSlice::new(geometry),
            triangle_shading: HugeSlice::new(triangle_shading),
            triangle_normals: HugeSlice::new(triangle_normals),
            prim_shape: HugeSlice::new(prim_shape),
            accel,
            lights: Lights::new(lights),
            max_depth: self.max_depth,
            bounds: (lo, hi),
            warnings: self.ctx.warnings.take(),
        })
    }
}
