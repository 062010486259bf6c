//! The 4 children of the root, exactly clipped, as spherical triangles.
//!
//! A level-1 cell is a quarter sphere {s_z·z ≥ 0} ∩ {s_y·y ≥ 0}, and the
//! lobe vanishes outside the hemisphere {h·ω ≥ 0}, h the third row of the
//! world → cosine map A. The clipped cell is therefore the intersection of
//! three hemispheres: a spherical triangle whose vertices are the pairwise
//! intersections of the great circles, (n₂×n₃, n₃×n₁, n₁×n₂)/D with
//! D = n₁·(n₂×n₃) (the dual basis). With n₁ = s_z·ẑ, n₂ = s_y·ŷ, n₃ = h:
//! - u₁ = s_y·(h_z, 0, −h_x), u₂ = s_z·(h_y, −h_x, 0), u₃ = −s_z·s_y·x̂,
//! - D = −s_z·s_y·h_x.
//!
//! The edge integrand is unchanged when all vertices are negated, so the
//! triangle (u₁, u₂, u₃) mapped by A gives the integral up to the sign of D
//! (its winding). Its image lies above the horizon (two vertices on it), so
//! no clipping remains: 3 edges per child, 12 in all, one f32x16 instead of
//! four 5-vertex polygons clipped vertex by vertex. When h_x is small the
//! three great circles nearly meet at ±x̂ (the clipped cell tends to a lune)
//! and the triangle degenerates; those lobes return `None` and the caller
//! clips the polygons.
//!
//! The triangles are large (edges up to nearly π), and this kernel runs
//! once per descent with nothing to overlap it, so its cost is the latency
//! of one edge term. Each term is therefore taken from the unit vertices,
//! as in the quad kernels: with w = 1/(|a||b|) (two `rsqrt`s, no √ and no
//! division), θ·(a×b)/|a×b| = (θ/sin θ)(w·a·b)·w·(a×b), θ/sin θ being the
//! polynomial of [`super::fast_math::theta_over_sin`].

use super::fast_math::{
    RSQRT_FLOOR, rsqrt, rsqrt_x16, theta_over_sin_obtuse, theta_over_sin_poly, theta_over_sin_x16,
};
use super::polygon::transform_rows;
use super::simd::{BLOCK_OF_EDGE, block_sums, edge_end_blocks, shuffle_blocks, splat, transform};
use crate::directional::Cell;
use glam::Vec3;
use wide::{f32x4, f32x16};

/// Below this |n_x| the cosine lobe's root children take the lune form,
/// whose error is ≈ 0.35·n_x² (5.7e-6 at 4e-3, tests/ltc_form_factor.rs),
/// where the triangle form's is ~1e-7/|n_x|.
pub const LUNE_MAX_NORMAL_X: f32 = 4e-3;

/// Smallest |h_x|/|h| handled as triangles: below it the nearly antipodal
/// vertices cost up to ~1e-7/(|h_x|/|h|) of relative accuracy.
const MIN_HX: f32 = 0.05;

/// Signs (s_z, s_y) of child k (bit 0: upper half in z; bit 1: φ ∈ [π, 2π]).
#[inline(always)]
fn child_signs(k: usize) -> (f32, f32) {
    (
        if k & 1 == 1 { 1.0 } else { -1.0 },
        if k & 2 == 0 { 1.0 } else { -1.0 },
    )
}

/// World-space triangle (unnormalised) of child k for the horizon normal h.
#[inline(always)]
fn triangle(k: usize, h: Vec3) -> [Vec3; 3] {
    let (sz, sy) = child_signs(k);
    [
        Vec3::new(sy * h.z, 0.0, -sy * h.x),
        Vec3::new(sz * h.y, -sz * h.x, 0.0),
        Vec3::new(-sz * sy, 0.0, 0.0),
    ]
}

/// Per-child factor sign(D)·orientation/2π, or `None` when degenerate.
#[inline(always)]
fn scales(rows: &[[f32; 3]; 3], orientation: f32) -> Option<[f32; 4]> {
    let h = Vec3::from(rows[2]);
    if !(h.x * h.x >= (MIN_HX * MIN_HX) * h.length_squared()) {
        return None;
    }
    Some(std::array::from_fn(|k| {
        let (sz, sy) = child_signs(k);
        let sign_d = if -sz * sy * h.x > 0.0 { 1.0 } else { -1.0 };
        sign_d * orientation * (0.5 / std::f32::consts::PI)
    }))
}

/// 1/|v| of a mapped vertex (finite for v = 0).
#[inline(always)]
fn inv_length(v: Vec3) -> f32 {
    rsqrt(
        v.z.mul_add(v.z, v.y.mul_add(v.y, v.x * v.x))
            .max(RSQRT_FLOOR),
    )
}

/// An edge between mapped vertices a and b, given 1/|a| and 1/|b|, as
/// [`super::quad::unit_edge`] takes it: w·(a×b)_z (no fused products, so
/// exactly antisymmetric), the cosine w·(a·b) and both values of
/// [`super::fast_math::theta_over_sin`] at it, for the edge and for the
/// edge to −b.
#[inline(always)]
fn base_edge(a: Vec3, b: Vec3, ia: f32, ib: f32) -> [f32; 4] {
    let w = ia * ib;
    let cz = a.x * b.y - a.y * b.x;
    let d = a.z.mul_add(b.z, a.y.mul_add(b.y, a.x * b.x)) * w;
    let (cx, cy) = (a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z);
    let q = cz.mul_add(cz, cy.mul_add(cy, cx * cx)) * (w * w);
    let p = theta_over_sin_poly(d.abs());
    let far = theta_over_sin_obtuse(p, q);
    [cz * w, d, p, far]
}

/// (θ·(a×b)/|a×b|)_z of the edge (s·a, ±b) from its [`base_edge`] (a, b),
/// s = ±1 the product of the endpoints' signs: a sign flips the cross
/// product and the cosine exactly, so this is the term the lanes of
/// [`level1_children_x16`] compute from the signed vertices.
#[inline(always)]
fn signed_term([czw, d, p, far]: [f32; 4], s: f32) -> f32 {
    (czw * s) * if d * s < 0.0 { far } else { p }
}

/// The clamped cosine about a unit normal `n`, integrated over the 4 root
/// cells (quarter spheres) and divided by π: each cell's share of the
/// irradiance under uniform light, summing to 1. Exact clipping, as for
/// the product's diffuse lobe at level 1.
pub fn cosine_root_children(n: Vec3) -> [f32; 4] {
    if n.x.abs() < LUNE_MAX_NORMAL_X {
        return super::form_factor::cosine_quarter_spheres_near_lune(n);
    }
    let f = crate::math::Frame::from_normal(n);
    let rows = [f.s.to_array(), f.t.to_array(), n.to_array()];
    let orientation = f.s.dot(f.t.cross(n)).signum();
    level1_children(&rows, orientation)
        .unwrap_or_else(|| super::children::exact_children_f32(&rows, orientation, Cell::ROOT))
}

/// Exactly clipped integrals of the root's children, scalar.
pub fn level1_children(rows: &[[f32; 3]; 3], orientation: f32) -> Option<[f32; 4]> {
    let scale = scales(rows, orientation)?;
    let h = Vec3::from(rows[2]);
    // Child k's vertices are those of child 1 (s_z = s_y = 1) times s_y,
    // s_z and s_z·s_y, and signs pass exactly through the map, the lengths
    // and the edge terms: 3 vertices and 3 edges serve the 4 children.
    let t = triangle(1, h).map(|u| transform_rows(rows, u));
    let i = t.map(inv_length);
    let e = [
        base_edge(t[0], t[1], i[0], i[1]),
        base_edge(t[1], t[2], i[1], i[2]),
        base_edge(t[2], t[0], i[2], i[0]),
    ];
    Some(
        std::array::from_fn(|k| {
            let (sz, sy) = child_signs(k);
            let e0 = signed_term(e[0], sy * sz);
            let e1 = signed_term(e[1], sz * (sz * sy));
            let e2 = signed_term(e[2], (sz * sy) * sy);
            ((e0 + e1) + e2) * scale[k]
        })
        .map(|f: f32| f.max(0.0)),
    )
}

/// Block order taking each edge's start (vertex e) to its end (vertex
/// e + 1 mod 3); edge 3 is empty (from 0 to 0, a term of exactly 0), so the
/// two block additions give the scalar (e0 + e1) + e2.
const NEXT: i32 = edge_end_blocks(3);

/// Coefficients of the start of edge e of child k's triangle, vertex e, in
/// lane k of block `BLOCK_OF_EDGE[e]`.
const fn lane_coefficients() -> [[f32; 16]; 5] {
    // Rows: x = C0·h_z + C1·h_y + C2, y = C3·h_x, z = C4·h_x.
    let mut c = [[0.0f32; 16]; 5];
    let mut k = 0;
    while k < 4 {
        let sz = if k & 1 == 1 { 1.0 } else { -1.0 };
        let sy = if k & 2 == 0 { 1.0 } else { -1.0 };
        let mut e = 0;
        while e < 3 {
            let l = 4 * BLOCK_OF_EDGE[e] + k;
            match e {
                0 => {
                    c[0][l] = sy;
                    c[4][l] = -sy;
                }
                1 => {
                    c[1][l] = sz;
                    c[3][l] = -sz;
                }
                _ => c[2][l] = -sz * sy,
            }
            e += 1;
        }
        k += 1;
    }
    c
}
const START: [[f32; 16]; 5] = lane_coefficients();

/// The triangle vertices of every lane, mapped by `rows`. Each coordinate
/// has one non-zero term, ±h_i or ±1, so it is exact, as in [`triangle`].
#[inline(always)]
fn lane_vertices(rows: &[[f32; 3]; 3], c: &[[f32; 16]; 5], h: Vec3) -> [f32x16; 3] {
    let f = |i: usize| f32x16::from(c[i]);
    let x = f(0).mul_add(splat(h.z), f(1).mul_add(splat(h.y), f(2)));
    transform(rows, x, f(3) * splat(h.x), f(4) * splat(h.x))
}

/// [`level1_children`] with the 12 edges in one f32x16.
pub fn level1_children_x16(rows: &[[f32; 3]; 3], orientation: f32) -> Option<[f32; 4]> {
    let scale = scales(rows, orientation)?;
    let h = Vec3::from(rows[2]);
    let a = lane_vertices(rows, &START, h);
    let b = a.map(shuffle_blocks::<NEXT>);
    let ia = rsqrt_x16(
        a[2].mul_add(a[2], a[1].mul_add(a[1], a[0] * a[0]))
            .fast_max(splat(RSQRT_FLOOR)),
    );
    // The operations of `base_edge` and `signed_term`, lane by lane.
    let cz = a[0] * b[1] - a[1] * b[0];
    let w = ia * shuffle_blocks::<NEXT>(ia);
    let d = a[2].mul_add(b[2], a[1].mul_add(b[1], a[0] * b[0])) * w;
    let k = theta_over_sin_x16(d, || {
        let cx = a[1] * b[2] - a[2] * b[1];
        let cy = a[2] * b[0] - a[0] * b[2];
        cz.mul_add(cz, cy.mul_add(cy, cx * cx)) * (w * w)
    });
    let ez = (cz * w) * k;
    let f = block_sums(ez) * f32x4::from(scale);
    Some(f.fast_max(f32x4::splat(0.0)).to_array())
}
