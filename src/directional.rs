//! The directional domain shared by the quadtree and the LTC cell integrals.
//!
//! World directions map to the unit square by the equal-area cylindrical map
//! u = (cos θ + 1)/2, v = φ/2π, with θ and φ measured around world +z. The
//! density conversion is therefore constant: p_ω = p_square / 4π.
//!
//! Cells are addressed as (depth, ix, iy): at depth d the square is split into
//! 2^d × 2^d cells and cell (ix, iy) covers u ∈ [ix, ix+1]/2^d and
//! v ∈ [iy, iy+1]/2^d. Child k ∈ 0..4 of a cell is (2·ix + (k & 1),
//! 2·iy + (k >> 1)) at depth d+1: bit 0 steps in u (cos θ), bit 1 in v (φ).
//! Every module that enumerates children uses this order.

use crate::math::{INV_4PI, PI};
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_PI_2, FRAC_PI_4};

/// Converts a square-measure density to a solid-angle density.
pub const SQUARE_TO_SOLID_ANGLE_PDF: f32 = INV_4PI;

/// A cell of the cylindrical map, as bounds on cos θ and φ.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cell {
    pub depth: u32,
    pub ix: u32,
    pub iy: u32,
}

/// Cylindrical bounds of a cell: cos θ ∈ [z0, z1], φ ∈ [phi0, phi1].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CellBounds {
    pub z0: f64,
    pub z1: f64,
    pub phi0: f64,
    pub phi1: f64,
}

impl Cell {
    pub const ROOT: Cell = Cell {
        depth: 0,
        ix: 0,
        iy: 0,
    };

    #[inline]
    pub fn child(&self, k: usize) -> Cell {
        Cell {
            depth: self.depth + 1,
            ix: 2 * self.ix + (k as u32 & 1),
            iy: 2 * self.iy + (k as u32 >> 1),
        }
    }

    /// Bounds on the unit square: (u0, v0) and the side length.
    #[inline]
    pub fn square_bounds(&self) -> (f64, f64, f64) {
        let size = 1.0 / (1u64 << self.depth) as f64;
        (self.ix as f64 * size, self.iy as f64 * size, size)
    }

    pub fn bounds(&self) -> CellBounds {
        let (u0, v0, size) = self.square_bounds();
        CellBounds {
            z0: 2.0 * u0 - 1.0,
            z1: 2.0 * (u0 + size) - 1.0,
            phi0: 2.0 * std::f64::consts::PI * v0,
            phi1: 2.0 * std::f64::consts::PI * (v0 + size),
        }
    }

    /// Side length 2^-depth of the cell on the unit square, in f32: exact
    /// down to depth 20, as are the dyadic origins `ix`·size and `iy`·size.
    #[inline]
    pub fn square_size(&self) -> f32 {
        f32::from_bits((127 - self.depth) << 23)
    }

    /// Solid angle of the cell: every cell at depth d covers 4π/4^d sr.
    #[inline]
    pub fn solid_angle(&self) -> f64 {
        4.0 * std::f64::consts::PI / (1u64 << (2 * self.depth)) as f64
    }
}

/// atan2(y, x) in (−π, π], within 4e-7 rad (1.7 ulp at π) of the exact value (tested): Cephes'
/// atanf reduction and polynomial, arranged around a single division and
/// no branches. Every guided vertex maps one or two directions to the
/// square, and libm's atan2f was 5–6 % of a radiance-guided render.
#[inline]
pub fn fast_atan2(y: f32, x: f32) -> f32 {
    const TAN_PI_8: f32 = 0.414_213_57;
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = (ax.min(ay), ax.max(ay));
    // atan(lo/hi) for lo/hi in [0, 1]; above tan(π/8) use
    // π/4 + atan((lo − hi)/(lo + hi)), whose argument is small again.
    let upper = lo > TAN_PI_8 * hi;
    let (num, den) = if upper { (lo - hi, lo + hi) } else { (lo, hi) };
    let t = if den > 0.0 { num / den } else { 0.0 };
    let z = t * t;
    let p =
        (((8.053_744_5e-2 * z - 1.387_768_6e-1) * z + 1.997_771_1e-1) * z - 3.333_295e-1) * z * t
            + t;
    let mut r = if upper { FRAC_PI_4 + p } else { p };
    if ay > ax {
        r = FRAC_PI_2 - r;
    }
    if x < 0.0 {
        r = PI - r;
    }
    if y.is_sign_negative() { -r } else { r }
}

/// Square coordinates of a unit world direction.
#[inline]
pub fn dir_to_square(d: Vec3) -> Vec2 {
    let u = (d.z.clamp(-1.0, 1.0) + 1.0) * 0.5;
    let mut phi = fast_atan2(d.y, d.x);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    let v = phi * (0.5 / PI);
    // atan2 can round up to exactly 2π; keep v in [0, 1).
    Vec2::new(u.clamp(0.0, 1.0), if v >= 1.0 { 0.0 } else { v })
}

/// Unit world direction of a point of the square.
#[inline]
pub fn square_to_dir(p: Vec2) -> Vec3 {
    let z = 2.0 * p.x - 1.0;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (s, c) = (2.0 * PI * p.y).sin_cos();
    Vec3::new(r * c, r * s, z)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_atan2_matches_libm() {
        let mut worst = 0.0f64;
        let mut state = 0x1234_5678u32;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state as f32 / u32::MAX as f32 * 2.0 - 1.0
        };
        let mut check = |y: f32, x: f32| {
            let e = (fast_atan2(y, x) as f64 - (y as f64).atan2(x as f64)).abs();
            worst = worst.max(e);
        };
        for _ in 0..200_000 {
            let (y, x) = (next(), next());
            check(y, x);
            check(y * 1e-6, x);
            check(y, x * 1e-6);
        }
        for (y, x) in [
            (0.0, 1.0),
            (1.0, 0.0),
            (0.0, -1.0),
            (-1.0, 0.0),
            (1.0, 1.0),
            (-1.0, -1.0),
        ] {
            check(y, x);
        }
        // 1.7 ulp of π: the rounding of the result itself is 1.2e-7 there.
        assert!(worst < 4e-7, "worst error {worst:e} rad");
        assert_eq!(fast_atan2(0.0, 0.0), 0.0);
        assert_eq!(fast_atan2(0.0, -1.0), PI);
        assert_eq!(fast_atan2(-0.0, 1.0), 0.0);
    }

    #[test]
    fn map_round_trips_and_children_tile_the_parent() {
        for &d in &[
            Vec3::new(0.3, -0.5, 0.2).normalize(),
            Vec3::new(-1.0, 0.0, 0.0),
            Vec3::Z,
        ] {
            let back = square_to_dir(dir_to_square(d));
            assert!((back - d).length() < 1e-5, "{d:?} {back:?}");
        }
        let parent = Cell {
            depth: 3,
            ix: 5,
            iy: 2,
        };
        let pb = parent.bounds();
        let c0 = parent.child(0).bounds();
        let c3 = parent.child(3).bounds();
        assert_eq!(c0.z0, pb.z0);
        assert_eq!(c0.phi0, pb.phi0);
        assert_eq!(c3.z1, pb.z1);
        assert_eq!(c3.phi1, pb.phi1);
        let child_area: f64 = (0..4).map(|k| parent.child(k).solid_angle()).sum();
        assert!((child_area - parent.solid_angle()).abs() < 1e-12);
    }
}
