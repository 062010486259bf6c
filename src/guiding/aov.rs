//! The learned BSDF fraction as an image (the paper's Figure 3): for each
//! pixel, α of the spatial leaf holding the first non-delta vertex seen
//! through the pixel centre (following delta bounces).

use super::sdtree::SdTree;
use crate::math::Frame;
use crate::scene::Scene;
use glam::Vec2;
use std::path::{Path, PathBuf};

/// α per pixel, `None` where the camera ray leaves the scene or meets only
/// delta surfaces.
pub fn alpha_aov(scene: &Scene, tree: &SdTree) -> Vec<Option<f32>> {
    let (w, h) = (scene.camera.width, scene.camera.height);
    (0..w * h)
        .map(|i| {
            let film = Vec2::new((i % w) as f32 + 0.5, (i / w) as f32 + 0.5);
            let (mut o, mut d) = scene.camera.ray(film);
            for _ in 0..8 {
                let it = scene.intersect(o, d, f32::INFINITY)?;
                let bsdf = scene.material_of(&it).at(it.uv);
                if !bsdf.has_smooth_lobes_only() {
                    return Some(tree.bsdf_fraction(tree.lookup(it.p)));
                }
                // Follow the (first) delta lobe deterministically.
                let wo = it.frame.to_local(-d);
                let s = bsdf.sample(wo, 0.0, Vec2::splat(0.5))?;
                let frame: &Frame = &it.frame;
                d = frame.to_world(s.wi);
                o = crate::integrator::path::spawn_origin(scene, it.p, it.ng, d);
            }
            None
        })
        .collect()
}

/// Writes [`alpha_aov`] next to the render `out` as `OUT-alpha.exr` (α in
/// every channel, 0 where there is no vertex) and a false-colour PNG
/// (black there).
pub fn write_alpha_aov(scene: &Scene, tree: &SdTree, out: &Path) -> Result<(), String> {
    let alpha = alpha_aov(scene, tree);
    let (w, h) = (scene.camera.width, scene.camera.height);
    let stem = out.with_extension("");
    let exr = PathBuf::from(format!("{}-alpha.exr", stem.display()));
    let png = exr.with_extension("png");
    let values: Vec<glam::Vec3> = alpha
        .iter()
        .map(|a| glam::Vec3::splat(a.unwrap_or(0.0)))
        .collect();
    crate::film::exr_io::write_rgb(&exr, w, h, &values)?;
    let rgb: Vec<u8> = alpha
        .iter()
        .flat_map(|a| a.map_or([0, 0, 0], crate::experiment::colormap::viridis))
        .collect();
    crate::film::png_io::write_png_rgb8(&png, w, h, &rgb)?;
    eprintln!("alpha AOV -> {} and {}", exr.display(), png.display());
    Ok(())
}
