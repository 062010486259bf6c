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

use super::polygon::{edge_vector, transform_rows};
use super::simd::{edge_vectors, permute, splat, transform};
use glam::Vec3;
use wide::f32x16;

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
    if !(h.x.abs() >= MIN_HX * h.length()) {
        return None;
    }
    Some(std::array::from_fn(|k| {
        let (sz, sy) = child_signs(k);
        let sign_d = if -sz * sy * h.x > 0.0 { 1.0 } else { -1.0 };
        sign_d * orientation * (0.5 / std::f32::consts::PI)
    }))
}

/// Exactly clipped integrals of the root's children, scalar.
pub fn level1_children(rows: &[[f32; 3]; 3], orientation: f32) -> Option<[f32; 4]> {
    let scale = scales(rows, orientation)?;
    let h = Vec3::from(rows[2]);
    Some(
        std::array::from_fn(|k| {
            let t = triangle(k, h).map(|u| transform_rows(rows, u));
            let e0 = edge_vector(t[0], t[1]).z;
            let e1 = edge_vector(t[1], t[2]).z;
            let e2 = edge_vector(t[2], t[0]).z;
            ((e0 + e1) + e2) * scale[k]
        })
        .map(|f: f32| f.max(0.0)),
    )
}

/// Lane 4k + e holds edge e of child k's triangle (e = 3 is an empty edge
/// from 0 to 0, whose term is exactly 0). `END` picks the edge end.
const fn lane_coefficients(end: bool) -> [[f32; 16]; 5] {
    // Rows: x = C0·h_z + C1·h_y + C2, y = C3·h_x, z = C4·h_x.
    let mut c = [[0.0f32; 16]; 5];
    let mut k = 0;
    while k < 4 {
        let sz = if k & 1 == 1 { 1.0 } else { -1.0 };
        let sy = if k & 2 == 0 { 1.0 } else { -1.0 };
        let mut e = 0;
        while e < 3 {
            let v = if end { (e + 1) % 3 } else { e };
            let l = 4 * k + e;
            match v {
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
const START: [[f32; 16]; 5] = lane_coefficients(false);
const END: [[f32; 16]; 5] = lane_coefficients(true);

/// The triangle vertices of every lane, mapped by `rows`. Each coordinate
/// has one non-zero term, ±h_i or ±1, so it is exact, as in [`triangle`].
#[inline(always)]
fn lane_vertices(rows: &[[f32; 3]; 3], c: &[[f32; 16]; 5], h: Vec3) -> [f32x16; 3] {
    let f = |i: usize| f32x16::from(c[i]);
    let x = f(0).mul_add(splat(h.z), f(1).mul_add(splat(h.y), f(2)));
    transform(rows, x, f(3) * splat(h.x), f(4) * splat(h.x))
}

const SWAP1: [i32; 16] = [1, 0, 3, 2, 5, 4, 7, 6, 9, 8, 11, 10, 13, 12, 15, 14];
const SWAP2: [i32; 16] = [2, 3, 0, 1, 6, 7, 4, 5, 10, 11, 8, 9, 14, 15, 12, 13];

/// [`level1_children`] with the 12 edges in one f32x16.
pub fn level1_children_x16(rows: &[[f32; 3]; 3], orientation: f32) -> Option<[f32; 4]> {
    let scale = scales(rows, orientation)?;
    let h = Vec3::from(rows[2]);
    let a = lane_vertices(rows, &START, h);
    let b = lane_vertices(rows, &END, h);
    let ez = edge_vectors(a, b)[2];
    let y = ez + permute(ez, &SWAP1);
    let s = (y + permute(y, &SWAP2)).to_array();
    Some(std::array::from_fn(|k| (s[4 * k] * scale[k]).max(0.0)))
}
