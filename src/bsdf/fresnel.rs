//! Exact unpolarised Fresnel reflectance of dielectric and conductor
//! interfaces, with Mitsuba 3's sign conventions for the refracted cosine.

use crate::math::Spectrum;
use glam::Vec3;

/// The outcome of a dielectric Fresnel evaluation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DielectricFresnel {
    /// Unpolarised reflectance in [0, 1]; 1 under total internal reflection.
    pub r: f32,
    /// Cosine of the refracted direction, with the sign opposite to `cos_i`
    /// (the transmitted ray leaves on the other side of the interface).
    pub cos_t: f32,
    /// Relative IOR η_i/η_t seen from the side of `cos_i`'s direction.
    pub eta_it: f32,
    /// Its inverse η_t/η_i.
    pub eta_ti: f32,
}

/// Dielectric Fresnel reflectance for a direction with cosine `cos_i` to the
/// normal, for the relative IOR `eta` = η_inside/η_outside. A negative
/// `cos_i` means the direction lies inside, so the ratio is inverted.
#[inline]
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> DielectricFresnel {
    let outside = cos_i >= 0.0;
    let inv_eta = 1.0 / eta;
    let (eta_it, eta_ti) = if outside {
        (eta, inv_eta)
    } else {
        (inv_eta, eta)
    };
    let cos_i_abs = cos_i.abs().min(1.0);
    let cos_t_sqr = 1.0 - eta_ti * eta_ti * (1.0 - cos_i_abs * cos_i_abs);
    let cos_t_abs = cos_t_sqr.max(0.0).sqrt();
    let cos_t = if outside { -cos_t_abs } else { cos_t_abs };
    let r = if eta == 1.0 {
        0.0
    } else if cos_t_sqr <= 0.0 || cos_i_abs == 0.0 {
        // Total internal reflection, or exactly grazing incidence where both
        // amplitude ratios tend to -1.
        1.0
    } else {
        // Amplitude ratios written with η_it so a single expression serves
        // both sides of the interface.
        let a_s = (eta_it * cos_t_abs - cos_i_abs) / (eta_it * cos_t_abs + cos_i_abs);
        let a_p = (eta_it * cos_i_abs - cos_t_abs) / (eta_it * cos_i_abs + cos_t_abs);
        (0.5 * (a_s * a_s + a_p * a_p)).clamp(0.0, 1.0)
    };
    DielectricFresnel {
        r,
        cos_t,
        eta_it,
        eta_ti,
    }
}

/// Shorthand for the reflectance alone.
#[inline]
pub fn fresnel_dielectric_r(cos_i: f32, eta: f32) -> f32 {
    fresnel_dielectric(cos_i, eta).r
}

/// Refraction of `wi` about the microfacet normal `m` given the refracted
/// cosine from [`fresnel_dielectric`] (signed) and η_t/η_i.
#[inline]
pub fn refract(wi: Vec3, m: Vec3, cos_t: f32, eta_ti: f32) -> Vec3 {
    m * (wi.dot(m) * eta_ti + cos_t) - wi * eta_ti
}

/// Mirror reflection of `w` about the unit normal `m`.
#[inline]
pub fn reflect(w: Vec3, m: Vec3) -> Vec3 {
    2.0 * w.dot(m) * m - w
}

/// Egan–Hilgeman fit of the hemispherically averaged (diffuse) Fresnel
/// reflectance, as Mitsuba's `fresnel_diffuse_reflectance`: the first branch
/// is the one the `plastic` model uses with `eta` = 1/η (light inside the
/// coating).
pub fn fresnel_diffuse_reflectance(eta: f32) -> f32 {
    if eta < 1.0 {
        -1.4399 * eta * eta + 0.7099 * eta + 0.6681 + 0.0636 / eta
    } else {
        let inv = 1.0 / eta;
        let (i2, i3) = (inv * inv, inv * inv * inv);
        0.919317 - 3.4793 * inv + 6.75335 * i2 - 7.80989 * i3 + 4.98554 * i2 * i2
            - 1.36881 * i2 * i3
    }
}

/// Exact unpolarised reflectance of a conductor with complex IOR η + iκ
/// (relative to the outside medium), all three channels at once. `cos_i` is
/// the cosine to the (micro)normal; the surface is opaque, so its sign is
/// ignored.
///
/// Uses the real (a, b) form of the Fresnel equations (Born & Wolf): with
/// n² − sin²θ = (a + ib)², a² + b² = |n² − sin²θ|, both amplitude ratios
/// reduce to real arithmetic (two square roots and two divisions per
/// channel), which the compiler evaluates lane-wise.
#[inline]
pub fn fresnel_conductor(cos_i: f32, eta: Spectrum, k: Spectrum) -> Spectrum {
    let c = cos_i.abs().min(1.0);
    let c2 = c * c;
    let s2 = 1.0 - c2;
    let t0 = eta * eta - k * k - Spectrum::splat(s2);
    let a2pb2 = sqrt3(t0 * t0 + 4.0 * eta * eta * k * k);
    let a = sqrt3(0.5 * (a2pb2 + t0));
    let t1 = a2pb2 + Spectrum::splat(c2);
    let t2 = 2.0 * c * a;
    let t3 = a2pb2 * c2 + Spectrum::splat(s2 * s2);
    let t4 = t2 * s2;
    let rs = (t1 - t2) / (t1 + t2);
    let rp = rs * (t3 - t4) / (t3 + t4);
    let r = 0.5 * (rs + rp);
    // Only 0/0 (η = κ = 0 at grazing) can fail; a mirror is the limit.
    Spectrum::select(
        r.cmpeq(r),
        r.clamp(Spectrum::ZERO, Spectrum::ONE),
        Spectrum::ONE,
    )
}

#[inline]
fn sqrt3(v: Spectrum) -> Spectrum {
    Spectrum::new(
        v.x.max(0.0).sqrt(),
        v.y.max(0.0).sqrt(),
        v.z.max(0.0).sqrt(),
    )
}

/// One channel of [`fresnel_conductor`].
#[inline]
pub fn fresnel_conductor_1(cos_i: f32, eta: f32, k: f32) -> f32 {
    fresnel_conductor(cos_i, Spectrum::splat(eta), Spectrum::splat(k)).x
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Independent reference: the Fresnel amplitudes with complex
    /// arithmetic in f64, r_s = (cosθ − n cosθ_t)/(cosθ + n cosθ_t),
    /// r_p = (n² cosθ − n cosθ_t)/(n² cosθ + n cosθ_t), n cosθ_t =
    /// sqrt(n² − sin²θ) on the principal branch.
    fn conductor_ab(cos_i: f64, eta: f64, k: f64) -> f64 {
        type C = (f64, f64);
        let mul = |a: C, b: C| (a.0 * b.0 - a.1 * b.1, a.0 * b.1 + a.1 * b.0);
        let abs2 = |a: C| a.0 * a.0 + a.1 * a.1;
        let sqrt = |a: C| {
            let r = abs2(a).sqrt();
            let re = (0.5 * (r + a.0)).max(0.0).sqrt();
            let im = (0.5 * (r - a.0)).max(0.0).sqrt().copysign(a.1);
            (re, im)
        };
        let n = (eta, k);
        let n2 = mul(n, n);
        let nct = sqrt((n2.0 - (1.0 - cos_i * cos_i), n2.1));
        let rs = abs2((cos_i - nct.0, -nct.1)) / abs2((cos_i + nct.0, nct.1));
        let n2c = (n2.0 * cos_i, n2.1 * cos_i);
        let rp = abs2((n2c.0 - nct.0, n2c.1 - nct.1)) / abs2((n2c.0 + nct.0, n2c.1 + nct.1));
        0.5 * (rs + rp)
    }

    #[test]
    fn conductor_matches_independent_closed_form_at_all_angles() {
        for &(eta, k) in &[
            (0.2f32, 3.0f32),
            (1.1, 2.5),
            (0.27, 2.78),
            (3.0, 0.0),
            (1.5, 0.1),
        ] {
            for i in 0..=50 {
                let c = i as f32 / 50.0;
                let a = fresnel_conductor_1(c, eta, k) as f64;
                let b = conductor_ab(c as f64, eta as f64, k as f64);
                assert!((a - b).abs() < 2e-5, "eta {eta} k {k} cos {c}: {a} vs {b}");
            }
        }
    }

    #[test]
    fn conductor_with_zero_k_equals_dielectric() {
        for i in 1..=20 {
            let c = i as f32 / 20.0;
            let a = fresnel_conductor_1(c, 1.5, 0.0);
            let b = fresnel_dielectric_r(c, 1.5);
            assert!((a - b).abs() < 1e-5, "{c}: {a} vs {b}");
        }
    }

    #[test]
    fn dielectric_is_symmetric_under_reciprocal_side_swap() {
        // Snell pairs (θ_i outside, θ_t inside) reflect identically.
        let eta = 1.5f32;
        for i in 1..20 {
            let ci = i as f32 / 20.0;
            let f = fresnel_dielectric(ci, eta);
            let back = fresnel_dielectric(f.cos_t, eta);
            assert!((f.r - back.r).abs() < 1e-5);
            assert!((back.cos_t - ci).abs() < 1e-5);
        }
        // Beyond the critical angle from inside: total internal reflection.
        assert_eq!(fresnel_dielectric(-0.3, 1.5).r, 1.0);
    }
}
