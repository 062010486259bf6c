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
//! no clipping remains. Child k's vertices are child 1's times ±1, and a
//! sign passes exactly through the map, the lengths and the edge terms: 3
//! edges serve the 4 children, each child taking each edge's term for one
//! of the two signs of its endpoints. When h_x is small the three great
//! circles nearly meet at ±x̂ (the clipped cell tends to a lune) and the
//! triangle degenerates; those lobes take the closed form of
//! [`super::quarter_sphere`], three arctangents, which is exact to the
//! lune but slower here.
//!
//! The triangles are large (edges up to nearly π), and this kernel runs
//! once per descent with nothing to overlap it, so its cost is the latency
//! of one edge term. Each term is therefore taken from the unit vertices,
//! as in the quad kernels: with w = 1/(|a||b|) (two `rsqrt`s, no √ and no
//! division), θ·(a×b)/|a×b| = (θ/sin θ)(w·a·b)·w·(a×b), θ/sin θ being the
//! polynomial of [`super::fast_math::theta_over_sin`].
//!
//! The wide kernel is four lanes wide, [`level1_children_x4`]: the 3 shared
//! edges side by side, then the 12 signed terms as selections. A 16-lane
//! kernel that computed the 12 (child, edge) terms as 12 full edges, the
//! layout of the quad kernels, took 19.1 ns per call against 15.9 ns for
//! the four lanes and 28.0 ns for the scalar kernel (criterion, one run,
//! session 60).
//!
//! The cosine lobe (M = I) does not come here: its four shares depend on
//! the normal alone, and the closed form is cheaper for it,
//! [`super::form_factor::cosine_root_children`].

use super::fast_math::{RSQRT_FLOOR, rsqrt, rsqrt_x4, theta_over_sin_obtuse, theta_over_sin_poly};
use super::polygon::transform_rows;
use super::quarter_sphere::{quarter_sphere_children, quarter_sphere_children_x4};
use glam::Vec3;
use wide::f32x4;

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

/// Per-child factor sign(D)·orientation/2π, or `None` when degenerate
/// (or not finite).
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
/// product and the cosine exactly, so this is the term of the signed
/// vertices' own edge.
#[inline(always)]
fn signed_term([czw, d, p, far]: [f32; 4], s: f32) -> f32 {
    (czw * s) * if d * s < 0.0 { far } else { p }
}

/// Exactly clipped integrals of the root's children, scalar; `None` only
/// for a singular or non-finite map.
pub fn level1_children(rows: &[[f32; 3]; 3], orientation: f32) -> Option<[f32; 4]> {
    let Some(scale) = scales(rows, orientation) else {
        return quarter_sphere_children(rows, orientation);
    };
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

/// Whether edge e enters child k's sum with the sign s_k,e = +1 (else −1):
/// s_y·s_z, s_y and s_z for e = 0, 1, 2, the products [`level1_children`]
/// forms (exact).
const EDGE_SIGNS: [[bool; 3]; 4] = {
    let mut t = [[false; 3]; 4];
    let mut k = 0;
    while k < 4 {
        let (z_up, y_up) = (k & 1 == 1, k & 2 == 0);
        t[k] = [z_up == y_up, y_up, z_up];
        k += 1;
    }
    t
};

/// [`level1_children`] four lanes wide, bit for bit: its 3 shared edges in
/// lanes 0–2 (lane 3 repeats edge 0), then each edge's term for both signs
/// of its endpoints, (a·b < 0 ? far : p)·(a×b)_z·w and its mirror
/// (a·b > 0 ? far : p)·(−(a×b)_z·w) — the scalar's (s·cz·w)·(s·d < 0 ?
/// far : p) for s = ±1, since a sign flips those exactly — and each
/// child's sum of its edges' terms in the scalar's order. The scalar
/// kernel spends most of its operations on those 12 signed terms.
pub fn level1_children_x4(rows: &[[f32; 3]; 3], orientation: f32) -> Option<[f32; 4]> {
    let Some(scale) = scales(rows, orientation) else {
        return quarter_sphere_children_x4(rows, orientation);
    };
    let h = Vec3::from(rows[2]);
    let s4 = f32x4::splat;
    // `triangle(1, h)`, vertex e in lane e, mapped as `transform_rows` maps it.
    let (vx, vy, vz) = (
        f32x4::from([h.z, h.y, -1.0, h.z]),
        f32x4::from([0.0, -h.x, 0.0, 0.0]),
        f32x4::from([-h.x, 0.0, 0.0, -h.x]),
    );
    let a = rows.map(|r| s4(r[2]).mul_add(vz, s4(r[1]).mul_add(vy, s4(r[0]) * vx)));
    let ia = rsqrt_x4(
        a[2].mul_add(a[2], a[1].mul_add(a[1], a[0] * a[0]))
            .fast_max(s4(RSQRT_FLOOR)),
    );
    // Edge e runs from vertex e to vertex e + 1 (mod 3).
    let next = |v: f32x4| -> f32x4 {
        let v = v.to_array();
        f32x4::from([v[1], v[2], v[0], v[1]])
    };
    let (b, ib) = (a.map(next), next(ia));
    // `base_edge`, lane by lane.
    let w = ia * ib;
    let cz = a[0] * b[1] - a[1] * b[0];
    let d = a[2].mul_add(b[2], a[1].mul_add(b[1], a[0] * b[0])) * w;
    let (cx, cy) = (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2]);
    let q = cz.mul_add(cz, cy.mul_add(cy, cx * cx)) * (w * w);
    let p = theta_over_sin_poly(d.abs());
    let far = s4(std::f32::consts::PI).mul_add(rsqrt_x4(q.fast_max(s4(RSQRT_FLOOR))), -p);
    let czw = cz * w;
    let zero = s4(0.0);
    let plus = (czw * d.simd_lt(zero).bitselect(far, p)).to_array();
    let minus = (-czw * d.simd_gt(zero).bitselect(far, p)).to_array();
    let term = |e: usize| {
        f32x4::from(std::array::from_fn::<f32, 4, _>(|k| {
            if EDGE_SIGNS[k][e] { plus[e] } else { minus[e] }
        }))
    };
    let f = ((term(0) + term(1)) + term(2)) * f32x4::from(scale);
    Some(f.fast_max(zero).to_array())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    /// The four-lane kernel against the scalar one, bit for bit, under
    /// random maps: orthonormal frames (the cosine lobe's) and general ones
    /// (glossy LTCs), including maps whose triangles degenerate (the closed
    /// form for both). Mutation check: taking the mirror term with d < 0 instead of
    /// d > 0 fails it.
    #[test]
    fn four_lanes_equal_the_scalar_kernel_bit_for_bit() {
        let mut rng = Rng::new(21, 5);
        let mut triangles = 0;
        for trial in 0..20_000 {
            let rows: [[f32; 3]; 3] = if trial % 2 == 0 {
                let n = crate::sampling::square_to_uniform_sphere(rng.next_2d());
                let f = crate::math::Frame::from_normal(n);
                [f.s.to_array(), f.t.to_array(), n.to_array()]
            } else {
                std::array::from_fn(|_| std::array::from_fn(|_| 8.0 * rng.next_f32() - 4.0))
            };
            let orientation = if rng.next_f32() < 0.5 { -1.0 } else { 1.0 };
            let a = level1_children(&rows, orientation);
            let b = level1_children_x4(&rows, orientation);
            assert_eq!(
                a.map(|v| v.map(f32::to_bits)),
                b.map(|v| v.map(f32::to_bits)),
                "rows {rows:?}"
            );
            triangles += scales(&rows, orientation).is_some() as usize;
            assert!(a.is_some());
        }
        assert!(triangles > 15_000, "{triangles}");
    }
}
