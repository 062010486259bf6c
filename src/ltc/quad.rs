//! Children that are plain quads (depth ≥ 6: no parallel is subdivided),
//! scalar: the 4 children of a node share a 3×3 corner grid, so 9 corners
//! are mapped into the lobe's cosine space and normalised once, and the 12
//! distinct edges (6 on parallels, 6 on meridians; interior ones serve two
//! children with opposite orientation) are integrated once each.
//!
//! With unit vertices an edge's term is (θ/sin θ)(a·b)·(a×b): no atan2, no
//! division, and (a×b) keeps the accuracy of short edges (θ/sin θ → 1 is
//! flat there). [`super::quad_x16`] evaluates the same 16 child edges with
//! the same operations, one lane each, so both agree bit for bit.
//!
//! Three freedoms make the corner map cheap, all exact for the result:
//! a corner is only needed as a direction (so (cos φ, sin φ, cot θ), see
//! [`NodeGrid`]); F_z and |F|, all the kernels use, do not change under a
//! turn about the cosine-space z axis (so [`quad_rows`] has a zero); and
//! past level ~6 every edge of a node is short (so θ/sin θ is a cubic,
//! [`super::fast_math::theta_over_sin_short`], whose coefficients then
//! carry the integral's scale too: [`short_poly`]).

use super::children::{GlossyLtc, HorizonSide, child_grid};
use super::fast_math::{
    DYADIC_BITS, RSQRT_FLOOR, SHORT_EDGE_MIN_COS, THETA_OVER_SIN_SHORT, dyadic_entries,
    dyadic_sincos, rsqrt, short_polynomial, step_sincos, theta_over_sin,
};
use super::polygon::transform_rows;
use crate::directional::Cell;
use glam::Vec3;
use std::f32::consts::PI;

/// The short-edge θ/sin θ cubic times the integral's scale, orientation/2π
/// (`GlossyLtc::short_poly`): a short node's children are then the sums of
/// its edge terms as they are.
pub fn short_poly(orientation: f32) -> [f32; 4] {
    THETA_OVER_SIN_SHORT.map(|c| c * (orientation * (0.5 / PI)))
}

/// [`short_poly`] with coefficient k divided by 4^(k+1) (exact: powers of
/// 2), for the wide kernel's vertices of length 2.
pub fn short_poly_by_4(orientation: f32) -> [f32; 4] {
    let c = short_poly(orientation);
    [c[0] / 4.0, c[1] / 16.0, c[2] / 64.0, c[3] / 256.0]
}

/// R·A by rows (f32), R the turn about the cosine-space z axis that makes
/// the first row's z entry exactly 0: the corner map then needs no
/// operation for it. The plain-quad kernels use F_z and |F| only, which R
/// keeps (the horizon row is A's own).
pub fn quad_rows(a: &glam::DMat3) -> [[f32; 3]; 3] {
    let r = a.transpose();
    let (a0, a1, a2) = (r.col(0), r.col(1), r.col(2));
    let hyp = a0.z.hypot(a1.z);
    let (c, s) = if hyp > 0.0 {
        (a1.z / hyp, a0.z / hyp)
    } else {
        (1.0, 0.0)
    };
    let (q0, q1) = (a0 * c - a1 * s, a0 * s + a1 * c);
    [
        [q0.x as f32, q0.y as f32, 0.0],
        [q1.x as f32, q1.y as f32, q1.z as f32],
        [a2.x as f32, a2.y as f32, a2.z as f32],
    ]
}

/// Floor of r² = (1 − z)(1 + z) before the cotangent divides by r: only
/// the poles (r = 0) see it — the smallest other r², at depth 22, is
/// ~2^-20, and adding 2^-48 to it rounds back — and there it turns
/// z/r into ±2^24, far enough that the map of the pole is A·ẑ to f32
/// precision, without an infinity.
pub const POLE_R2_FLOOR: f32 = 1.0 / (1u64 << 48) as f32;

/// The 3×3 corner grid of a node's children: heights, cot θ = z/√(1 − z²)
/// and sin, cos of the azimuths (index 1 is the node's centre meridian).
/// A corner (r·cos φ, r·sin φ, z) is only needed as a direction, so it is
/// taken as (cos φ, sin φ, cot θ): mapped by A that is P(φ) + cot θ·A·ẑ,
/// one fused operation per coordinate instead of two.
#[derive(Clone, Copy, Debug)]
pub struct NodeGrid {
    pub z: [f32; 3],
    pub cot: [f32; 3],
    pub sin: [f32; 3],
    pub cos: [f32; 3],
}

/// sin, cos of φ_n + ψ, φ_n = 2π·n/2^depth given by its [`dyadic_entries`]
/// (high, low), from (cos ψ, sin ψ): rotated by the low part, then by the
/// high part. At ψ = 0 both rotations reduce to [`dyadic_sincos`]'s angle
/// addition, so the centre azimuth is its value; the wide kernel rotates
/// its lanes with these operations, straight from the table entries.
#[inline(always)]
pub fn rotate_by_entries(
    ([sh, ch], [sl, cl]): ([f32; 2], [f32; 2]),
    co: f32,
    so: f32,
) -> (f32, f32) {
    let (ec, es) = (cl.mul_add(co, -(sl * so)), sl.mul_add(co, cl * so));
    (sh.mul_add(ec, ch * es), ch.mul_add(ec, -(sh * es)))
}

/// Corner grid of `cell`'s children. The azimuths are dyadic: the centre's
/// two table entries rotated by a child's width either way (deeper than the
/// tables resolve, the centre rotated by the width).
#[inline]
pub fn node_grid(cell: Cell) -> NodeGrid {
    let (z, _) = child_grid(cell);
    // (1 − z)(1 + z) is exact near the poles, where 1 − z² cancels.
    let cot = z.map(|z| z / (1.0 - z).mul_add(1.0 + z, POLE_R2_FLOOR).sqrt());
    let d = cell.depth + 1;
    let n = 2 * cell.iy as u64 + 1;
    let (ss, cs) = step_sincos(d);
    let (sin, cos) = if d <= DYADIC_BITS {
        let e = dyadic_entries(n, d);
        let [(s0, c0), (s1, c1), (s2, c2)] =
            [(cs, -ss), (1.0, 0.0), (cs, ss)].map(|(co, so)| rotate_by_entries(e, co, so));
        ([s0, s1, s2], [c0, c1, c2])
    } else {
        let (s1, c1) = dyadic_sincos(n, d);
        (
            [s1.mul_add(cs, -(c1 * ss)), s1, s1.mul_add(cs, c1 * ss)],
            [c1.mul_add(cs, s1 * ss), c1, c1.mul_add(cs, -(s1 * ss))],
        )
    };
    NodeGrid { z, cot, sin, cos }
}

/// P(φ) = A·(cos φ, sin φ, 0) per azimuth of the grid: `p[vi]`.
#[inline(always)]
pub fn grid_columns(rows: &[[f32; 3]; 3], gr: &NodeGrid) -> [[f32; 3]; 3] {
    std::array::from_fn(|vi| {
        std::array::from_fn(|i| rows[i][1].mul_add(gr.sin[vi], rows[i][0] * gr.cos[vi]))
    })
}

/// The corner P + cot θ·A·ẑ (see [`NodeGrid`]), normalised; the floor of
/// |t|² rides in the first product. `rows` are [`GlossyLtc::quad_rows`],
/// whose first row has no z entry.
#[inline(always)]
pub fn unit_grid_vertex(rows: &[[f32; 3]; 3], cot: f32, p: &[f32; 3]) -> Vec3 {
    debug_assert_eq!(rows[0][2], 0.0);
    let t = Vec3::new(
        p[0],
        cot.mul_add(rows[1][2], p[1]),
        cot.mul_add(rows[2][2], p[2]),
    );
    let n2 =
        t.z.mul_add(t.z, t.y.mul_add(t.y, t.x.mul_add(t.x, RSQRT_FLOOR)));
    t * rsqrt(n2)
}

/// A world direction mapped by `rows` and normalised.
#[inline(always)]
pub fn unit_cosine_vertex(rows: &[[f32; 3]; 3], w: Vec3) -> Vec3 {
    let t = transform_rows(rows, w);
    let n2 = t.z.mul_add(t.z, t.y.mul_add(t.y, t.x * t.x));
    t * rsqrt(n2.max(RSQRT_FLOOR))
}

/// a×b (no fused products, so exactly antisymmetric) and a·b of unit
/// vectors a and b.
#[inline(always)]
pub fn cross_dot(a: Vec3, b: Vec3) -> (Vec3, f32) {
    let c = Vec3::new(
        a.y * b.z - a.z * b.y,
        a.z * b.x - a.x * b.z,
        a.x * b.y - a.y * b.x,
    );
    (c, a.z.mul_add(b.z, a.y.mul_add(b.y, a.x * b.x)))
}

/// a×b and θ/sin θ of the edge between unit vectors a and b; the edge's
/// term is (a×b)·k.
#[inline(always)]
pub fn unit_edge(a: Vec3, b: Vec3) -> (Vec3, f32) {
    let (c, d) = cross_dot(a, b);
    let k = theta_over_sin(d, || c.z.mul_add(c.z, c.y.mul_add(c.y, c.x * c.x)));
    (c, k)
}

/// The 4 plain-quad children's integrals, from their edge sums (2π·F,
/// winding as built) and horizon sides. Only F_z is formed unless a child
/// straddles the horizon (the sphere approximation then needs all of F).
/// When every child is above the horizon and every edge is short
/// (cos θ ≥ [`SHORT_EDGE_MIN_COS`]), θ/sin θ is the short polynomial with
/// the scale folded in; the wide kernel decides alike (its 16 lanes hold
/// the same 12 edges and 9 corners), so both stay bit for bit.
pub fn quad_children_scalar(g: &GlossyLtc, cell: Cell) -> [f32; 4] {
    let gr = node_grid(cell);
    let pc = grid_columns(&g.quad_rows, &gr);
    let p: [[Vec3; 3]; 3] = std::array::from_fn(|zi| {
        std::array::from_fn(|vi| unit_grid_vertex(&g.quad_rows, gr.cot[zi], &pc[vi]))
    });
    // Parallel (zi, vi→vi+1) and meridian (vi, zi→zi+1) edges.
    let par = |zi: usize, vi: usize| cross_dot(p[zi][vi], p[zi][vi + 1]);
    let mer = |vi: usize, zi: usize| cross_dot(p[zi][vi], p[zi + 1][vi]);
    let pe = [
        [par(0, 0), par(0, 1)],
        [par(1, 0), par(1, 1)],
        [par(2, 0), par(2, 1)],
    ];
    let me = [
        [mer(0, 0), mer(0, 1)],
        [mer(1, 0), mer(1, 1)],
        [mer(2, 0), mer(2, 1)],
    ];
    let sides: [HorizonSide; 4] = std::array::from_fn(|k| {
        let (iu, iv) = (k & 1, k >> 1);
        HorizonSide::of_vertices(&[p[iu][iv], p[iu][iv + 1], p[iu + 1][iv + 1], p[iu + 1][iv]])
    });
    let short_node = sides.iter().all(|&s| s == HorizonSide::Above)
        && pe
            .iter()
            .chain(&me)
            .flatten()
            .all(|&(_, d)| d >= SHORT_EDGE_MIN_COS);
    if short_node {
        // F_z only, each child's 4 edges in its own direction with a fused
        // (a×b)_z (the wide kernel's lanes): an interior edge's two terms
        // then differ by a rounding, which the children's sum does not see
        // at f32 precision.
        let cz = |a: Vec3, b: Vec3| a.x.mul_add(b.y, -(a.y * b.x));
        return std::array::from_fn(|k| {
            let (iu, iv) = (k & 1, k >> 1);
            let c = [p[iu][iv], p[iu][iv + 1], p[iu + 1][iv + 1], p[iu + 1][iv]];
            let d = [
                pe[iu][iv].1,
                me[iv + 1][iu].1,
                pe[iu + 1][iv].1,
                me[iv][iu].1,
            ];
            let e: [f32; 4] = std::array::from_fn(|e| {
                cz(c[e], c[(e + 1) % 4]) * short_polynomial(&g.short_poly, d[e])
            });
            ((e[0] + e[1]) + (e[2] + e[3])).max(0.0)
        });
    }
    let full = sides.contains(&HorizonSide::Crossing);
    let term = |(c, d): (Vec3, f32)| {
        let k = theta_over_sin(d, || c.z.mul_add(c.z, c.y.mul_add(c.y, c.x * c.x)));
        if full {
            c * k
        } else {
            Vec3::new(0.0, 0.0, c.z * k)
        }
    };
    let sums = std::array::from_fn(|k| {
        let (iu, iv) = (k & 1, k >> 1);
        let e0 = term(pe[iu][iv]);
        let e1 = term(me[iv + 1][iu]);
        let e2 = -term(pe[iu + 1][iv]);
        let e3 = -term(me[iv][iu]);
        (e0 + e1) + (e2 + e3)
    });
    g.finish_children(cell, sums, sides, None)
}
