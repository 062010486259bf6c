//! The clamped cosine over the root's quarter spheres after a linear map,
//! in closed form: three arctangents.
//!
//! A level-1 cell is a quarter sphere {s_z·z ≥ 0} ∩ {s_y·y ≥ 0}. The map A
//! (world → cosine) takes a half-space {m·ω ≥ 0} to {(A⁻ᵀm)·ω' ≥ 0}, so in
//! the cosine space the child is bounded by the planes of unit normals
//! â ∝ o·A⁻ᵀẑ and b̂ ∝ o·A⁻ᵀŷ (o = sign det A, so that the inward sides
//! stay inward), and the clamped cosine clips it at ẑ·ω' ≥ 0. The clipped
//! child is the intersection of three hemispheres with inward normals
//! n₁ = s_z·â, n₂ = s_y·b̂, n₃ = ẑ: a spherical triangle T, never empty
//! while the normals are independent. Lambert's ∫_T ω dω = ½·Σ θ_i·n_i (θ_i
//! the arc of T on the great circle ⊥ n_i) gives the child's share
//!
//! (θ₃ + s_z·â_z·θ₁ + s_y·b̂_z·θ₂)/2π.
//!
//! T's vertices are (n₂×n₃, n₃×n₁, n₁×n₂)/D, D = n₁·(n₂×n₃), and since
//! (n₂×n₃)×(n₃×n₁) = D·n₃ the arc between the first two needs no vertex:
//! θ₃ = atan2(|D|, (n₂·n₃)(n₃·n₁) − (n₁·n₂)), and likewise θ₁ and θ₂. With
//! D = s_z·s_y·d, d = (â×b̂)_z, and c = â·b̂:
//! - θ₃ = atan2(|d|, s_z·s_y·y₃), y₃ = −â_xy·b̂_xy (the x-y parts);
//! - θ₁ = atan2(|d|, −s_y·y₁), y₁ = b̂_z − c·â_z = b̂_z·|â_xy|² + â_z·y₃;
//! - θ₂ = atan2(|d|, −s_z·y₂), y₂ = â_z − c·b̂_z = â_z·|b̂_xy|² + b̂_z·y₃.
//!
//! A sign flip is atan2(|d|, −x) = π − atan2(|d|, x), so three arctangents
//! serve the four children ([`root_shares_x4`]). The cosine lobe is the case
//! A = the shading frame (rows s, t, n), where â and b̂ are world ẑ and ŷ in
//! the frame's coordinates, (s_z, t_z, n_z) and (s_y, t_y, n_y):
//! d = −n_x, y₃ = n_y·n_z, y₁ = n_y, y₂ = n_z
//! ([`super::form_factor::cosine_root_children`]).
//!
//! d → 0 is the world x axis's image reaching the horizon: the three great
//! circles then meet at one pair of points and T tends to a lune, each arc
//! 0 or π by the sign of its y. The arctangents stay well conditioned as
//! long as d and the y are accurate to their own size, which the sharpest
//! lobes make hard: there â and b̂ both lie near ±ẑ, and the information is
//! in their x-y parts, ~1e-6 of them. So the cofactors and the small
//! quantities are differences of products taken to an ulp, and the y come
//! from the x-y parts, never from â·b̂. At d = 0 with a y = 0 a cell's plane
//! is the horizon itself, and the shares are lunes of that hemisphere
//! (`plane_on_horizon`). The tests measure ≤ 1e-6 against the f64
//! reference down to d = 0; only singular or non-finite maps are left to the
//! caller.
//!
//! [`super::level1`] takes this form where its mapped triangles lose
//! accuracy, |h_x| < 0.05·|h| (h = A's third row, so h_x ∝ d), in place of
//! the four clipped polygons it took there before session 61. Those fail as
//! |h_x| → 0: the corners ±x̂ map to nearly antipodal points on the horizon,
//! and rounding decides which half of the horizon joins them, errors of
//! 0.5–1 of the lobe below |h_x| = 1e-5·|h| (the tests print them). It does
//! not replace the triangles everywhere: its arctangents' division and the
//! exact products cost 19.8 ns a call four lanes wide against the
//! triangles' 13.6 ns (`ltc/children_x16/1`, session 61).

use super::fast_math::{atan2_upper_x4, rsqrt};
use crate::directional::fast_atan2;
use glam::Vec3;
use std::f32::consts::PI;
use wide::f32x4;

/// What the shares of the root's children depend on: |d| and the second
/// arguments (y₃, y₁, y₂) of the three arctangents, and the weights â_z,
/// b̂_z (module notes).
#[derive(Clone, Copy, Debug)]
pub struct RootPlanes {
    pub d_abs: f32,
    pub y: [f32; 3],
    pub a_z: f32,
    pub b_z: f32,
}

/// The root's children under a map: triangles in closed form, or the
/// degenerate case of a cell's plane on the horizon.
#[derive(Clone, Copy, Debug)]
pub enum RootCase {
    Triangles(RootPlanes),
    PlaneOnHorizon([f32; 4]),
}

impl RootCase {
    /// The planes z = 0 and y = 0 under the world → cosine map `rows`,
    /// `orientation` its determinant's sign. `None` when the map is
    /// singular or not finite.
    #[inline(always)]
    pub fn of_map(rows: &[[f32; 3]; 3], orientation: f32) -> Option<Self> {
        let [r0, r1, r2] = rows.map(Vec3::from);
        // Columns z and y of the cofactor matrix (det·A⁻ᵀ), times sign det.
        // Sharp lobes' rows reach 1e4 while these entries can be 1e-6 of
        // their products: each is a difference of products taken exactly.
        let a = Vec3::new(
            products_minus(r1.x, r2.y, r1.y, r2.x),
            products_minus(r2.x, r0.y, r2.y, r0.x),
            products_minus(r0.x, r1.y, r0.y, r1.x),
        ) * orientation;
        let b = Vec3::new(
            products_minus(r1.z, r2.x, r1.x, r2.z),
            products_minus(r2.z, r0.x, r2.x, r0.z),
            products_minus(r0.z, r1.x, r0.x, r1.z),
        ) * orientation;
        let a = a * rsqrt(a.length_squared());
        let b = b * rsqrt(b.length_squared());
        let d_abs = products_minus(a.x, b.y, a.y, b.x).abs();
        // From the x-y parts, not from â·b̂: for sharp lobes â and b̂ both
        // lie near ±ẑ, and b̂_z − (â·b̂)·â_z would cancel to its rounding.
        let p = products_minus(a.x, b.x, -a.y, b.y);
        let (a_xy, b_xy) = (a.x.mul_add(a.x, a.y * a.y), b.x.mul_add(b.x, b.y * b.y));
        let y = [
            -p,
            products_minus(b.z, a_xy, a.z, p),
            products_minus(a.z, b_xy, b.z, p),
        ];
        // NaN or Inf anywhere makes d so (and a singular map, through 1/0).
        if !(d_abs <= f32::MAX) {
            return None;
        }
        // d = 0 is the lune, where each arc is 0 or π by the sign of its
        // y, unless a y vanishes too: then (for an invertible map) â or b̂
        // is ±ẑ, a cell's plane mapped onto the horizon.
        if d_abs == 0.0 && y.contains(&0.0) {
            return Some(RootCase::PlaneOnHorizon(plane_on_horizon(
                a,
                b,
                a_xy <= b_xy,
            )));
        }
        Some(RootCase::Triangles(RootPlanes {
            d_abs,
            y,
            a_z: a.z,
            b_z: b.z,
        }))
    }
}

/// The shares when the plane of â (`a_on_horizon`) or of b̂ is the horizon:
/// the children on its upper side split the hemisphere along the other
/// plane, a lune whose arcs are both π, (π + π·s·m_z)/2π; the others are
/// empty.
fn plane_on_horizon(a: Vec3, b: Vec3, a_on_horizon: bool) -> [f32; 4] {
    std::array::from_fn(|k| {
        let (upper, other) = if a_on_horizon {
            (S_Z[k] * a.z > 0.0, S_Y[k] * b.z)
        } else {
            (S_Y[k] * b.z > 0.0, S_Z[k] * a.z)
        };
        if upper { 0.5 * (1.0 + other) } else { 0.0 }
    })
}

/// a·b − c·d to about an ulp of the result, cancellation or not (Kahan:
/// the rounding error of c·d, recovered by a fused product, added back).
#[inline(always)]
fn products_minus(a: f32, b: f32, c: f32, d: f32) -> f32 {
    let cd = c * d;
    let error = (-c).mul_add(d, cd);
    a.mul_add(b, -cd) + error
}

/// Child k's signs (s_z, s_y) in lane k ([`crate::directional::Cell::child`]
/// order: bit 0 the upper half in z, bit 1 φ ∈ [π, 2π]).
const S_Z: [f32; 4] = [-1.0, 1.0, -1.0, 1.0];
const S_Y: [f32; 4] = [1.0, 1.0, -1.0, -1.0];

/// The 4 shares, four lanes wide: one division for the three arctangents
/// (lane 3 repeats lane 0). A NaN and rounding below 0 both give 0.
#[inline(always)]
pub fn root_shares_x4(p: RootPlanes) -> [f32; 4] {
    let s4 = f32x4::splat;
    let c4 = f32x4::from;
    let [horizon, a_edge, b_edge, _] =
        atan2_upper_x4(s4(p.d_abs), c4([p.y[0], p.y[1], p.y[2], p.y[0]])).to_array();
    // base·flip + (1 − flip)·π/2: base for flip = 1, π − base for −1.
    let arc = |base: f32, flip: f32x4| s4(base).mul_add(flip, (s4(1.0) - flip) * s4(0.5 * PI));
    let theta_3 = arc(horizon, c4(S_Z) * c4(S_Y));
    let theta_1 = arc(a_edge, -c4(S_Y));
    let theta_2 = arc(b_edge, -c4(S_Z));
    let share = (s4(p.b_z) * c4(S_Y))
        .mul_add(theta_2, (s4(p.a_z) * c4(S_Z)).mul_add(theta_1, theta_3))
        * s4(0.5 / PI);
    share.fast_max(s4(0.0)).to_array()
}

/// [`root_shares_x4`], one child at a time, with the same operations.
#[inline(always)]
pub fn root_shares(p: RootPlanes) -> [f32; 4] {
    let horizon = fast_atan2(p.d_abs, p.y[0]);
    let a_edge = fast_atan2(p.d_abs, p.y[1]);
    let b_edge = fast_atan2(p.d_abs, p.y[2]);
    let arc = |base: f32, flip: f32| base.mul_add(flip, (1.0 - flip) * (0.5 * PI));
    std::array::from_fn(|k| {
        let theta_3 = arc(horizon, S_Z[k] * S_Y[k]);
        let theta_1 = arc(a_edge, -S_Y[k]);
        let theta_2 = arc(b_edge, -S_Z[k]);
        let share = (p.b_z * S_Y[k]).mul_add(theta_2, (p.a_z * S_Z[k]).mul_add(theta_1, theta_3))
            * (0.5 / PI);
        share.max(0.0)
    })
}

/// Integrals of an LTC over the root's children, scalar; `None` for a
/// singular or non-finite map ([`RootCase::of_map`]).
pub fn quarter_sphere_children(rows: &[[f32; 3]; 3], orientation: f32) -> Option<[f32; 4]> {
    Some(match RootCase::of_map(rows, orientation)? {
        RootCase::Triangles(p) => root_shares(p),
        RootCase::PlaneOnHorizon(shares) => shares,
    })
}

/// [`quarter_sphere_children`] four lanes wide, bit for bit.
pub fn quarter_sphere_children_x4(rows: &[[f32; 3]; 3], orientation: f32) -> Option<[f32; 4]> {
    Some(match RootCase::of_map(rows, orientation)? {
        RootCase::Triangles(p) => root_shares_x4(p),
        RootCase::PlaneOnHorizon(shares) => shares,
    })
}

/// Child k's share in f64 with exact arctangents, for the f64 reference
/// near the lune, where its polygons fail ([`super::polygon`]); `a` is the
/// world → cosine map. The same formulas as the f32 kernel (x-y parts, no
/// â·b̂), with â and b̂ from A⁻ᵀ itself; `None` when a cell's plane lies on
/// the horizon or the map is singular.
pub fn quarter_sphere_share_f64(a: &glam::DMat3, k: usize) -> Option<f64> {
    use glam::DVec3;
    let inverse_transpose = a.inverse().transpose();
    let (ca, cb) = (inverse_transpose * DVec3::Z, inverse_transpose * DVec3::Y);
    let (ca, cb) = (ca.try_normalize()?, cb.try_normalize()?);
    let d = (ca.x * cb.y - ca.y * cb.x).abs();
    let p = ca.x * cb.x + ca.y * cb.y;
    let (a_xy, b_xy) = (ca.x * ca.x + ca.y * ca.y, cb.x * cb.x + cb.y * cb.y);
    let y = [-p, cb.z * a_xy - ca.z * p, ca.z * b_xy - cb.z * p];
    if d == 0.0 && y.contains(&0.0) {
        return None;
    }
    let (s_z, s_y) = (S_Z[k] as f64, S_Y[k] as f64);
    let theta_3 = d.atan2(s_z * s_y * y[0]);
    let theta_1 = d.atan2(-s_y * y[1]);
    let theta_2 = d.atan2(-s_z * y[2]);
    let share = (theta_3 + s_z * ca.z * theta_1 + s_y * cb.z * theta_2) / std::f64::consts::TAU;
    Some(share.max(0.0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::directional::Cell;
    use crate::ltc::polygon::cell_integral_reference;
    use crate::sampling::{Rng, square_to_uniform_sphere};
    use glam::{DMat3, DVec3};

    /// The f32 rows and orientation the kernels get, as the lobe builds them.
    fn rows_of(a: &DMat3) -> ([[f32; 3]; 3], f32) {
        let g = crate::ltc::children::GlossyLtc::from_map(*a, 1.0, &Default::default());
        (g.rows, g.orientation)
    }

    /// An LTC-like map: into a random frame turned by a random azimuth, then
    /// the inverse of [[m11, 0, m13], [0, m22, 0], [0, 0, 1]] with m11 and
    /// m22 down to 1e-4 (the sharpest lobes: â and b̂ both near ±ẑ).
    fn ltc_like(rng: &mut Rng) -> DMat3 {
        let n = square_to_uniform_sphere(rng.next_2d()).as_dvec3();
        let f = crate::math::Frame::from_normal(n.as_vec3());
        let (s, t) = (f.s.as_dvec3(), f.t.as_dvec3());
        let phi = std::f64::consts::TAU * rng.next_f64();
        let (x, y) = (s * phi.cos() + t * phi.sin(), t * phi.cos() - s * phi.sin());
        let to_local = DMat3::from_cols(x, y, n).transpose();
        let alpha = 10f64.powf(-4.0 * rng.next_f64());
        let m = DMat3::from_cols(
            DVec3::new(alpha * (0.5 + rng.next_f64()), 0.0, 0.0),
            DVec3::new(0.0, alpha * (0.5 + rng.next_f64()), 0.0),
            DVec3::new(rng.next_f64() - 0.5, 0.0, 1.0),
        );
        m.inverse() * to_local
    }

    /// Random maps, half of them general and half LTC-like, with the x
    /// axis's image (A·x̂)_z = A₂₀ scaled towards the horizon by `eps`
    /// (d ∝ A₂₀), as f32 rows.
    fn maps(seed: u64, eps: f64, count: usize) -> Vec<([[f32; 3]; 3], f32)> {
        let mut rng = Rng::new(seed, 1);
        (0..count)
            .map(|trial| {
                let mut a = if trial % 2 == 0 {
                    ltc_like(&mut rng)
                } else {
                    DMat3::from_cols_array(&std::array::from_fn(|_| 8.0 * rng.next_f64() - 4.0))
                };
                if eps < 1.0 {
                    let sign = if rng.next_f64() < 0.5 { -1.0 } else { 1.0 };
                    a.x_axis.z = sign * eps * a.row(2).length();
                }
                rows_of(&a)
            })
            .collect()
    }

    /// The closed form against the f64 polygon reference of the same (f32)
    /// map, as the x axis's image approaches the horizon, where the polygon
    /// routes fail: the level-1 cells' corners ±x̂ then map to nearly
    /// antipodal points on the horizon, and which half of the horizon joins
    /// them is decided by rounding. At d = 0 exactly the reference's own
    /// polygons fail too, and it takes the closed form in f64 (tested
    /// below against its polygons off the lune). The level-1 kernel
    /// (mapped triangles, this form near the lune) is held to 2e-5 (its
    /// triangles measure up to 8e-6). Also prints the f32 polygon clip's
    /// error, which level 1 fell back to for
    /// |h_x| < 0.05·|h| before session 61. Mutation checks: y₁ and y₂ taken
    /// as b̂_z − (â·b̂)·â_z and â_z − (â·b̂)·b̂_z give errors of 0.2 (sharp
    /// lobes); θ₁'s flip taken from s_z instead of s_y fails everywhere.
    #[test]
    fn closed_form_matches_the_f64_reference_up_to_the_lune() {
        let root = Cell {
            depth: 0,
            ix: 0,
            iy: 0,
        };
        for (i, eps) in [1.0, 1e-1, 1e-3, 1e-5, 1e-6, 1e-7, 1e-8, 0.0]
            .into_iter()
            .enumerate()
        {
            let (mut worst, mut worst_clip, mut worst_level1) = (0.0f64, 0.0f64, 0.0f64);
            for (rows, o) in maps(7 + i as u64, eps, 2000) {
                let a = DMat3::from_cols_array_2d(&rows.map(|r| r.map(f64::from))).transpose();
                let o64 = o as f64;
                let r: [f64; 4] =
                    std::array::from_fn(|k| cell_integral_reference(root.child(k), &a, o64));
                let got = quarter_sphere_children(&rows, o)
                    .unwrap_or_else(|| panic!("no closed form for {rows:?}"));
                let clip = crate::ltc::children::exact_children_f32(&rows, o, root);
                let level1 = crate::ltc::level1::level1_children_x4(&rows, o).unwrap();
                for k in 0..4 {
                    worst = worst.max((got[k] as f64 - r[k]).abs());
                    worst_clip = worst_clip.max((clip[k] as f64 - r[k]).abs());
                    worst_level1 = worst_level1.max((level1[k] as f64 - r[k]).abs());
                }
                let sum: f32 = got.iter().sum();
                assert!((sum - 1.0).abs() < 3e-6, "sum {sum} for {rows:?}");
            }
            println!(
                "|A20|/|A2| = {eps:e}: closed form {worst:.2e}, level 1 (triangles or closed form) \
                 {worst_level1:.2e}, polygon clip {worst_clip:.2e}"
            );
            assert!(worst_level1 < 2e-5, "eps {eps}: level 1 {worst_level1:e}");
            // Measured ≤ 9.5e-7, the arctangent's 4e-7 rad; with plain
            // differences of products for the cofactors, 3.4e-5 (sharp
            // lobes: b̂'s x-y part, 2e-6 of b̂, a few % off).
            assert!(worst < 2e-6, "eps {eps}: {worst:e}");
        }
    }

    /// The f64 closed form (the reference's at the lune) against the f64
    /// polygons away from it, and at (A·x̂)_z = 0 exactly, where the
    /// polygons fail, the reference's four children sum to the lobe.
    /// Mutation check: â from A⁻¹ instead of A⁻ᵀ fails it.
    #[test]
    fn f64_closed_form_is_the_reference_at_the_lune() {
        let root = Cell {
            depth: 0,
            ix: 0,
            iy: 0,
        };
        let mut worst = 0.0f64;
        for (i, eps) in [1.0, 1e-2, 1e-6, 0.0].into_iter().enumerate() {
            for (rows, o) in maps(70 + i as u64, eps, 1000) {
                let a = DMat3::from_cols_array_2d(&rows.map(|r| r.map(f64::from))).transpose();
                let o = o as f64;
                if eps > 0.0 {
                    for k in 0..4 {
                        let polygon =
                            crate::ltc::polygon::cell_integral_chords(root.child(k), &a, o, 1e-3);
                        let closed = quarter_sphere_share_f64(&a, k).unwrap();
                        worst = worst.max((polygon - closed).abs());
                    }
                } else {
                    let sum: f64 = (0..4)
                        .map(|k| cell_integral_reference(root.child(k), &a, o))
                        .sum();
                    assert!((sum - 1.0).abs() < 1e-12, "sum {sum} for {rows:?}");
                }
            }
        }
        println!("f64 closed form vs polygons: {worst:.2e}");
        assert!(worst < 1e-12, "{worst:e}");
    }

    /// The four-lane kernel against the scalar one, bit for bit, including
    /// maps at and near the lune (d = 0).
    #[test]
    fn four_lanes_equal_the_scalar_kernel_bit_for_bit() {
        let mut closed = 0;
        for (i, eps) in [1.0, 1e-4, 1e-8, 0.0].into_iter().enumerate() {
            for (rows, o) in maps(40 + i as u64, eps, 5000) {
                let a = quarter_sphere_children(&rows, o);
                let b = quarter_sphere_children_x4(&rows, o);
                assert_eq!(
                    a.map(|v| v.map(f32::to_bits)),
                    b.map(|v| v.map(f32::to_bits)),
                    "rows {rows:?}"
                );
                closed += a.is_some() as usize;
            }
        }
        assert_eq!(closed, 20_000);
    }

    /// The degenerate maps: a cell's plane mapped onto the horizon (d = 0
    /// and a y = 0; the identity, and a rotation about x̂, whose shares are
    /// lunes of the cosine about n = (0, 0.6, 0.8)), the lune d = 0 with
    /// every y ≠ 0 (a glossy lobe viewed exactly along ±ŷ about a world-z
    /// normal maps x̂ onto the horizon), and singular and non-finite maps,
    /// which are left to the caller.
    #[test]
    fn degenerate_maps() {
        let identity = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        assert_eq!(
            quarter_sphere_children(&identity, 1.0),
            Some([0.0, 0.5, 0.0, 0.5])
        );
        let mirrored = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]];
        assert_eq!(
            quarter_sphere_children(&mirrored, -1.0),
            Some([0.5, 0.0, 0.5, 0.0])
        );
        let on_horizon = [[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]];
        assert_eq!(
            quarter_sphere_children(&on_horizon, 1.0),
            Some([0.5, 0.5, 0.0, 0.0])
        );
        let lune = [[1.0, 0.0, 0.0], [0.0, 0.8, -0.6], [0.0, 0.6, 0.8]];
        let expected = crate::ltc::form_factor::cosine_quarter_spheres_near_lune(glam::Vec3::new(
            0.0, 0.6, 0.8,
        ));
        for rows in [lune, lune.map(|r| r.map(|v| 7.0 * v))] {
            let shares =
                quarter_sphere_children_x4(&rows, 1.0).expect("the lune has a closed form");
            for k in 0..4 {
                assert!(
                    (shares[k] - expected[k]).abs() < 1e-6,
                    "{shares:?} vs {expected:?}"
                );
            }
        }
        let singular = [[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 0.0, 1.0]];
        assert!(quarter_sphere_children(&singular, 1.0).is_none());
        let nan = [[f32::NAN, 0.0, 0.0], [0.0, 1.0, 0.0], [0.3, 0.0, 1.0]];
        assert!(quarter_sphere_children_x4(&nan, 1.0).is_none());
    }
}
