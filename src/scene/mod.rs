//! The renderable scene: geometry with its BVH, materials, emitters and the
//! camera, loaded from the Mitsuba 3 XML subset.

pub mod error;
mod loader;
mod loader_materials;
pub mod obj;
pub mod shapes;
pub mod xml;

pub use error::SceneError;
pub use loader::{load_scene, load_scene_from_str};

use crate::accel::{Accel, Hit, KIND_SPHERE, PrimGeom};
use crate::bsdf::Material;
use crate::camera::Camera;
use crate::emitter::Lights;
use crate::huge::HugeSlice;
use crate::math::Frame;
use glam::{Vec2, Vec3};
use std::path::PathBuf;

/// One `<shape>`: which material it uses and whether it emits.
#[derive(Clone, Debug)]
pub struct Shape {
    pub material: u32,
    /// Index into `Lights::lights` of its area emitter.
    pub light: Option<u32>,
}

/// Per-triangle shading data (indexed by primitive id).
#[derive(Clone, Copy, Debug)]
pub struct TriangleShading {
    pub n: Option<[Vec3; 3]>,
    pub uv: [Vec2; 3],
}

pub struct Scene {
    pub file: PathBuf,
    pub name: String,
    pub camera: Camera,
    pub materials: Vec<Material>,
    pub shapes: Vec<Shape>,
    /// Geometry in primitive-id order: all triangles, then all spheres.
    pub geometry: HugeSlice<PrimGeom>,
    pub triangle_shading: HugeSlice<TriangleShading>,
    /// Unit geometric normal of each triangle (indexed by primitive id),
    /// computed once: per hit it was a square root and a division on the
    /// path's critical path.
    pub triangle_normals: HugeSlice<Vec3>,
    /// Shape of each primitive.
    pub prim_shape: HugeSlice<u32>,
    pub accel: Accel,
    pub lights: Lights,
    /// Maximum number of path segments (Mitsuba's `max_depth`), `None` = unlimited.
    pub max_depth: Option<u32>,
    pub bounds: (Vec3, Vec3),
    /// Elements that were ignored, with their location.
    pub warnings: Vec<String>,
}

/// A surface point hit by a ray.
#[derive(Clone, Copy, Debug)]
pub struct Interaction {
    pub p: Vec3,
    pub t: f32,
    /// Geometric normal (follows `flip_normals` and the winding).
    pub ng: Vec3,
    /// Shading frame; `frame.n` is the shading normal.
    pub frame: Frame,
    pub uv: Vec2,
    pub shape: u32,
    pub prim: u32,
}

impl Scene {
    /// Inlined into the path loop with [`interaction`](Self::interaction):
    /// returned through memory, the interaction was copied back in wider
    /// loads than it had been stored in, a store-forwarding stall per ray.
    #[inline(always)]
    pub fn intersect(&self, o: Vec3, d: Vec3, tmax: f32) -> Option<Interaction> {
        let hit = self.accel.closest_hit(o, d, 0.0, tmax)?;
        Some(self.interaction(o, d, hit))
    }

    pub fn occluded(&self, o: Vec3, d: Vec3, tmax: f32) -> bool {
        self.accel.occluded(o, d, 0.0, tmax)
    }

    /// Occlusion of a shadow ray towards emitter primitive `light_prim`.
    pub fn occluded_except(&self, o: Vec3, d: Vec3, tmax: f32, light_prim: u32) -> bool {
        self.accel.occluded_except(o, d, 0.0, tmax, light_prim)
    }

    #[inline(always)]
    pub fn interaction(&self, o: Vec3, d: Vec3, hit: Hit) -> Interaction {
        let g = &self.geometry[hit.prim as usize];
        let shape = self.prim_shape[hit.prim as usize];
        if g.kind == KIND_SPHERE {
            let p = o + d * hit.t;
            let local = (p - g.p0) / g.e1.x;
            let n = local.normalize_or(Vec3::Z) * g.e2.x.signum_or_one();
            let theta = local.z.clamp(-1.0, 1.0).acos();
            let mut phi = local.y.atan2(local.x);
            if phi < 0.0 {
                phi += std::f32::consts::TAU;
            }
            return Interaction {
                // Re-project onto the surface: the ray-parametric point drifts.
                p: g.p0 + local.normalize_or(Vec3::Z) * g.e1.x,
                t: hit.t,
                ng: n,
                frame: Frame::from_normal(n),
                uv: Vec2::new(phi / std::f32::consts::TAU, theta / std::f32::consts::PI),
                shape,
                prim: hit.prim,
            };
        }
        // The triangle test's barycentrics: no re-projection of p (two
        // divisions and nine dot products per hit). The clamps keep the
        // point inside the triangle against rounding.
        let b1 = hit.uv.0.clamp(0.0, 1.0);
        let b2 = hit.uv.1.clamp(0.0, 1.0 - b1);
        let b0 = 1.0 - b1 - b2;
        let ng = self.triangle_normals[hit.prim as usize];
        let sh = &self.triangle_shading[hit.prim as usize];
        let ns = match sh.n {
            Some(n) => (n[0] * b0 + n[1] * b1 + n[2] * b2).normalize_or(ng),
            None => ng,
        };
        Interaction {
            p: g.p0 + g.e1 * b1 + g.e2 * b2,
            t: hit.t,
            ng,
            frame: Frame::from_normal(ns),
            uv: sh.uv[0] * b0 + sh.uv[1] * b1 + sh.uv[2] * b2,
            shape,
            prim: hit.prim,
        }
    }

    pub fn material_of(&self, it: &Interaction) -> &Material {
        &self.materials[self.shapes[it.shape as usize].material as usize]
    }

    /// The geometric normal `interaction` reports for a triangle.
    pub fn triangle_normal(g: &PrimGeom) -> Vec3 {
        g.e1.cross(g.e2).normalize_or(Vec3::Z)
    }

    pub fn triangle_count(&self) -> usize {
        self.triangle_shading.len()
    }

    /// Distance scale used to offset ray origins off surfaces.
    pub fn ray_epsilon(&self, p: Vec3) -> f32 {
        1e-4 * (1.0 + p.abs().max_element())
    }
}

trait SignumOrOne {
    fn signum_or_one(self) -> f32;
}

impl SignumOrOne for f32 {
    /// Sphere primitives store −1 in e2.x when their normals are flipped.
    fn signum_or_one(self) -> f32 {
        if self < 0.0 { -1.0 } else { 1.0 }
    }
}
