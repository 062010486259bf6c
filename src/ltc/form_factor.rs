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
//! fly, and from [`MIDPOINT_DEPTH`] on the midpoint rule Ω·ω_centre/π, whose
//! relative error O(δ²) is then below f32 resolution — except within
//! [`MIDPOINT_POLE_MARGIN`] rows of a pole, where √(1−z²) is too curved for
//! it and the closed form stays.

use crate::directional::Cell;
use glam::{DVec3, Vec3};
use std::f64::consts::PI;
use std::sync::OnceLock;

/// Levels 0..=PRECOMPUTED_DEPTH are tabulated (1365 cells, 16 KiB).
pub const PRECOMPUTED_DEPTH: u32 = 5;
/// From this depth on the midpoint rule replaces the closed form.
pub const MIDPOINT_DEPTH: u32 = 12;
/// Rows (in cos θ) next to each pole that keep the closed form.
pub const MIDPOINT_POLE_MARGIN: u32 = 32;

/// True when the midpoint rule is accurate enough for this cell.
#[inline]
pub fn uses_midpoint(cell: Cell) -> bool {
    let n = 1u32 << cell.depth.min(31);
    cell.depth >= MIDPOINT_DEPTH
        && cell.ix >= MIDPOINT_POLE_MARGIN
        && cell.ix < n - MIDPOINT_POLE_MARGIN
}

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

/// Ω·ω_centre/π, the midpoint-rule F of a small cell, in f64.
pub fn cell_form_factor_midpoint(cell: Cell) -> DVec3 {
    let b = cell.bounds();
    let z = 0.5 * (b.z0 + b.z1);
    let phi = 0.5 * (b.phi0 + b.phi1);
    let r = (1.0 - z * z).max(0.0).sqrt();
    DVec3::new(r * phi.cos(), r * phi.sin(), z) * (cell.solid_angle() / PI)
}

fn level_offset(depth: u32) -> usize {
    // Σ_{d < depth} 4^d
    (((1usize << (2 * depth)) - 1) / 3) as usize
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

/// Forces the one-time precomputation (otherwise done on first use).
pub fn precompute() {
    let _ = table();
}

/// F of a cell at any depth: tabulated, closed form or midpoint.
#[inline]
pub fn form_factor(cell: Cell) -> Vec3 {
    if cell.depth <= PRECOMPUTED_DEPTH {
        let n = 1u32 << cell.depth;
        table()[level_offset(cell.depth) + (cell.iy * n + cell.ix) as usize]
    } else if uses_midpoint(cell) {
        cell_form_factor_midpoint(cell).as_vec3()
    } else {
        cell_form_factor(cell).as_vec3()
    }
}
