//! The learned BSDF fraction as an image (the paper's Figure 3): for each
//! pixel, α of the spatial leaf holding the first non-delta vertex seen
//! through the pixel centre (following delta bounces).

use super::sdtree::SdTree;
use crate::math::Frame;
use crate::scene::Scene;
use glam::Vec2;

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
