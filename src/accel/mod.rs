//! Ray queries over the scene's primitives: an obvhs compressed-wide BVH
//! (CWBVH, Ylitie et al. 2017) with our own primitive tests.
//!
//! Each node carries the primitives of its leaf children (see [`leaf`]):
//! triangles in 8-wide packets, so a node's hit leaves are tested together.

mod leaf;

use crate::huge::HugeSlice;
use glam::{Vec3, Vec3A};
use leaf::{Ray8, SphereRef, Tri8, pack_node_leaves};
use obvhs::{BvhBuildParams, aabb::Aabb, cwbvh::CwBvh, cwbvh::builder::build_cwbvh};
use std::time::Duration;
use wide::f32x8;

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
    /// Barycentrics of the hit point (weights of p1 and p2) from the
    /// triangle test; zero for spheres.
    pub uv: (f32, f32),
}

/// A BVH8 node decoded from obvhs's compressed node: the eight child boxes
/// in full precision, structure-of-arrays, so one 8-wide slab test
/// (`wide::f32x8`, one AVX register per plane) tests all children.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct Node8 {
    lo: [[f32; 8]; 3],
    hi: [[f32; 8]; 3],
    /// Node index of each internal child.
    child: [u32; 8],
    /// Bit s set when slot s is a leaf.
    leaf_mask: u32,
    /// This node's leaf triangles: `packets[packet..packet + n_packets]`.
    packet: u32,
    n_packets: u32,
    /// This node's leaf spheres: `spheres[sphere..sphere + n_spheres]`.
    sphere: u32,
    n_spheres: u32,
    /// The child slots each of the first eight packets holds triangles
    /// of, so packets of missed leaves are skipped without loading them
    /// (packets are cold: a miss each). Later packets are all-ones.
    packet_slots: [u8; 8],
}

const STACK_SIZE: usize = 128;

/// The scene's BVH: built by obvhs (PLOC + reinsertion, collapsed to a
/// compressed wide BVH8), traversed by our own CPU traversal. obvhs's
/// traversal is the GPU-style ordered-by-octant CWBVH walk with two 4-wide
/// SSE box tests per node; decoding the quantised boxes once at build time
/// and testing all eight children in one AVX pass, nearest first, is what
/// makes this renderer faster than the reference CPU renderer (see the
/// closing notes for the measured ratio).
pub struct Accel {
    nodes: HugeSlice<Node8>,
    packets: HugeSlice<Tri8>,
    spheres: Vec<SphereRef>,
}

impl Accel {
    pub fn build(geometry: &[PrimGeom]) -> Self {
        if geometry.is_empty() {
            return Accel {
                nodes: HugeSlice::new(Vec::new()),
                packets: HugeSlice::new(Vec::new()),
                spheres: Vec::new(),
            };
        }
        let bounds: Vec<BoundsOnly> = geometry.iter().map(|g| BoundsOnly(g.aabb())).collect();
        let bvh = build_cwbvh(
            &bounds,
            BvhBuildParams::medium_build(),
            &mut Duration::default(),
        );
        let (nodes, packets, spheres) = decode_nodes(&bvh, geometry);
        Accel {
            nodes: HugeSlice::new(nodes),
            packets: HugeSlice::new(packets),
            spheres,
        }
    }

    /// Closest hit along o + t·d for t in (tmin, tmax).
    #[inline(always)]
    pub fn closest_hit(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<Hit> {
        self.closest_hit_in_registers(o.x, o.y, o.z, d.x, d.y, d.z, tmin, tmax)
    }

    /// Not inlined: the traversal is large and its callers inline the hit's
    /// interaction. The ray comes as eight floats, which the ABI passes in
    /// xmm registers; as two `Vec3`s it was passed through stack copies
    /// that the traversal's first instructions had to reload.
    #[allow(clippy::too_many_arguments)]
    #[inline(never)]
    fn closest_hit_in_registers(
        &self,
        ox: f32,
        oy: f32,
        oz: f32,
        dx: f32,
        dy: f32,
        dz: f32,
        tmin: f32,
        tmax: f32,
    ) -> Option<Hit> {
        let (o, d) = (Vec3::new(ox, oy, oz), Vec3::new(dx, dy, dz));
        let mut best = tmax;
        let mut best_prim = u32::MAX;
        let mut uv = (0.0, 0.0);
        self.traverse::<false>(o, d, tmin, &mut best, &mut best_prim, &mut uv, u32::MAX);
        (best_prim != u32::MAX).then_some(Hit {
            prim: best_prim,
            t: best,
            uv,
        })
    }

    /// True if anything blocks the open segment (tmin, tmax).
    #[inline]
    pub fn occluded(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> bool {
        self.occluded_except(o, d, tmin, tmax, u32::MAX)
    }

    /// Like [`occluded`](Self::occluded), ignoring primitive `skip` (an
    /// original index). A shadow ray towards a point sampled on an emitter
    /// must not be blocked by that emitter's own primitive: from an offset
    /// origin, a ray to a point near a sphere's silhouette can clip the
    /// sphere before reaching it, which would darken every sphere light.
    #[inline]
    pub fn occluded_except(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32, skip: u32) -> bool {
        let mut t = tmax;
        let mut prim = u32::MAX;
        let mut uv = (0.0, 0.0);
        self.traverse::<true>(o, d, tmin, &mut t, &mut prim, &mut uv, skip);
        prim != u32::MAX
    }

    // Always inlined into its two callers, so the ray's parts as separate
    // arguments cost nothing.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn traverse<const ANY_HIT: bool>(
        &self,
        o: Vec3,
        d: Vec3,
        tmin: f32,
        tmax: &mut f32,
        hit_prim: &mut u32,
        hit_uv: &mut (f32, f32),
        skip: u32,
    ) {
        if self.nodes.is_empty() {
            return;
        }
        let inv = safe_inverse(d);
        // Slab planes as t = plane·inv − o·inv, one fused multiply-add each.
        let inv_x = f32x8::splat(inv.x);
        let inv_y = f32x8::splat(inv.y);
        let inv_z = f32x8::splat(inv.z);
        let oi_x = f32x8::splat(o.x * inv.x);
        let oi_y = f32x8::splat(o.y * inv.y);
        let oi_z = f32x8::splat(o.z * inv.z);
        // Which plane is near depends on the direction's sign per axis.
        let (nx, ny, nz) = (
            (inv.x < 0.0) as usize,
            (inv.y < 0.0) as usize,
            (inv.z < 0.0) as usize,
        );
        let tmin_v = f32x8::splat(tmin);
        let ray = Ray8::new(o, d);
        // Uninitialised: zeroing 1 KiB per ray costs as much as traversing
        // a small scene. Only entries below `sp` are ever read.
        let mut stack = [std::mem::MaybeUninit::<(u32, f32)>::uninit(); STACK_SIZE];
        let mut sp = 1usize;
        stack[0].write((0, tmin));
        while sp > 0 {
            sp -= 1;
            // SAFETY: every slot below `sp` was written before `sp` passed it.
            let (index, t_enter) = unsafe { stack[sp].assume_init() };
            if t_enter > *tmax {
                continue;
            }
            let node = &self.nodes[index as usize];
            let planes = [&node.lo, &node.hi];
            let near_x = f32x8::from(planes[nx][0]).mul_sub(inv_x, oi_x);
            let far_x = f32x8::from(planes[1 - nx][0]).mul_sub(inv_x, oi_x);
            let near_y = f32x8::from(planes[ny][1]).mul_sub(inv_y, oi_y);
            let far_y = f32x8::from(planes[1 - ny][1]).mul_sub(inv_y, oi_y);
            let near_z = f32x8::from(planes[nz][2]).mul_sub(inv_z, oi_z);
            let far_z = f32x8::from(planes[1 - nz][2]).mul_sub(inv_z, oi_z);
            let t_near = near_x.fast_max(near_y).fast_max(near_z.fast_max(tmin_v));
            // Robust slab test (Ize 2013): widen the far distance by 2γ₃ so
            // that rounding never culls a box the ray touches.
            let t_far = far_x
                .fast_min(far_y)
                .fast_min(far_z.fast_min(f32x8::splat(*tmax)))
                * f32x8::splat(1.000_000_4);
            let mut mask = t_near.simd_le(t_far).to_bitmask();
            if mask == 0 {
                continue;
            }
            let leaf_hit = mask & node.leaf_mask;
            if leaf_hit != 0 {
                // Lanes hit in node order (slot, then primitive), nearest
                // strictly first: the order the scalar loop visited them in.
                let packets = node.packet as usize..(node.packet + node.n_packets) as usize;
                for (k, packet) in self.packets[packets].iter().enumerate() {
                    let slots = node.packet_slots.get(k).map_or(0xff, |&m| m as u32);
                    if slots & leaf_hit == 0 {
                        continue;
                    }
                    let active = packet.active(leaf_hit);
                    if active == 0 {
                        continue;
                    }
                    let (mut hits, t, u, v) = packet.intersect(&ray, tmin, *tmax, active);
                    while hits != 0 {
                        let lane = hits.trailing_zeros() as usize;
                        hits &= hits - 1;
                        let p = packet.prim[lane];
                        if t[lane] < *tmax && p != skip {
                            *tmax = t[lane];
                            *hit_prim = p;
                            *hit_uv = (u[lane], v[lane]);
                            if ANY_HIT {
                                return;
                            }
                        }
                    }
                }
                let spheres = node.sphere as usize..(node.sphere + node.n_spheres) as usize;
                for sphere in &self.spheres[spheres] {
                    let t = sphere.intersect(&ray, leaf_hit, tmin, *tmax);
                    if t < *tmax && sphere.prim != skip {
                        *tmax = t;
                        *hit_prim = sphere.prim;
                        *hit_uv = (0.0, 0.0);
                        if ANY_HIT {
                            return;
                        }
                    }
                }
                mask &= !leaf_hit;
            }
            if mask == 0 {
                continue;
            }
            let t_near = t_near.to_array();
            // Internal children hit, to be pushed farthest first.
            let mut pending = [(0u32, 0f32); 8];
            let mut n_pending = 0usize;
            while mask != 0 {
                let slot = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                let t = t_near[slot];
                let mut k = n_pending;
                // Insertion sort by decreasing distance (≤ 8 entries).
                // Occlusion asks whether anything is hit, not what is hit
                // first, so its children go in slot order unsorted.
                while !ANY_HIT && k > 0 && pending[k - 1].1 < t {
                    pending[k] = pending[k - 1];
                    k -= 1;
                }
                pending[k] = (node.child[slot], t);
                n_pending += 1;
                // The farther children are popped only after the nearer
                // subtrees, by when their lines have arrived. (Prefetched
                // before the parent's leaf tests instead, the extra loop
                // over the hit mask cost more than it hid.)
                crate::huge::prefetch(&self.nodes[node.child[slot] as usize]);
            }
            if sp + n_pending > STACK_SIZE {
                // Unreachable for obvhs trees (depth ≪ 16); never overflow.
                n_pending = STACK_SIZE - sp;
            }
            for (slot, &entry) in stack[sp..sp + n_pending]
                .iter_mut()
                .zip(&pending[..n_pending])
            {
                slot.write(entry);
            }
            sp += n_pending;
        }
    }

    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Node and packet counts with their memory, for `info`: traversal
    /// speed on large scenes follows how much of this stays in cache.
    pub fn summary(&self) -> String {
        let tris: usize = self.packets.iter().map(|p| p.slots_count()).sum();
        let mib = |n: usize, size: usize| (n * size) as f64 / (1 << 20) as f64;
        format!(
            "{} nodes ({:.1} MiB), {} triangle packets ({:.1} MiB, {:.2} triangles each), {} spheres",
            self.nodes.len(),
            mib(self.nodes.len(), size_of::<Node8>()),
            self.packets.len(),
            mib(self.packets.len(), size_of::<Tri8>()),
            tris as f64 / self.packets.len().max(1) as f64,
            self.spheres.len()
        )
    }
}

/// 1/d per axis, with near-zero components replaced by ±ε·10⁻⁶ so the
/// slab distances stay finite; one packed division for the three axes.
#[inline(always)]
fn safe_inverse(d: Vec3) -> Vec3 {
    const TINY: f32 = f32::EPSILON * 1e-6;
    let d = Vec3A::from(d);
    let tiny = Vec3A::splat(TINY).copysign(d);
    Vec3::from(Vec3A::ONE / Vec3A::select(d.abs().cmple(Vec3A::splat(TINY)), tiny, d))
}

/// Decodes obvhs's quantised child boxes (plane = p + 2^(e−127)·q) into
/// full-precision boxes and packs each node's leaf primitives. The
/// quantisation rounds outwards, so the decoded box still contains the
/// child; empty slots get an inverted box.
fn decode_nodes(bvh: &CwBvh, geometry: &[PrimGeom]) -> (Vec<Node8>, Vec<Tri8>, Vec<SphereRef>) {
    let mut packets = Vec::new();
    let mut spheres = Vec::new();
    let nodes = bvh
        .nodes
        .iter()
        .map(|n| {
            let mut out = Node8 {
                lo: [[f32::INFINITY; 8]; 3],
                hi: [[f32::NEG_INFINITY; 8]; 3],
                child: [0; 8],
                leaf_mask: 0,
                packet: packets.len() as u32,
                n_packets: 0,
                sphere: spheres.len() as u32,
                n_spheres: 0,
                packet_slots: [0; 8],
            };
            let mut leaves = Vec::new();
            for slot in 0..8 {
                if n.is_child_empty(slot) {
                    continue;
                }
                let b = n.child_aabb(slot);
                for axis in 0..3 {
                    out.lo[axis][slot] = b.min[axis];
                    out.hi[axis][slot] = b.max[axis];
                }
                if n.is_leaf(slot) {
                    let (start, count) = n.child_primitives(slot);
                    out.leaf_mask |= 1 << slot;
                    leaves.push((slot, start as usize..(start + count) as usize));
                } else {
                    out.child[slot] = n.child_node_index(slot);
                }
            }
            out.n_packets = pack_node_leaves(&leaves, bvh, geometry, &mut packets, &mut spheres);
            let first = out.packet as usize;
            for (mask, packet) in out.packet_slots.iter_mut().zip(&packets[first..]) {
                *mask = packet.slots() as u8;
            }
            out.n_spheres = spheres.len() as u32 - out.sphere;
            out
        })
        .collect();
    (nodes, packets, spheres)
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
