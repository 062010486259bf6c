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

/// [`cell_form_factor`] rounded to f32, in a call of its own: inlined
/// four times over (the children next to a pole), LLVM packs the four
/// cells' f64 arithmetic into 512-bit instructions, which on Intel cores
/// lower the clock of the whole render (see [`crate::math::narrow_dvec3`]).
#[inline(never)]
fn cell_form_factor_f32(cell: Cell) -> Vec3 {
    cell_form_factor(cell).as_vec3()
}

/// Whether a node's children lie in the two rows next to a pole (the node
/// itself in the first or last row), where the two-point rule of
/// [`children_form_factors_f32`] gives way to the f64 closed form.
#[inline]
pub fn next_to_pole(cell: Cell) -> bool {
    cell.ix == 0 || cell.ix as u64 == (1u64 << cell.depth) - 1
}

/// The per-depth constants of [`children_form_factors_f32`]: a child's
/// height Δz, the Gauss nodes' offset from its centre, and
/// 2·sin(Δφ/2)/π, the azimuthal factor of F_x, F_y. Δφ/2 = π·h is a
/// quarter of the node's width, so its sine is the node's table entry
/// (no polynomial, no division on the kernels' path).
#[inline(always)]
pub fn gauss_constants(cell: Cell) -> (f32, f32, f32) {
    let dz = 2.0 / (1u64 << (cell.depth + 1)) as f32;
    let (sin_half_width, _) = super::fast_math::step_sincos(cell.depth + 2);
    (
        dz,
        dz * (0.5 / 3f32.sqrt()),
        sin_half_width * (2.0 * std::f32::consts::FRAC_1_PI),
    )
}

/// F of the 4 children of a node below the precomputed levels, in f32:
/// exact in φ, two-point Gauss–Legendre in z. The rule's relative error is
/// ≲ (Δz/h)⁴/4320 at distance h from a pole, so the two rows next to each
/// pole keep the f64 closed form. No term cancels, so depth 20 is as
/// accurate as depth 6. The wide kernel
/// ([`super::children_x16::diffuse_children_x4`]) repeats these operations
/// lane by lane.
pub fn children_form_factors_f32(cell: Cell) -> [Vec3; 4] {
    if next_to_pole(cell) {
        return std::array::from_fn(|k| cell_form_factor_f32(cell.child(k)));
    }
    let (dz, off, k2_scale) = gauss_constants(cell);
    // Child centres: heights by the u bit, azimuths by the v bit.
    let (zc, _) = super::children::child_centres(cell);
    let f = |z: f32| (1.0 - z * z).max(0.0).sqrt();
    let k2 = zc.map(|z| (0.5 * dz) * (f(z - off) + f(z + off)) * k2_scale);
    let (s, c) = super::children::child_centre_sincos(cell);
    std::array::from_fn(|k| {
        let (iu, iv) = (k & 1, k >> 1);
        Vec3::new(k2[iu] * c[iv], k2[iu] * s[iv], (dz * dz) * zc[iu])
    })
}

/// The clamped cosine about a unit normal `n`, integrated over the 4 root
/// cells (quarter spheres {s_z·z ≥ 0} ∩ {s_y·y ≥ 0}, in [`Cell::child`]
/// order) and divided by π: each cell's share of the irradiance under
/// uniform light, summing to 1. Radiance guiding takes them for
/// roulette's adjoint estimate at every vertex that reads it, and product
/// guiding for its cosine lobe at level 1.
///
/// In closed form, the case A = shading frame of [`super::quarter_sphere`]'s
/// three arctangents. The clipped child is the intersection of three hemispheres
/// with inward normals s_z·ẑ, s_y·ŷ and n, a spherical triangle T, and
/// ∫_T ω dω = ½·Σ θ_i·m_i over its edges (θ_i the arc on the great circle
/// of normal m_i), so the share is (θ_n + s_z·n_z·θ_z + s_y·n_y·θ_y)/2π.
/// The vertices are ±x̂ and the horizon's crossings of the two planes,
/// which give
/// - θ_z = atan2(|n_x|, −s_y·n_y) (on z = 0, from ±x̂),
/// - θ_y = atan2(|n_x|, −s_z·n_z) (on y = 0, from ±x̂),
/// - θ_n = atan2(|n_x|, s_y·s_z·n_y·n_z) (on the horizon),
///
/// each well conditioned for any n_x ≠ 0. With a sign flipped,
/// atan2(|n_x|, −c) = π − atan2(|n_x|, c), so three arctangents serve the
/// four children. At n_x = 0 the cells are lunes and
/// [`cosine_quarter_spheres_near_lune`] is exact.
///
/// Inlined: called out of line it takes the `Vec3` through the caller's
/// stack, and its 8-byte load of (y, z) waited on the caller's narrower
/// stores, a failed store forwarding (16 % of the out-of-line version's
/// profile on its first use; `ltc/cosine_root_children` 44 ns a call out
/// of line, 8.8 ns inlined).
#[inline]
pub fn cosine_root_children(n: Vec3) -> [f32; 4] {
    if n.x == 0.0 {
        return cosine_quarter_spheres_near_lune(n);
    }
    super::quarter_sphere::root_shares_x4(super::quarter_sphere::RootPlanes {
        d_abs: n.x.abs(),
        y: [n.y * n.z, n.y, n.z],
        a_z: n.z,
        b_z: n.y,
    })
}

/// The cosine lobe's integrals over the root's children (quarter spheres
/// {s_z·z ≥ 0} ∩ {s_y·y ≥ 0}, in [`Cell::child`] order) when the normal n
/// is (nearly) perpendicular to x̂, where the three great circles bounding a
/// clipped child nearly meet at ±x̂: exact at n_x = 0, where
/// [`cosine_root_children`] takes it.
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
