//! Wavefront OBJ meshes through tobj, validated: finite numbers, indices in
//! range, triangles only, no zero-area triangles. Problems are reported with
//! the OBJ line that causes them.

use super::error::SceneError;
use super::shapes::ShapeTriangle;
use glam::{Vec2, Vec3};
use std::path::Path;

pub struct ObjOptions {
    pub face_normals: bool,
    pub flip_normals: bool,
}

/// Loads the triangles of an OBJ file (v/vt/vn sharing one index per corner,
/// Mitsuba's v flip applied to texture coordinates).
pub fn load_obj(path: &Path, opts: &ObjOptions) -> Result<Vec<ShapeTriangle>, SceneError> {
    let whole = |msg: String| SceneError::new(path, 0, "obj", msg);
    let text =
        std::fs::read_to_string(path).map_err(|e| whole(format!("cannot read mesh: {e}")))?;
    // Checks with line numbers first: tobj reports neither lines nor NaN.
    scan_obj_text(path, &text, opts.face_normals)?;
    let load_opts = tobj::LoadOptions {
        single_index: true,
        triangulate: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let parsed = std::panic::catch_unwind(|| {
        tobj::load_obj_buf(&mut text.as_bytes(), &load_opts, |_| {
            Err(tobj::LoadError::OpenFileFailed)
        })
    });
    let (models, _materials) = match parsed {
        Ok(Ok(m)) => m,
        Ok(Err(e)) => return Err(whole(format!("cannot parse mesh: {e}"))),
        Err(_) => return Err(whole("cannot parse mesh: malformed OBJ".to_string())),
    };
    let mut out = Vec::new();
    let mut face_counter = 0usize;
    for model in &models {
        let m = &model.mesh;
        if m.face_arities.iter().any(|&a| a != 3) {
            return Err(whole("only triangle faces are supported".into()));
        }
        let nverts = m.positions.len() / 3;
        let has_normals = !m.normals.is_empty() && !opts.face_normals;
        let has_uv = !m.texcoords.is_empty();
        if has_normals && m.normals.len() != m.positions.len() {
            return Err(whole("normals do not match positions".into()));
        }
        let pos = |i: usize| {
            Vec3::new(
                m.positions[3 * i],
                m.positions[3 * i + 1],
                m.positions[3 * i + 2],
            )
        };
        for tri in m.indices.chunks_exact(3) {
            face_counter += 1;
            let idx = [tri[0] as usize, tri[1] as usize, tri[2] as usize];
            if idx.iter().any(|&i| i >= nverts) {
                return Err(face_error(
                    path,
                    &text,
                    face_counter,
                    "vertex index out of range",
                ));
            }
            let p = idx.map(pos);
            let area2 = (p[1] - p[0])
                .as_dvec3()
                .cross((p[2] - p[0]).as_dvec3())
                .length();
            if area2 == 0.0 || !area2.is_finite() {
                return Err(face_error(
                    path,
                    &text,
                    face_counter,
                    "degenerate (zero-area) triangle",
                ));
            }
            let n = if has_normals {
                let nrm = |i: usize| {
                    let v = Vec3::new(m.normals[3 * i], m.normals[3 * i + 1], m.normals[3 * i + 2]);
                    if opts.flip_normals { -v } else { v }
                };
                let ns = idx.map(nrm);
                if ns.iter().any(|v| v.length_squared() == 0.0) {
                    return Err(face_error(
                        path,
                        &text,
                        face_counter,
                        "zero-length vertex normal",
                    ));
                }
                Some(ns.map(|v| v.normalize()))
            } else {
                None
            };
            let uv = if has_uv {
                idx.map(|i| {
                    let t = m.texcoords.get(2 * i..2 * i + 2).unwrap_or(&[0.0, 0.0]);
                    Vec2::new(t[0], 1.0 - t[1])
                })
            } else {
                // Mitsuba falls back to barycentric coordinates.
                [Vec2::ZERO, Vec2::new(1.0, 0.0), Vec2::new(0.0, 1.0)]
            };
            // flip_normals also turns the geometric normal around, which we
            // express through the winding.
            let (p, n, uv) = if opts.flip_normals {
                (
                    [p[0], p[2], p[1]],
                    n.map(|n| [n[0], n[2], n[1]]),
                    [uv[0], uv[2], uv[1]],
                )
            } else {
                (p, n, uv)
            };
            out.push(ShapeTriangle { p, n, uv });
        }
    }
    if out.is_empty() {
        return Err(whole("mesh has no triangles".into()));
    }
    Ok(out)
}

fn face_error(path: &Path, text: &str, face: usize, msg: &str) -> SceneError {
    let line = text
        .lines()
        .enumerate()
        .filter(|(_, l)| l.trim_start().starts_with("f "))
        .nth(face.saturating_sub(1))
        .map(|(i, _)| i as u32 + 1)
        .unwrap_or(0);
    SceneError::new(path, line, "f", format!("face {face}: {msg}"))
}

/// Line-level validation: every number finite, every face index within the
/// vertices declared so far (OBJ indices are 1-based; negative ones count
/// back from the last vertex), and faces that agree on which attributes
/// they index.
fn scan_obj_text(path: &Path, text: &str, face_normals: bool) -> Result<(), SceneError> {
    let (mut nv, mut nvt, mut nvn) = (0i64, 0i64, 0i64);
    // (line, has vt) of the first face, and the first face without normals.
    let mut first_face: Option<(u32, bool)> = None;
    let mut face_without_vn: Option<u32> = None;
    for (i, line) in text.lines().enumerate() {
        let lineno = i as u32 + 1;
        let mut it = line.split_whitespace();
        let Some(tag) = it.next() else { continue };
        let err = |msg: String| SceneError::new(path, lineno, tag, msg);
        match tag {
            "v" | "vt" | "vn" => {
                let mut count = 0;
                for tok in it {
                    count += 1;
                    match tok.parse::<f32>() {
                        Ok(x) if x.is_finite() => {}
                        Ok(_) => return Err(err(format!("non-finite number '{tok}'"))),
                        Err(_) => return Err(err(format!("'{tok}' is not a number"))),
                    }
                }
                let need = if tag == "vt" { 2 } else { 3 };
                if count < need {
                    return Err(err(format!("needs {need} numbers, got {count}")));
                }
                match tag {
                    "v" => nv += 1,
                    "vt" => nvt += 1,
                    _ => nvn += 1,
                }
            }
            "f" => {
                let corners: Vec<&str> = it.collect();
                if corners.len() != 3 {
                    return Err(err(format!(
                        "only triangles are supported, face has {} corners",
                        corners.len()
                    )));
                }
                let has = |k: usize, c: &&str| c.split('/').nth(k).is_some_and(|p| !p.is_empty());
                let (vt, vn) = (has(1, &corners[0]), has(2, &corners[0]));
                if corners.iter().any(|c| has(1, c) != vt || has(2, c) != vn) {
                    return Err(err(
                        "the corners of a face must all have, or all lack, texture coordinate and normal indices".into(),
                    ));
                }
                // tobj would shift the coordinates of the faces that have
                // them onto the wrong vertices, and the scene format defines
                // no per-face fallback within one mesh.
                match first_face {
                    None => first_face = Some((lineno, vt)),
                    Some((first, first_vt)) if first_vt != vt => {
                        let (with, without) = if vt { (lineno, first) } else { (first, lineno) };
                        return Err(err(format!(
                            "faces with texture coordinates (line {with}) and without (line {without}) in one mesh are not supported"
                        )));
                    }
                    Some(_) => {}
                }
                if !vn && face_without_vn.is_none() {
                    face_without_vn = Some(lineno);
                }
                for c in corners {
                    for (k, part) in c.split('/').enumerate() {
                        if part.is_empty() {
                            continue;
                        }
                        let limit = [nv, nvt, nvn].get(k).copied().unwrap_or(0);
                        let idx: i64 = part
                            .parse()
                            .map_err(|_| err(format!("'{part}' is not an index")))?;
                        let ok = (idx > 0 && idx <= limit) || (idx < 0 && -idx <= limit);
                        if !ok {
                            let what = ["vertex", "texture coordinate", "normal"][k.min(2)];
                            return Err(err(format!(
                                "{what} index {idx} out of range (1..={limit})"
                            )));
                        }
                    }
                }
            }
            // Objects, groups, smoothing groups and materials only split the
            // file into models, whose triangles are all read (materials come
            // from the scene), as in Mitsuba.
            "o" | "g" | "s" | "usemtl" | "mtllib" => {}
            // Lines, points, free-form geometry…: tobj would drop or
            // reinterpret them, so the mesh would not be the file's.
            t if t.starts_with('#') => {}
            other => {
                return Err(err(format!(
                    "'{other}' statements are not part of the scene format (only v, vt, vn, f, o, g, s, usemtl, mtllib and comments)"
                )));
            }
        }
    }
    // The format's smooth shading interpolates the file's vn; a face that
    // indexes none would silently be shaded flat instead (Mitsuba would
    // compute its own vertex normals, which the format leaves undefined).
    if let Some(line) = face_without_vn
        && !face_normals
    {
        let msg = if nvn > 0 {
            "the file has vn normals but this face has no normal indices"
        } else {
            "smooth shading needs vn normals, and the file has none"
        };
        return Err(SceneError::new(
            path,
            line,
            "f",
            format!("{msg} (use face_normals=\"true\" for flat shading)"),
        ));
    }
    Ok(())
}
