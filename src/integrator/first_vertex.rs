//! The first non-delta vertex seen through a pixel centre, following delta
//! bounces deterministically: where a pixel's paths first meet a surface
//! that guiding can act on. Shared by the α image and the attribution's
//! split of the variance by material.

use crate::bsdf::Bsdf;
use crate::scene::Scene;
use glam::{Vec2, Vec3};

/// Delta bounces followed before giving up (a hall of mirrors).
const MAX_DELTA_BOUNCES: usize = 8;

pub struct FirstVertex {
    pub p: Vec3,
    pub bsdf: Bsdf,
    /// ω_o in the vertex's shading frame.
    pub wo_local: Vec3,
}

/// The first non-delta vertex on the ray through `film` (pixel
/// coordinates), `None` where the ray leaves the scene, meets only delta
/// surfaces, or meets a surface that reflects nothing (paths end there, so
/// no guide acts on it). A delta surface is left through its first lobe
/// (the sample at u = 0), as a deterministic stand-in for the paths' choice.
pub fn first_non_delta_vertex(scene: &Scene, film: Vec2) -> Option<FirstVertex> {
    let (mut o, mut d) = scene.camera.ray(film);
    for _ in 0..MAX_DELTA_BOUNCES {
        let it = scene.intersect(o, d, f32::INFINITY)?;
        let material = scene.material_of(&it);
        if material.reflects_nothing() {
            return None;
        }
        let bsdf = material.at(it.uv);
        let wo_local = it.frame.to_local(-d);
        if !bsdf.has_smooth_lobes_only() {
            return Some(FirstVertex {
                p: it.p,
                bsdf,
                wo_local,
            });
        }
        let s = bsdf.sample(wo_local, 0.0, Vec2::splat(0.5))?;
        d = it.frame.to_world(s.wi);
        o = super::path::spawn_origin(scene, it.p, it.ng, d);
    }
    None
}

/// [`first_non_delta_vertex`] through the centre of pixel `i` (row-major).
pub fn at_pixel_centre(scene: &Scene, i: usize) -> Option<FirstVertex> {
    let w = scene.camera.width;
    first_non_delta_vertex(scene, Vec2::new((i % w) as f32 + 0.5, (i / w) as f32 + 0.5))
}
