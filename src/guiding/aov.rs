//! The learned BSDF fraction as an image (the paper's Figure 3): for each
//! pixel, α of the spatial leaf holding the first non-delta vertex seen
//! through the pixel centre (following delta bounces).

use super::sdtree::SdTree;
use crate::integrator::first_vertex::at_pixel_centre;
use crate::scene::Scene;
use std::path::{Path, PathBuf};

/// α per pixel, `None` where the camera ray finds no vertex to guide (see
/// [`crate::integrator::first_vertex::first_non_delta_vertex`]).
pub fn alpha_aov(scene: &Scene, tree: &SdTree) -> Vec<Option<f32>> {
    let (w, h) = (scene.camera.width, scene.camera.height);
    (0..w * h)
        .map(|i| {
            let v = at_pixel_centre(scene, i)?;
            Some(tree.bsdf_fraction(tree.lookup(v.p)))
        })
        .collect()
}

/// The EXR and PNG paths [`write_alpha_aov`] writes for the render `out`.
pub fn alpha_aov_paths(out: &Path) -> (PathBuf, PathBuf) {
    let stem = out.with_extension("");
    let exr = PathBuf::from(format!("{}-alpha.exr", stem.display()));
    let png = exr.with_extension("png");
    (exr, png)
}

/// Writes the α the render used next to the render `out` as
/// `OUT-alpha.exr` (α in every channel, 0 where there is no vertex) and a
/// false-colour PNG (black there): [`alpha_aov`], or `fixed` (a
/// `--bsdf-fraction`) wherever there is a vertex, since Adam still trains
/// the leaves' fractions that such a run never uses.
pub fn write_alpha_aov(
    scene: &Scene,
    tree: &SdTree,
    fixed: Option<f32>,
    out: &Path,
) -> Result<(), String> {
    let mut alpha = alpha_aov(scene, tree);
    if let Some(a) = fixed {
        alpha.iter_mut().flatten().for_each(|v| *v = a);
    }
    let (w, h) = (scene.camera.width, scene.camera.height);
    let (exr, png) = alpha_aov_paths(out);
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
