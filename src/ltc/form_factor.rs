//! Exact vector form factors of the cylindrical cells (DESIGN.md §2).
//!
//! F = (1/π)∫_cell ω dω has a closed form for a cell z ∈ [z0, z1],
//! φ ∈ [φ0, φ1]: with S(z) = (z√(1−z²) + asin z)/2 = ∫√(1−z²) dz,
//! - F_x = (sin φ1 − sin φ0)·(S(z1) − S(z0))/π,
//! - F_y = (cos φ0 − cos φ1)·(S(z1) − S(z0))/π,
//! - F_z = (φ1 − φ0)·(z1² − z0²)/(2π).
//!
//! Cells live in world space, so F does not depend on the shading point: the
//! first levels are computed once, and a diffuse lobe with normal n then only
//! needs F·n (exact when the cell is above the horizon) and |F| for the
//! sphere-clipping approximation. Deeper cells use the closed form on the
//! fly in f64 ([`form_factor`]) or, on the hot path, in f32 with the φ part
//! exact and a two-point Gauss rule in z ([`children_form_factors_f32`]).

use crate::directional::Cell;
use glam::{DVec3, Vec3};
use std::f64::consts::PI;
use std::sync::OnceLock;

/// Levels 0..=PRECOMPUTED_DEPTH are tabulated (1365 cells, 16 KiB).
pub const PRECOMPUTED_DEPTH: u32 = 5;
fn s_of(z: f64) -> f64 {
    let z = z.clamp(-1.0, 1.0);
    0.5 * (z * (1.0 - z * z).max(0.0).sqrt() + z.asin())
}

/// Closed-form F of a cell, in f64.
pub fn cell_form_factor(cell: Cell) -> DVec3 {
    let b = cell.bounds();
    let ds = s_of(b.z1) - s_of(b.z0);
    DVec3::new(
        (b.phi1.sin() - b.phi0.sin()) * ds / PI,
        (b.phi0.cos() - b.phi1.cos()) * ds / PI,
        (b.phi1 - b.phi0) * (b.z1 * b.z1 - b.z0 * b.z0) / (2.0 * PI),
    )
}

fn level_offset(depth: u32) -> usize {
    // Σ_{d < depth} 4^d
    ((1usize << (2 * depth)) - 1) / 3
}

fn table() -> &'static [Vec3] {
    static TABLE: OnceLock<Vec<Vec3>> = OnceLock::new();
    TABLE.get_or_init(|| {
        let mut t = vec![Vec3::ZERO; level_offset(PRECOMPUTED_DEPTH + 1)];
        for depth in 0..=PRECOMPUTED_DEPTH {
            let n = 1u32 << depth;
            for iy in 0..n {
                for ix in 0..n {
                    let cell = Cell { depth, ix, iy };
                    t[level_offset(depth) + (iy * n + ix) as usize] =
                        cell_form_factor(cell).as_vec3();
                }
            }
        }
        t
    })
}

/// Forces the one-time precomputations (form factors and coarse cell
/// polygons; otherwise done on first use).
pub fn precompute() {
    let _ = table();
    super::coarse::precompute();
    super::fast_math::precompute();
    let mut p = Vec::new();
    super::polygon::cell_polygon_f32(Cell::ROOT, &mut p);
}

/// F of a cell at any depth: tabulated, else the closed form in f64.
#[inline]
pub fn form_factor(cell: Cell) -> Vec3 {
    if cell.depth <= PRECOMPUTED_DEPTH {
        let n = 1u32 << cell.depth;
        table()[level_offset(cell.depth) + (cell.iy * n + cell.ix) as usize]
    } else {
        cell_form_factor(cell).as_vec3()
    }
}

/// F of the 4 children of a node below the precomputed levels, in f32:
/// exact in φ, two-point Gauss–Legendre in z. The rule's relative error is
/// ≲ (Δz/h)⁴/4320 at distance h from a pole, so the two rows next to each
/// pole keep the f64 closed form. No term cancels, so depth 20 is as
/// accurate as depth 6.
pub fn children_form_factors_f32(cell: Cell) -> [Vec3; 4] {
    use super::polygon::sincos_turns;
    let n_child = 1u64 << (cell.depth + 1);
    let h = 1.0 / n_child as f32;
    let dz = 2.0 * h;
    // Child centres: z by the u bit, azimuth (turns) by the v bit.
    let (zc, vc) = super::children::child_centres(cell);
    let off = dz * (0.5 / 3f32.sqrt());
    let f = |z: f32| (1.0 - z * z).max(0.0).sqrt();
    let g = zc.map(|z| 0.5 * dz * (f(z - off) + f(z + off)));
    // sin(Δφ/2) with Δφ/2 = π·h ≤ π/64: three Taylor terms are exact in f32.
    let x = std::f32::consts::PI * h;
    let x2 = x * x;
    let sh = x * (1.0 - x2 / 6.0 * (1.0 - x2 / 20.0));
    let sc = vc.map(sincos_turns);
    let inv_pi = std::f32::consts::FRAC_1_PI;
    std::array::from_fn(|k| {
        let child = cell.child(k);
        if child.ix < 2 || child.ix as u64 >= n_child - 2 {
            return cell_form_factor(child).as_vec3();
        }
        let (iu, iv) = (k & 1, k >> 1);
        let (s, c) = sc[iv];
        Vec3::new(
            2.0 * g[iu] * sh * c * inv_pi,
            2.0 * g[iu] * sh * s * inv_pi,
            2.0 * h * dz * zc[iu],
        )
    })
}

/// The cosine lobe's integrals over the root's children (quarter spheres
/// {s_z·z ≥ 0} ∩ {s_y·y ≥ 0}, in [`Cell::child`] order) when the normal n
/// is (nearly) perpendicular to x̂, where the three great circles bounding a
/// clipped child nearly meet at ±x̂ and the triangle form of
/// [`super::level1`] loses its accuracy.
///
/// For n_x = 0 the clipped child is a lune around the x axis: with ψ the
/// angle about x̂ and m = (n_y, n_z)/|(n_y, n_z)|, ω = (cos t, sin t·cos ψ,
/// sin t·sin ψ) and ∫_0^π sin² t dt = π/2, the integral over the quadrant
/// [a, b] of ψ is ½∫_a^b max(0, cos(ψ − ψ_m)) dψ = ½·max(0, S(b) − S(a)),
/// S the antiderivative sin(ψ − ψ_m) saturated at ±1 (the max takes care
/// of a quadrant wrapping through the back). The quarter spheres are
/// symmetric under x ↦ −x, so the first-order term in n_x vanishes and the
/// error for a unit normal is O(n_x²) (measured in the tests).
pub fn cosine_quarter_spheres_near_lune(n: Vec3) -> [f32; 4] {
    let len = (n.y * n.y + n.z * n.z).sqrt();
    if !(len > 0.0) {
        return [0.0; 4];
    }
    let (my, mz) = (n.y / len, n.z / len);
    // S at a quadrant boundary e (a unit vector of the y-z plane).
    let s = |ey: f32, ez: f32| {
        let sin = ez * my - ey * mz;
        if ey * my + ez * mz >= 0.0 {
            sin
        } else if sin >= 0.0 {
            1.0
        } else {
            -1.0
        }
    };
    // Quadrant boundaries, counter-clockwise about x̂: +y, +z, −y, −z.
    let (py, pz, ny, nz) = (s(1.0, 0.0), s(0.0, 1.0), s(-1.0, 0.0), s(0.0, -1.0));
    let part = |a: f32, b: f32| 0.5 * (b - a).max(0.0);
    // Child k: bit 0 set = upper half (s_z = +1), bit 1 set = y < 0.
    [part(nz, py), part(py, pz), part(ny, nz), part(pz, ny)]
}
