//! Horizon clipping by the sphere approximation of Hill & Heitz (2017).
//!
//! Exact clipping of a transformed polygon against z = 0 needs branches and a
//! variable vertex count. Instead, the unclipped vector form factor F of the
//! polygon is replaced by a spherical cap with the same F: its half-angle σ
//! satisfies sin²σ = len = |F| and its axis makes cos ω = z = F_z/len with
//! the normal. The clipped integral is then len·K(z, len), where K is the
//! projected solid angle of the horizon-clipped cap over π·len, known in
//! closed form (Snyder 1996):
//! - cap wholly above the horizon (z ≥ sin σ): K = z, exact for any polygon
//!   that is wholly above too;
//! - cap wholly below (z ≤ −sin σ): K = 0;
//! - in between, with x = cot σ, y = −x·z/sin ω:
//!   π·len·K = len·(z·acos y − x·sin ω·√(1−y²)) + atan(sin ω·√(1−y²)/x).
//!
//! Only the middle band needs a table. There h = K/sin σ depends smoothly on
//! (z/sin σ, σ), in [−1, 1]×[0, π/2], so we tabulate h on that rectangle
//! (σ rather than sin σ: h steepens like √(1 − sin σ) as the cap approaches
//! a hemisphere) and interpolate bilinearly. The band boundaries are exact
//! (h = 1 at z = sin σ, h = 0 at z = −sin σ), so the table never creates a
//! jump. `tests/ltc_sphere_clip.rs` measures the error of the table.

use std::f64::consts::PI;
use std::sync::OnceLock;

/// Snyder's clipped-cap form factor len·K(z, len), in f64.
pub fn clipped_cap_form_factor(z: f64, len: f64) -> f64 {
    let len = len.clamp(0.0, 1.0);
    let z = z.clamp(-1.0, 1.0);
    if len <= 0.0 {
        return 0.0;
    }
    if z * z >= len {
        return len * z.max(0.0);
    }
    let sin_omega = (1.0 - z * z).max(0.0).sqrt();
    if sin_omega <= 0.0 {
        // Only reachable with len = 1 (a hemisphere): F = (1 + z)/2.
        return 0.5 * (1.0 + z);
    }
    let x = (1.0 / len - 1.0).max(0.0).sqrt();
    let y = (-x * z / sin_omega).clamp(-1.0, 1.0);
    let w = sin_omega * (1.0 - y * y).max(0.0).sqrt();
    let atan_term = if x > 0.0 { (w / x).atan() } else { 0.5 * PI };
    let f = (len * (z * y.acos() - x * w) + atan_term) / PI;
    f.max(0.0)
}

/// K(z, len) = clipped / unclipped-magnitude, in f64.
pub fn k_exact(z: f64, len: f64) -> f64 {
    if len <= 0.0 {
        return z.max(0.0);
    }
    clipped_cap_form_factor(z, len) / len
}

const NX: usize = 65;
const NS: usize = 33;

fn table() -> &'static [f32] {
    static TABLE: OnceLock<Vec<f32>> = OnceLock::new();
    TABLE.get_or_init(|| {
        let mut t = Vec::with_capacity(NX * NS);
        for js in 0..NS {
            // The σ → 0 limit is approached closely enough at σ = 1e-4.
            let sigma = (js as f64 / (NS - 1) as f64 * std::f64::consts::FRAC_PI_2).max(1e-4);
            let s = sigma.sin();
            for ix in 0..NX {
                let x = -1.0 + 2.0 * ix as f64 / (NX - 1) as f64;
                let h = if ix == NX - 1 {
                    1.0
                } else if ix == 0 {
                    0.0
                } else {
                    k_exact(x * s, s * s) / s
                };
                t.push(h as f32);
            }
        }
        t
    })
}

/// asin on [0, 1] through the project's polynomial atan2
/// ([`crate::directional::fast_atan2`], within 4e-7 rad): libm's asinf was
/// a tenth of the band's cost, and only the table coordinate needs it.
#[inline]
fn asin_unit(x: f32) -> f32 {
    crate::directional::fast_atan2(x, ((1.0 - x) * (1.0 + x)).max(0.0).sqrt())
}

/// The clipped integral len·K(F_z/len, len) of a polygon with unclipped
/// vector form factor of squared length `q` = F·F and normal component `fz`.
#[inline]
pub fn clipped_integral(fz: f32, q: f32) -> f32 {
    // Wholly above or below iff |F_z| ≥ sin σ·len = q^(3/4), i.e.
    // (F_z²/q)² ≥ q. Written with the ratio, not as F_z⁴ ≥ q³: for deep
    // cells q³ would be denormal, and denormals cost ~100 cycles each.
    if !(q > 0.0) {
        return 0.0;
    }
    let r = fz * fz / q;
    if r * r >= q {
        return fz.max(0.0);
    }
    clipped_integral_band(fz, q)
}

/// Out of line to keep [`clipped_integral`]'s common exits short; not
/// cold: product guiding's coarse diffuse children straddle the horizon
/// often.
#[inline(never)]
fn clipped_integral_band(fz: f32, q: f32) -> f32 {
    let len = q.sqrt().min(1.0);
    let s = len.sqrt();
    if !(s > 0.0) {
        return 0.0;
    }
    let x = (fz / (len * s)).clamp(-1.0, 1.0);
    let fx = (x + 1.0) * 0.5 * (NX - 1) as f32;
    let fs = asin_unit(s.min(1.0)) * std::f32::consts::FRAC_2_PI * (NS - 1) as f32;
    let ix = (fx as usize).min(NX - 2);
    let js = (fs as usize).min(NS - 2);
    let (wx, ws) = (fx - ix as f32, fs - js as f32);
    let t = table();
    let r0 = t[js * NX + ix] * (1.0 - wx) + t[js * NX + ix + 1] * wx;
    let r1 = t[(js + 1) * NX + ix] * (1.0 - wx) + t[(js + 1) * NX + ix + 1] * wx;
    let h = r0 * (1.0 - ws) + r1 * ws;
    (len * s * h).max(0.0)
}

#[cfg(test)]
mod tests {
    /// The polynomial asin against f64 asin over [0, 1], ends included.
    #[test]
    fn asin_unit_is_accurate_to_f32_rounding() {
        let mut worst = 0.0f64;
        for i in 0..=100_000 {
            let x = i as f32 / 100_000.0;
            let e = (super::asin_unit(x) as f64 - (x as f64).asin()).abs();
            worst = worst.max(e);
        }
        assert!(worst < 4e-7, "{worst:e}");
    }
}
