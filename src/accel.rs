//! Ray queries over the scene's primitives: an obvhs compressed-wide BVH
//! (CWBVH, Ylitie et al. 2017) with our own primitive tests.
//!
//! Primitives are reordered into BVH leaf order after the build, so a leaf's
//! primitive index addresses geometry directly without the indirection
//! through `primitive_indices` in the inner loop.

use glam::{Vec3, Vec3A};
use obvhs::{
    BvhBuildParams, aabb::Aabb, cwbvh::CwBvh, cwbvh::builder::build_cwbvh, ray::Ray, ray::RayHit,
};
use std::time::Duration;

/// The geometry a ray test needs, 48 bytes.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
pub struct PrimGeom {
    /// First vertex, or the centre of a sphere.
    pub p0: Vec3,
    pub kind: u32,
    /// Triangle edge p1 − p0, or (radius, 0, 0) for a sphere.
    pub e1: Vec3,
    _pad0: u32,
    pub e2: Vec3,
    _pad1: u32,
}

pub const KIND_TRIANGLE: u32 = 0;
pub const KIND_SPHERE: u32 = 1;

impl PrimGeom {
    pub fn triangle(p0: Vec3, p1: Vec3, p2: Vec3) -> Self {
        PrimGeom {
            p0,
            kind: KIND_TRIANGLE,
            e1: p1 - p0,
            _pad0: 0,
            e2: p2 - p0,
            _pad1: 0,
        }
    }

    pub fn sphere(center: Vec3, radius: f32) -> Self {
        PrimGeom {
            p0: center,
            kind: KIND_SPHERE,
            e1: Vec3::new(radius, 0.0, 0.0),
            _pad0: 0,
            e2: Vec3::ZERO,
            _pad1: 0,
        }
    }

    pub fn aabb(&self) -> Aabb {
        if self.kind == KIND_SPHERE {
            let r = Vec3A::splat(self.e1.x);
            let c = Vec3A::from(self.p0);
            Aabb::new(c - r, c + r)
        } else {
            let p0 = Vec3A::from(self.p0);
            Aabb::from_points(&[p0, p0 + Vec3A::from(self.e1), p0 + Vec3A::from(self.e2)])
        }
    }

    /// Distance to the hit in (tmin, tmax), or +∞.
    #[inline(always)]
    pub fn intersect(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> f32 {
        if self.kind == KIND_TRIANGLE {
            // Möller–Trumbore
            let pvec = d.cross(self.e2);
            let det = self.e1.dot(pvec);
            if det == 0.0 || !det.is_finite() {
                return f32::INFINITY;
            }
            let inv = 1.0 / det;
            let tvec = o - self.p0;
            let u = tvec.dot(pvec) * inv;
            if !(0.0..=1.0).contains(&u) {
                return f32::INFINITY;
            }
            let qvec = tvec.cross(self.e1);
            let v = d.dot(qvec) * inv;
            if v < 0.0 || u + v > 1.0 {
                return f32::INFINITY;
            }
            let t = self.e2.dot(qvec) * inv;
            if t > tmin && t < tmax {
                t
            } else {
                f32::INFINITY
            }
        } else {
            sphere_intersect(self.p0, self.e1.x, o, d, tmin, tmax)
        }
    }
}

/// Ray–sphere in the numerically stable form of Ray Tracing Gems ch. 7
/// (the quadratic's discriminant from the closest-approach vector).
#[inline]
pub fn sphere_intersect(c: Vec3, r: f32, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> f32 {
    let f = o - c;
    let a = d.length_squared();
    let b = -f.dot(d);
    let l = f + (b / a) * d;
    let disc = r * r - l.length_squared();
    if disc < 0.0 {
        return f32::INFINITY;
    }
    let q = b + b.signum() * (a * disc).sqrt();
    let c0 = f.length_squared() - r * r;
    let (mut t0, mut t1) = if q != 0.0 {
        (c0 / q, q / a)
    } else {
        (b / a, b / a)
    };
    if t0 > t1 {
        std::mem::swap(&mut t0, &mut t1);
    }
    if t0 > tmin && t0 < tmax {
        t0
    } else if t1 > tmin && t1 < tmax {
        t1
    } else {
        f32::INFINITY
    }
}

/// A closest hit: the original primitive index and the distance.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    pub prim: u32,
    pub t: f32,
}

pub struct Accel {
    bvh: CwBvh,
    /// Geometry in BVH leaf order.
    prims: Vec<PrimGeom>,
    /// Original primitive index of each entry of `prims`.
    prim_ids: Vec<u32>,
}

impl Accel {
    pub fn build(geometry: &[PrimGeom]) -> Self {
        if geometry.is_empty() {
            return Accel {
                bvh: CwBvh::default(),
                prims: Vec::new(),
                prim_ids: Vec::new(),
            };
        }
        let bounds: Vec<BoundsOnly> = geometry.iter().map(|g| BoundsOnly(g.aabb())).collect();
        let bvh = build_cwbvh(
            &bounds,
            BvhBuildParams::medium_build(),
            &mut Duration::default(),
        );
        let prim_ids: Vec<u32> = bvh.primitive_indices.clone();
        let prims = prim_ids.iter().map(|&i| geometry[i as usize]).collect();
        Accel {
            bvh,
            prims,
            prim_ids,
        }
    }

    /// Closest hit along o + t·d for t in (tmin, tmax).
    #[inline]
    pub fn closest_hit(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<Hit> {
        if self.prims.is_empty() {
            return None;
        }
        let ray = Ray::new(o.into(), d.into(), tmin, tmax);
        let mut hit = RayHit::none();
        let prims = &self.prims;
        if self.bvh.ray_traverse(ray, &mut hit, |r, id| {
            prims[id].intersect(r.origin.into(), r.direction.into(), r.tmin, r.tmax)
        }) {
            Some(Hit {
                prim: self.prim_ids[hit.primitive_id as usize],
                t: hit.t,
            })
        } else {
            None
        }
    }

    /// True if anything blocks the open segment (tmin, tmax).
    #[inline]
    pub fn occluded(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> bool {
        if self.prims.is_empty() {
            return false;
        }
        let ray = Ray::new(o.into(), d.into(), tmin, tmax);
        let prims = &self.prims;
        !self.bvh.ray_traverse_miss(ray, |r, id| {
            prims[id].intersect(r.origin.into(), r.direction.into(), r.tmin, r.tmax)
        })
    }

    pub fn node_count(&self) -> usize {
        self.bvh.nodes.len()
    }
}

struct BoundsOnly(Aabb);

impl obvhs::Boundable for BoundsOnly {
    fn aabb(&self) -> Aabb {
        self.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    #[test]
    fn bvh_agrees_with_brute_force() {
        let mut rng = Rng::new(1, 1);
        let mut r3 = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 10.0;
        let mut geom = Vec::new();
        for _ in 0..300 {
            let p = r3();
            geom.push(PrimGeom::triangle(p, p + r3() * 0.1, p + r3() * 0.1));
        }
        for _ in 0..10 {
            geom.push(PrimGeom::sphere(r3(), 0.3));
        }
        let accel = Accel::build(&geom);
        let mut rng = Rng::new(2, 1);
        let mut hits = 0;
        for _ in 0..2000 {
            let o = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 10.0;
            let d = crate::sampling::square_to_uniform_sphere(rng.next_2d());
            let brute = geom
                .iter()
                .enumerate()
                .map(|(i, g)| (g.intersect(o, d, 0.0, f32::INFINITY), i))
                .fold(
                    (f32::INFINITY, usize::MAX),
                    |a, b| if b.0 < a.0 { b } else { a },
                );
            let bvh = accel.closest_hit(o, d, 0.0, f32::INFINITY);
            match bvh {
                Some(h) => {
                    hits += 1;
                    assert_eq!(h.prim as usize, brute.1);
                    assert!((h.t - brute.0).abs() < 1e-4);
                    assert!(accel.occluded(o, d, 0.0, h.t * 1.001));
                    assert!(!accel.occluded(o, d, 0.0, h.t * 0.999));
                }
                None => assert!(brute.0.is_infinite()),
            }
        }
        assert!(hits > 100);
    }
}
