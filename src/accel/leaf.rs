//! Leaf primitives stored per BVH node: the triangles of all leaf children
//! of a node packed eight to a structure-of-arrays packet, so one 8-wide
//! Möller–Trumbore test replaces up to eight scalar ones. CWBVH leaves hold
//! 1–3 primitives each and a bottom node has up to eight of them; testing
//! them one at a time was over half of the render time.

use super::{KIND_SPHERE, PrimGeom, sphere_intersect};
use glam::Vec3;
use obvhs::cwbvh::CwBvh;
use wide::{f32x8, i32x8};

/// Eight triangles, structure of arrays. Padding lanes have zero edges
/// (det = 0, never a hit) and no slot bit (never active).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub(super) struct Tri8 {
    p0: [[f32; 8]; 3],
    e1: [[f32; 8]; 3],
    e2: [[f32; 8]; 3],
    /// Original primitive index of each lane.
    pub(super) prim: [u32; 8],
    /// 1 << (the node's child slot holding this triangle); 0 for padding.
    slot_bit: [i32; 8],
}

/// A sphere of a leaf child (spheres are rare: tested one at a time).
#[derive(Clone, Copy, Debug)]
pub(super) struct SphereRef {
    center: Vec3,
    radius: f32,
    pub(super) prim: u32,
    slot_bit: u32,
}

/// A ray broadcast to eight lanes.
pub(super) struct Ray8 {
    o: [f32x8; 3],
    d: [f32x8; 3],
    o_s: Vec3,
    d_s: Vec3,
}

impl Ray8 {
    #[inline(always)]
    pub(super) fn new(o: Vec3, d: Vec3) -> Self {
        Ray8 {
            o: [f32x8::splat(o.x), f32x8::splat(o.y), f32x8::splat(o.z)],
            d: [f32x8::splat(d.x), f32x8::splat(d.y), f32x8::splat(d.z)],
            o_s: o,
            d_s: d,
        }
    }
}

impl Tri8 {
    fn empty() -> Self {
        Tri8 {
            p0: [[0.0; 8]; 3],
            e1: [[0.0; 8]; 3],
            e2: [[0.0; 8]; 3],
            prim: [u32::MAX; 8],
            slot_bit: [0; 8],
        }
    }

    /// The child slots this packet holds triangles of.
    pub(super) fn slots(&self) -> u32 {
        self.slot_bit.iter().fold(0, |m, &b| m | b as u32)
    }

    /// Lanes holding a triangle.
    pub(super) fn slots_count(&self) -> usize {
        self.slot_bit.iter().filter(|&&b| b != 0).count()
    }

    /// Lanes whose child slot is in `slots`.
    #[inline(always)]
    pub(super) fn active(&self, slots: u32) -> u32 {
        let bits = i32x8::from(self.slot_bit) & i32x8::splat(slots as i32);
        !bits.simd_eq(i32x8::ZERO).to_bitmask() & 0xff
    }

    /// Möller–Trumbore on eight triangles: the lanes (within `active`) hit
    /// in (tmin, tmax), and every lane's distance and barycentrics (u, v). The operations and their
    /// order are those of [`PrimGeom::intersect`], so a lane's distance is
    /// bit-identical to the scalar test's and the images do not change.
    #[inline(always)]
    pub(super) fn intersect(
        &self,
        ray: &Ray8,
        tmin: f32,
        tmax: f32,
        active: u32,
    ) -> (u32, [f32; 8], [f32; 8], [f32; 8]) {
        let l = |a: &[f32; 8]| f32x8::from(*a);
        let (e1x, e1y, e1z) = (l(&self.e1[0]), l(&self.e1[1]), l(&self.e1[2]));
        let (e2x, e2y, e2z) = (l(&self.e2[0]), l(&self.e2[1]), l(&self.e2[2]));
        let [dx, dy, dz] = ray.d;
        // pvec = d × e2
        let px = dy * e2z - e2y * dz;
        let py = dz * e2x - e2z * dx;
        let pz = dx * e2y - e2x * dy;
        let det = e1x * px + e1y * py + e1z * pz;
        let inv = f32x8::ONE / det;
        let tx = ray.o[0] - l(&self.p0[0]);
        let ty = ray.o[1] - l(&self.p0[1]);
        let tz = ray.o[2] - l(&self.p0[2]);
        let u = (tx * px + ty * py + tz * pz) * inv;
        // qvec = tvec × e1
        let qx = ty * e1z - e1y * tz;
        let qy = tz * e1x - e1z * tx;
        let qz = tx * e1y - e1x * ty;
        let v = (dx * qx + dy * qy + dz * qz) * inv;
        let t = (e2x * qx + e2y * qy + e2z * qz) * inv;
        // The scalar test's rejections, NaN behaviour included.
        let zero = f32x8::ZERO;
        let one = f32x8::ONE;
        let reject = det.simd_eq(zero).to_bitmask()
            | !det.is_finite().to_bitmask()
            | !(u.simd_ge(zero).to_bitmask() & u.simd_le(one).to_bitmask())
            | v.simd_lt(zero).to_bitmask()
            | (u + v).simd_gt(one).to_bitmask()
            | !(t.simd_gt(f32x8::splat(tmin)).to_bitmask()
                & t.simd_lt(f32x8::splat(tmax)).to_bitmask());
        (active & !reject, t.to_array(), u.to_array(), v.to_array())
    }
}

impl SphereRef {
    #[inline(always)]
    pub(super) fn intersect(&self, ray: &Ray8, slots: u32, tmin: f32, tmax: f32) -> f32 {
        if self.slot_bit & slots == 0 {
            return f32::INFINITY;
        }
        sphere_intersect(self.center, self.radius, ray.o_s, ray.d_s, tmin, tmax)
    }
}

/// Appends the primitives of one node's leaf children, given as (slot,
/// range of `bvh.primitive_indices`), to `packets` and `spheres`; returns
/// the number of packets added.
pub(super) fn pack_node_leaves(
    leaves: &[(usize, std::ops::Range<usize>)],
    bvh: &CwBvh,
    geometry: &[PrimGeom],
    packets: &mut Vec<Tri8>,
    spheres: &mut Vec<SphereRef>,
) -> u32 {
    let first = packets.len();
    let mut lane = 8;
    for (slot, range) in leaves {
        for &p in &bvh.primitive_indices[range.clone()] {
            let g = &geometry[p as usize];
            if g.kind == KIND_SPHERE {
                spheres.push(SphereRef {
                    center: g.p0,
                    radius: g.e1.x,
                    prim: p,
                    slot_bit: 1 << slot,
                });
                continue;
            }
            if lane == 8 {
                packets.push(Tri8::empty());
                lane = 0;
            }
            let t = packets.last_mut().expect("pushed above");
            for axis in 0..3 {
                t.p0[axis][lane] = g.p0[axis];
                t.e1[axis][lane] = g.e1[axis];
                t.e2[axis][lane] = g.e2[axis];
            }
            t.prim[lane] = p;
            t.slot_bit[lane] = 1 << slot;
            lane += 1;
        }
    }
    (packets.len() - first) as u32
}
