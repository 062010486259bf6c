//! Small geometric helpers shared by every module: the RGB spectrum type,
//! orthonormal shading frames, spherical coordinates and Gauss–Legendre
//! rules.

use glam::Vec3;

/// Radiometric quantities are RGB triples, as in Mitsuba's `*_rgb` variants.
pub type Spectrum = Vec3;

pub const PI: f32 = std::f32::consts::PI;
pub const INV_PI: f32 = std::f32::consts::FRAC_1_PI;
pub const INV_2PI: f32 = 0.5 * std::f32::consts::FRAC_1_PI;
pub const INV_4PI: f32 = 0.25 * std::f32::consts::FRAC_1_PI;

/// Rec. 709 luminance; used wherever a scalar stands in for an RGB quantity.
#[inline]
pub fn luminance(c: Spectrum) -> f32 {
    0.212671 * c.x + 0.715160 * c.y + 0.072169 * c.z
}

/// True when every component is finite.
#[inline]
pub fn is_finite3(v: Vec3) -> bool {
    v.x.is_finite() && v.y.is_finite() && v.z.is_finite()
}

/// `v / s` in one packed division: glam's `Vec3` divides lane by lane
/// (three dependent-issue scalar divisions); the packed one rounds each lane
/// identically.
#[inline(always)]
pub fn div3(v: Vec3, s: f32) -> Vec3 {
    Vec3::from(glam::Vec3A::from(v) / s)
}

/// (sin x, cos x) for |x| ≤ π/4 by Cephes' single-precision minimax
/// polynomials (within 2 ulp there): no range reduction and no libm call,
/// which the cosine-weighted warp would otherwise make per bounce.
#[inline(always)]
pub fn sin_cos_quarter(x: f32) -> (f32, f32) {
    let x2 = x * x;
    let s = x + x * x2 * (-1.666_665_5e-1 + x2 * (8.332_161e-3 + x2 * -1.951_529_6e-4));
    let c =
        1.0 - 0.5 * x2 + x2 * x2 * (4.166_664_6e-2 + x2 * (-1.388_731_6e-3 + x2 * 2.443_315_7e-5));
    (s, c)
}

/// An orthonormal frame; `n` is the local +z axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    pub s: Vec3,
    pub t: Vec3,
    pub n: Vec3,
}

impl Frame {
    /// Builds a frame around a unit normal with the branch-free construction of
    /// Duff et al. 2017, which is continuous everywhere except at n.z = -1 exactly
    /// and never produces NaN.
    #[inline]
    pub fn from_normal(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { s, t, n }
    }

    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

/// Unit direction from spherical angles around +z.
#[inline]
pub fn spherical_direction(cos_theta: f32, phi: f32) -> Vec3 {
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    let (sin_phi, cos_phi) = phi.sin_cos();
    Vec3::new(sin_theta * cos_phi, sin_theta * sin_phi, cos_theta)
}

/// Mirror reflection of `v` about the local +z axis.
#[inline]
pub fn reflect_local(v: Vec3) -> Vec3 {
    Vec3::new(-v.x, -v.y, v.z)
}

/// Clamps tiny negative rounding errors away before a square root.
#[inline]
pub fn safe_sqrt(x: f32) -> f32 {
    x.max(0.0).sqrt()
}

/// ‖M‖_F, the Frobenius norm: how much an LTC map magnifies directions at
/// most (within √3), cheap and without eigenvalues.
///
/// The squares are summed as one dependent chain: as nine independent
/// products, LLVM packed eight of them into a 512-bit multiply, and on Intel
/// cores one such instruction per shading point lowers the clock of the
/// whole render (see [`narrow_dvec3`]).
pub fn frobenius_norm(m: &glam::DMat3) -> f64 {
    m.to_cols_array()
        .iter()
        .fold(0.0f64, |sum, &x| x.mul_add(x, sum))
        .sqrt()
}

/// A DVec3 rounded to f32, in a call of its own. Inlined next to other
/// conversions, LLVM packs eight of them into one 512-bit vcvtpd2ps. Any
/// 512-bit floating-point instruction, even an add or a conversion, makes
/// an Intel core lower its clock for a while after it, so one per shading
/// point slows everything the render does (measured in
/// `docs/results-reading.md`, session 63); a build with the `ymm-kernels`
/// feature keeps such instructions off the per-vertex path.
#[inline(never)]
pub fn narrow_dvec3(v: glam::DVec3) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

/// κ_F = ‖A‖_F·‖A⁻¹‖_F, the Frobenius condition number of a map A.
pub fn frobenius_condition(a: &glam::DMat3) -> f64 {
    frobenius_norm(a) * frobenius_norm(&a.inverse())
}

/// Gauss–Legendre nodes and weights on [−1, 1] (Newton iteration on the
/// Legendre recurrence, f64).
pub fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        // Tricomi's initial guess for the i-th root.
        let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0f64, x);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            let p = if n == 0 { 1.0 } else { p1 };
            dp = n as f64 * (x * p - p0) / (x * x - 1.0);
            let dx = p / dp;
            x -= dx;
            if dx.abs() < 1e-15 {
                break;
            }
        }
        let w = 2.0 / ((1.0 - x * x) * dp * dp);
        out.push((x, w));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_legendre_integrates_polynomials_exactly() {
        let rule = gauss_legendre(8);
        let s: f64 = rule.iter().map(|&(_, w)| w).sum();
        assert!((s - 2.0).abs() < 1e-13);
        // Degree 14 ≤ 2n − 1: ∫ x¹⁴ = 2/15.
        let s: f64 = rule.iter().map(|&(x, w)| w * x.powi(14)).sum();
        assert!((s - 2.0 / 15.0).abs() < 1e-13);
    }

    #[test]
    fn quarter_range_sin_cos_is_within_two_ulp() {
        let n = 100_000;
        for k in -n..=n {
            let x = std::f32::consts::FRAC_PI_4 * k as f32 / n as f32;
            let (s, c) = sin_cos_quarter(x);
            let (s64, c64) = (x as f64).sin_cos();
            // 2 ulp of values in [−0.71, 1], with an absolute floor near 0.
            let ulp = |v: f64| (v.abs().max(1e-3) * f32::EPSILON as f64) * 2.0;
            assert!((s as f64 - s64).abs() <= ulp(s64), "sin {x}: {s} vs {s64}");
            assert!((c as f64 - c64).abs() <= ulp(c64), "cos {x}: {c} vs {c64}");
        }
    }

    #[test]
    fn frame_is_orthonormal_everywhere_including_poles() {
        for n in [
            Vec3::Z,
            -Vec3::Z,
            Vec3::X,
            Vec3::new(1e-7, 0.0, -1.0).normalize(),
            Vec3::new(0.3, -0.4, 0.5).normalize(),
        ] {
            let f = Frame::from_normal(n);
            for (a, b) in [(f.s, f.t), (f.s, f.n), (f.t, f.n)] {
                assert!(a.dot(b).abs() < 1e-5, "{n:?}");
            }
            for v in [f.s, f.t, f.n] {
                assert!((v.length() - 1.0).abs() < 1e-5, "{n:?}");
            }
            let v = Vec3::new(0.2, 0.7, -0.1);
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-5);
        }
    }
}
