//! The 16-wide child kernel: the 4 children × 4 edges of a node in one
//! f32x16, as in the paper (edge e of child k in lane 4·b(e) + k, b a fixed
//! block order, see [`super::quad_x16`]).
//!
//! Every lane builds its two edge endpoints from the node's 3×3 corner grid,
//! maps them into the lobe's cosine space and evaluates θ·(a×b)/|a×b| with
//! the same operations, in the same order, as the scalar kernel
//! ([`super::quad::unit_edge`]); the per-child sums use the scalar
//! kernel's order, (e0 + e1) + (e2 + e3), so both agree lane for lane.
//! The root's children are 4 clipped triangles ([`super::level1`]); coarse
//! nodes whose children have subdivided parallels batch their edges 16 at a
//! time ([`super::coarse_x16`]); deep nodes use the shared density × solid
//! angle path.

use super::children::{EXACT_CLIP_DEPTH, GlossyLtc};
use super::coarse_x16::coarse_children_x16;
use super::fast_math::{cell_solid_angle, dyadic_sincos, step_sincos};
use super::form_factor;
use super::level1::level1_children_x4;
use super::polygon::cached_cell_polygon;
use super::quad_x16::quad_children_x16;
use super::simd::{edge_vectors, load16};
use super::sphere_clip::clipped_integral;
use crate::directional::Cell;
use glam::Vec3;
use wide::{f32x4, i32x4};

/// `ez[j]` = (θ·(a×b)/|a×b|)_z of the edge (P[j], P[j+1]), j < m, of a
/// polygon in structure-of-arrays form, 16 edges at a time, with the scalar
/// [`super::polygon::edge_vector`]'s operations. The arrays must hold at
/// least 16 entries past m − 1 (`ez` too).
pub fn edge_z_soa(x: &[f32], y: &[f32], z: &[f32], m: usize, ez: &mut [f32]) {
    let mut j = 0;
    while j < m {
        let a = [load16(x, j), load16(y, j), load16(z, j)];
        let b = [load16(x, j + 1), load16(y, j + 1), load16(z, j + 1)];
        ez[j..j + 16].copy_from_slice(&edge_vectors(a, b)[2].to_array());
        j += 16;
    }
}

/// Most vertices of a clipped small polygon: a convex polygon of ≤ 6
/// vertices gains at most 2 crossing points.
const SMALL_CLIP: usize = 8;

/// Exactly clipped integrals (2π·F_z × `scale`, clamped at 0) of the 4
/// children of a node whose children are small polygons (≤ 6 vertices: the
/// level-1 quarter spheres). Each child is clipped at z = 0
/// (Sutherland–Hodgman) into its own 8 lanes of two edge-start/edge-end
/// batches, then all edges are evaluated 16 at a time and each child sums
/// its 8 lanes in order. `None` when a polygon does not fit (the caller then
/// clips polygon by polygon). Shared by the scalar and wide kernels.
pub fn clipped_small_children(rows: &[[f32; 3]; 3], scale: f32, cell: Cell) -> Option<[f32; 4]> {
    let mut a = [[0.0f32; 4 * SMALL_CLIP]; 3];
    let mut b = [[0.0f32; 4 * SMALL_CLIP]; 3];
    for k in 0..4 {
        let poly = cached_cell_polygon(cell.child(k))?;
        let n = poly.len();
        if n > 6 {
            return None;
        }
        let mut v = [Vec3::ZERO; 6];
        for (q, p) in v.iter_mut().zip(poly) {
            *q = super::polygon::transform_rows(rows, *p);
        }
        let mut c = [Vec3::ZERO; SMALL_CLIP];
        let mut m = 0;
        for i in 0..n {
            let (p, q) = (v[i], v[if i + 1 == n { 0 } else { i + 1 }]);
            if p.z >= 0.0 {
                if m == SMALL_CLIP {
                    return None;
                }
                c[m] = p;
                m += 1;
            }
            if (p.z >= 0.0) != (q.z >= 0.0) {
                if m == SMALL_CLIP {
                    return None;
                }
                let t = p.z / (p.z - q.z);
                let mut x = p + (q - p) * t;
                x.z = 0.0;
                c[m] = x;
                m += 1;
            }
        }
        if m < 3 {
            continue;
        }
        for i in 0..m {
            let (p, q) = (c[i], c[if i + 1 == m { 0 } else { i + 1 }]);
            let l = SMALL_CLIP * k + i;
            (a[0][l], a[1][l], a[2][l]) = (p.x, p.y, p.z);
            (b[0][l], b[1][l], b[2][l]) = (q.x, q.y, q.z);
        }
    }
    let mut ez = [0.0f32; 4 * SMALL_CLIP];
    for h in 0..2 {
        let o = 16 * h;
        let pa = [load16(&a[0], o), load16(&a[1], o), load16(&a[2], o)];
        let pb = [load16(&b[0], o), load16(&b[1], o), load16(&b[2], o)];
        ez[o..o + 16].copy_from_slice(&edge_vectors(pa, pb)[2].to_array());
    }
    Some(std::array::from_fn(|k| {
        let e = &ez[SMALL_CLIP * k..SMALL_CLIP * (k + 1)];
        let sum = ((e[0] + e[1]) + (e[2] + e[3])) + ((e[4] + e[5]) + (e[6] + e[7]));
        (sum * scale).max(0.0)
    }))
}

/// Heights of the 4 children's centres, child k in lane k (height by the
/// u bit), and their 1 + z, with the values of
/// [`super::children::child_centres`]: with u = 4·ix (converted lane-wise
/// as in `heights_and_radii`: no stale-register dependency between calls,
/// exact below 2^24), m = (u + 1 or 3)·2h is an integer times a power of 2,
/// so the fused m = u·2h + (1 or 3)·2h is exact, and so are z = m − 1,
/// 1 + z = m and 1 − z = 2 − m. The radius (1 − z)(1 + z) then starts
/// from m, two operations earlier than from z, on the deep kernel's chain.
#[inline(always)]
fn centre_heights_x4(cell: Cell) -> (f32x4, f32x4) {
    let height = f32x4::from([1.0, 3.0, 1.0, 3.0]);
    let two_h = f32x4::splat(2.0 / (1u64 << (cell.depth + 2)) as f32);
    let u = i32x4::splat((4 * cell.ix) as i32).round_float();
    let m = u.mul_add(two_h, height * two_h);
    (m - f32x4::splat(1.0), m)
}

/// sin and cos of the 4 children's centre azimuths, child k in lane k
/// (azimuth side by the v bit), with the operations of
/// [`super::children::child_centre_sincos`].
#[inline(always)]
fn centre_sincos_x4(cell: Cell) -> (f32x4, f32x4) {
    let side = f32x4::from([-1.0, -1.0, 1.0, 1.0]);
    let s4 = f32x4::splat;
    let (s1, c1) = dyadic_sincos(2 * cell.iy as u64 + 1, cell.depth + 1);
    let (ss, cs) = step_sincos(cell.depth + 2);
    let ss_l = side * s4(ss);
    let (s1, c1) = (s4(s1), s4(c1));
    (
        s1.mul_add(s4(cs), c1 * ss_l),
        c1.mul_add(s4(cs), -(s1 * ss_l)),
    )
}

/// Unit directions (x, y, z) of the 4 children's centres, child k in lane
/// k, with the values of [`super::children::child_centre_directions`]: its
/// operations, but 1 ± z taken from [`centre_heights_x4`]'s m (the same
/// exact values) and without its clamp of (1 − z)(1 + z) at 0, a no-op
/// here: a centre's |z| < 1.
#[inline(always)]
fn centre_directions_x4(cell: Cell) -> [f32x4; 3] {
    let (z, one_plus_z) = centre_heights_x4(cell);
    let r = ((f32x4::splat(2.0) - one_plus_z) * one_plus_z).sqrt();
    let (s, c) = centre_sincos_x4(cell);
    [r * c, r * s, z]
}

/// D(centre)·Ω for the 4 children, one per lane of an f32x4, with the
/// scalar [`GlossyLtc::children_deep`]'s operations. Four lanes, not
/// sixteen: the call is one chain through a square root and a division,
/// and with twelve idle lanes on 512-bit registers it took 12.5 ns
/// against 9.0 ns on 128-bit ones (same process, levels 6–20). In a
/// sample descent the next level's cell waits on this result, so its
/// latency, not its throughput, is what a level costs.
pub fn children_deep_x4(g: &GlossyLtc, cell: Cell) -> [f32; 4] {
    let s4 = f32x4::splat;
    let [x, y, z] = centre_directions_x4(cell);
    // `deep_row`'s operations, on four lanes.
    let row = |i: usize| {
        let m = &g.rows[i];
        s4(m[0]).mul_add(x, s4(m[1]).mul_add(y, s4(m[2]) * z))
    };
    let p = [row(0), row(1), row(2)];
    let l2 = p[0] * p[0] + p[1] * p[1] + p[2] * p[2];
    let d = (p[2].fast_max(s4(0.0)) * s4(g.deep_scale(cell.depth + 1))) / (l2 * l2);
    let ok = l2.simd_gt(s4(0.0));
    ok.bitselect(d, s4(0.0)).to_array()
}

/// n·ω⁺/π × Ω at the 4 children's centres, child k in lane k, with the
/// operations of the scalar `ShadingLtc::diffuse_centres` (so both agree
/// bit for bit): `Vec3::dot`'s order, (x·x' + y·y') + z·z', no fused
/// products. The guider takes this rule for a plastic's diffuse part at
/// every level from 2 on, where the scalar route called the centres'
/// sines out of line and passed its results through the stack twice: a
/// third of `child_integrals`' profile samples on staircase. Four wide,
/// `guiding/product_pdf` takes 0.91× its time and `product_sample` 0.97×;
/// whole renders, where the memo and the lobes shared by neighbouring
/// pixels spare most descents, did not measurably change (session 58).
/// Forming the centres' directions once for this and a glossy lobe at its
/// own centre rule gained nothing more in those benches.
#[inline]
pub fn diffuse_centres_x4(normal: Vec3, cell: Cell) -> [f32; 4] {
    let s4 = f32x4::splat;
    let omega_over_pi = cell_solid_angle(cell.depth + 1) / std::f32::consts::PI;
    let [x, y, z] = centre_directions_x4(cell);
    let dot = x * s4(normal.x) + y * s4(normal.y) + z * s4(normal.z);
    (dot.fast_max(s4(0.0)) * s4(omega_over_pi)).to_array()
}

/// Cosine-lobe integrals of the 4 children of a node at depth ≥ 5, child k
/// in lane k of an f32x4: the f32 form factors of
/// [`super::form_factor::children_form_factors_f32`] (exact in φ, Gauss in
/// z), then F·n where the equivalent cap clears the horizon, with the
/// operations of the scalar route (`ShadingLtc::diffuse_form_factors`), so
/// both agree bit for bit. Nodes next to a pole take the scalar route;
/// children straddling the horizon are sphere-clipped one at a time.
/// Four lanes, not sixteen, as in [`children_deep_x4`], and the azimuths
/// and sin(Δφ/2) from the sine tables instead of polynomials: through the
/// API at levels 6–20, 30.8 → 16.6–17.0 ns per call (three runs side by
/// side with the 16-lane version).
pub fn diffuse_children_x4(normal: Vec3, cell: Cell) -> [f32; 4] {
    if form_factor::next_to_pole(cell) {
        return form_factor::children_form_factors_f32(cell)
            .map(|f| clipped_integral(f.dot(normal), f.length_squared()));
    }
    let s4 = f32x4::splat;
    let (dz, off, k2_scale) = form_factor::gauss_constants(cell);
    let (z, _) = centre_heights_x4(cell);
    let f = |z: f32x4| (s4(1.0) - z * z).fast_max(s4(0.0)).sqrt();
    let g = s4(0.5 * dz) * (f(z - s4(off)) + f(z + s4(off)));
    let (s, c) = centre_sincos_x4(cell);
    let k2 = g * s4(k2_scale);
    let (fx, fy, fz) = (k2 * c, k2 * s, s4(dz * dz) * z);
    let dot = fx * s4(normal.x) + fy * s4(normal.y) + fz * s4(normal.z);
    let q = fx * fx + fy * fy + fz * fz;
    let r = dot * dot / q;
    let clear = (r * r).simd_ge(q) & q.simd_gt(s4(0.0));
    let fast = dot.fast_max(s4(0.0)).to_array();
    if clear.to_bitmask() == 0xF {
        return fast;
    }
    let (dot, q) = (dot.to_array(), q.to_array());
    std::array::from_fn(|k| clipped_integral(dot[k], q[k]))
}

/// The 4 child integrals of a glossy lobe, 16 lanes wide. Inlined, like
/// the plain-quad kernel, so that the 4 results reach the caller in a
/// register rather than through two stack round trips.
#[inline]
pub fn children_x16(g: &GlossyLtc, cell: Cell, deep_depth: u32) -> [f32; 4] {
    let depth = cell.depth + 1;
    if depth <= EXACT_CLIP_DEPTH {
        return level1_children_x4(&g.rows, g.orientation)
            .unwrap_or_else(|| g.children_exact_f32(cell));
    }
    if depth >= deep_depth {
        return children_deep_x4(g, cell);
    }
    if depth >= g.plain_quad_depth {
        quad_children_x16(g, cell)
    } else if let Some(n) = g.stokes_nodes_at(depth) {
        super::parallel_quadrature_x16::stokes_children_x16(g, cell, n)
    } else {
        coarse_children_x16(g, cell)
    }
}

#[cfg(test)]
mod tests {
    use super::super::children::{LtcOptions, ProductKernel, ShadingLtc};
    use super::super::table::LtcTable;
    use crate::bsdf::{GgxLobe, Lobes};
    use crate::directional::Cell;
    use crate::guiding::product::guiding_ltc_options;
    use crate::math::Frame;
    use crate::sampling::{Rng, square_to_uniform_sphere};

    /// Plastic-like mixtures under the guider's options: wherever both
    /// lobes take their centre rules ([`super::diffuse_centres_x4`] and
    /// [`super::children_deep_x4`]), the wide kernel's sum is the scalar
    /// route's bit for bit, and the descents reach such nodes often.
    #[test]
    fn plastic_centre_rules_equal_the_scalar_sum_bit_for_bit() {
        let table = LtcTable::load_default().unwrap();
        let opts: LtcOptions = guiding_ltc_options();
        let mut rng = Rng::new(58, 1);
        let (mut at_centres, mut compared) = (0, 0);
        for trial in 0..120 {
            let lobes = Lobes {
                diffuse: 0.4,
                ggx: [GgxLobe {
                    weight: 0.6,
                    alpha: [0.02, 0.1, 0.3][trial % 3],
                }],
                ggx_count: 1,
                delta: 0.0,
                side: 1.0,
            };
            let frame = Frame::from_normal(square_to_uniform_sphere(rng.next_2d()));
            let mut wo = square_to_uniform_sphere(rng.next_2d());
            wo.z = wo.z.abs().max(0.05);
            let s = ShadingLtc::new(&lobes, &frame, wo.normalize(), &table, &opts);
            let g = s.glossy[0];
            // A random descent to depth 19.
            let mut cell = Cell::ROOT;
            while cell.depth < 20 {
                let a = s.child_integrals(cell, ProductKernel::Optimized);
                let b = s.child_integrals(cell, ProductKernel::Simd);
                if cell.depth + 1 >= g.deep_depth.max(2) {
                    at_centres += 1;
                    for k in 0..4 {
                        assert!(
                            a[k].to_bits() == b[k].to_bits(),
                            "trial {trial} {cell:?} child {k}: scalar {} wide {}",
                            a[k],
                            b[k]
                        );
                    }
                }
                compared += 1;
                cell = cell.child(rng.next_u32() as usize % 4);
            }
        }
        assert!(
            at_centres > compared / 2,
            "{at_centres} of {compared} nodes at centre rules"
        );
    }
}
