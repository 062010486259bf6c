//! The isotropic GGX (Trowbridge–Reitz) microfacet distribution with Smith's
//! separable shadowing–masking, exactly as the scene README (and Mitsuba 3)
//! define it, and sampling of the distribution of visible normals.
//!
//! All directions are in the local shading frame (z = macro normal).

use super::fresnel::reflect;
use crate::math::PI;
use crate::sampling::square_to_disk_concentric;
use glam::{Vec2, Vec3};

/// Mitsuba clamps the roughness to this value; below it the lobe is a delta
/// in f32 anyway.
pub const MIN_ALPHA: f32 = 1e-4;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ggx {
    alpha: f32,
}

impl Ggx {
    /// `alpha` is clamped to [`MIN_ALPHA`]; a non-finite value becomes the
    /// minimum rather than propagating NaN (the material constructor
    /// rejects those earlier).
    #[inline]
    pub fn new(alpha: f32) -> Self {
        let alpha = if alpha.is_finite() {
            alpha.max(MIN_ALPHA)
        } else {
            MIN_ALPHA
        };
        Ggx { alpha }
    }

    #[inline]
    pub fn alpha(&self) -> f32 {
        self.alpha
    }

    /// D(m) = α² / (π cos⁴θ (α² + tan²θ)²), evaluated in the equivalent form
    /// 1 / (π α² ((x² + y²)/α² + z²)²), which needs no tangent and stays
    /// finite at θ = 0. Zero on the lower hemisphere.
    #[inline]
    pub fn d(&self, m: Vec3) -> f32 {
        if m.z <= 0.0 {
            return 0.0;
        }
        let a2 = self.alpha * self.alpha;
        let t = (m.x * m.x + m.y * m.y) / a2 + m.z * m.z;
        let d = 1.0 / (PI * a2 * t * t);
        // Mitsuba's underflow guard: keeps later products denormal-free.
        if d * m.z > 1e-20 && d.is_finite() {
            d
        } else {
            0.0
        }
    }

    /// Smith G1(v, m) = 2 / (1 + sqrt(1 + α² tan²θ_v)), zero when `m` faces
    /// away from `v` relative to the macro surface.
    #[inline]
    pub fn g1(&self, v: Vec3, m: Vec3) -> f32 {
        if v.dot(m) * v.z <= 0.0 {
            return 0.0;
        }
        let xy2 = v.x * v.x + v.y * v.y;
        if xy2 == 0.0 {
            return 1.0;
        }
        let a2_tan2 = self.alpha * self.alpha * xy2 / (v.z * v.z);
        let g = 2.0 / (1.0 + (1.0 + a2_tan2).sqrt());
        if g.is_finite() { g } else { 0.0 }
    }

    #[inline]
    pub fn g(&self, wo: Vec3, wi: Vec3, m: Vec3) -> f32 {
        self.g1(wo, m) * self.g1(wi, m)
    }

    /// Samples a microfacet normal from the distribution of normals visible
    /// from `wo` (wo.z > 0), D_wo(m) = G1(wo, m) max(0, wo·m) D(m) / wo.z,
    /// with Heitz's 2018 construction: in the configuration stretched to
    /// α = 1 the visible normals are uniform over the projected hemisphere,
    /// i.e. a disk squashed on the side hidden by the hemisphere's own
    /// silhouette. The concentric disk map keeps the warp continuous, so
    /// stratified and quadrature inputs stay well distributed.
    #[inline]
    pub fn sample_visible(&self, wo: Vec3, u: Vec2) -> Vec3 {
        let a = self.alpha;
        let vh = Vec3::new(a * wo.x, a * wo.y, wo.z).normalize_or(Vec3::Z);
        let len2 = vh.x * vh.x + vh.y * vh.y;
        let t1 = if len2 > 0.0 {
            Vec3::new(-vh.y, vh.x, 0.0) / len2.sqrt()
        } else {
            Vec3::X
        };
        let t2 = vh.cross(t1);
        let p = square_to_disk_concentric(u);
        let s = 0.5 * (1.0 + vh.z);
        let p2 = (1.0 - s) * (1.0 - p.x * p.x).max(0.0).sqrt() + s * p.y;
        let nh = t1 * p.x + t2 * p2 + vh * (1.0 - p.x * p.x - p2 * p2).max(0.0).sqrt();
        Vec3::new(a * nh.x, a * nh.y, nh.z.max(0.0)).normalize_or(Vec3::Z)
    }

    /// Density of [`Self::sample_visible`] over microfacet normals.
    #[inline]
    pub fn pdf_visible(&self, wo: Vec3, m: Vec3) -> f32 {
        if wo.z <= 0.0 {
            return 0.0;
        }
        self.d(m) * self.g1(wo, m) * wo.dot(m).max(0.0) / wo.z
    }

    /// Solid-angle density of wi = reflect(wo, m) with m from
    /// [`Self::sample_visible`]: D(h) G1(wo, h) / (4 wo.z), h the half vector.
    /// Directions below the horizon keep their density here; BSDFs that
    /// reject them simply lose that mass.
    #[inline]
    pub fn reflection_pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 {
            return 0.0;
        }
        // The BSDFs' fused eval+pdf take the same terms, so both agree bitwise.
        self.reflection(wo, wi).map_or(0.0, |r| r.pdf)
    }

    /// The microfacet terms of the reflection wo → wi (wo.z > 0, both
    /// unit), or `None` where D vanishes or the pair is degenerate.
    ///
    /// With the unnormalised half vector h = wo + wi (|h|² = l²), D and the
    /// Smith terms need no normalisation and share their divisions:
    /// - D = α² l⁴ / (π q²), q = h_x² + h_y² + α² h_z² (D's form above,
    ///   scaled by l⁴);
    /// - G1(v) = 2 v_z / (v_z + s_v), s_v = √(v_z² + α² (v_x² + v_y²));
    /// - D G1(wo) / (4 wo_z) = D / (2 (wo_z + s_o)), and both reciprocals
    ///   come from 1 / ((wo_z + s_o)(wi_z + s_i));
    /// - wo·ĥ = l / 2, since wo·h = 1 + wo·wi = l² / 2 for unit vectors.
    ///   It is also the more accurate form: for nearly opposite directions
    ///   the f32 dot wo·ĥ cancels (1e-4 relative at wo·ĥ = 0.012, against
    ///   5e-8 for l/2), and wo·h/l put a division before the Fresnel term's
    ///   own, 3 % slower on staircase.
    ///
    /// Two divisions and three square roots, where normalising h, D, both
    /// G1 and 1/(4 wo_z) took seven divisions and two roots: the eval of
    /// the rough BSDFs waited on the divider.
    #[inline]
    pub fn reflection(&self, wo: Vec3, wi: Vec3) -> Option<Reflection> {
        let h = wo + wi;
        let l2 = h.length_squared();
        if !(l2 > 0.0 && l2.is_finite() && h.z > 0.0) {
            return None;
        }
        let a2 = self.alpha * self.alpha;
        let q = h.z.mul_add(a2 * h.z, h.x * h.x + h.y * h.y);
        let d = a2 * l2 * l2 / (PI * q * q);
        let l = l2.sqrt();
        // Mitsuba's underflow guard, D·cos θ_h > 1e-20, without dividing by l.
        if !(d * h.z > 1e-20 * l && d.is_finite()) {
            return None;
        }
        let smith = |v: Vec3| v.z + (v.z * v.z + a2 * (v.x * v.x + v.y * v.y)).sqrt();
        let (so, si) = (smith(wo), smith(wi));
        let r = 1.0 / (so * si);
        let pdf = 0.5 * d * (r * si);
        let g1_i = 2.0 * wi.z * (r * so);
        if !(pdf.is_finite() && g1_i.is_finite()) {
            return None;
        }
        Some(Reflection {
            pdf,
            g1_i: g1_i.clamp(0.0, 1.0),
            cos_oh: (0.5 * l).min(1.0),
        })
    }

    /// Samples a reflected direction (possibly below the horizon).
    #[inline]
    pub fn sample_reflection(&self, wo: Vec3, u: Vec2) -> Vec3 {
        reflect(wo, self.sample_visible(wo, u))
    }
}

/// What the rough reflection BSDFs need of the microfacet model for one
/// pair of directions ([`Ggx::reflection`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reflection {
    /// D(h) G1(wo, h) / (4 wo.z): the density of visible-normal sampling.
    pub pdf: f32,
    /// G1(wi, h); the BRDF times cos θ_i is F(wo·h) · pdf · G1(wi, h).
    pub g1_i: f32,
    /// wo·ĥ, ĥ the normalised half vector: the Fresnel cosine.
    pub cos_oh: f32,
}

/// Normalised half vector of a reflection pair, `None` when degenerate.
#[inline]
pub fn half_vector(wo: Vec3, wi: Vec3) -> Option<Vec3> {
    let h = wo + wi;
    let l2 = h.length_squared();
    if l2 > 0.0 && l2.is_finite() {
        Some(crate::math::div3(h, l2.sqrt()))
    } else {
        None
    }
}

/// The GGX microfacet BRDF with Fresnel = 1, times cos θ_i:
/// D(h) G(wo, wi, h) / (4 cos θ_o). This is the `GGX_cos` of the product
/// guiding decomposition ([`super::Lobes`]); its hemispherical integral (the
/// GGX directional albedo) is below 1 because of shadowing–masking.
#[inline]
pub fn ggx_cos(alpha: f32, wo: Vec3, wi: Vec3) -> f32 {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return 0.0;
    }
    let Some(h) = half_vector(wo, wi) else {
        return 0.0;
    };
    let g = Ggx::new(alpha);
    let v = g.d(h) * g.g(wo, wi, h) / (4.0 * wo.z);
    if v.is_finite() { v.max(0.0) } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    /// The README's tangent form, in f64, as an independent reference.
    fn d_ref(alpha: f64, m: glam::DVec3) -> f64 {
        let c = m.z;
        let tan2 = (1.0 - c * c) / (c * c);
        let a2 = alpha * alpha;
        a2 / (std::f64::consts::PI * c.powi(4) * (a2 + tan2).powi(2))
    }

    #[test]
    fn d_matches_tangent_form_and_projects_to_one() {
        for &alpha in &[0.05f32, 0.3, 1.0] {
            let g = Ggx::new(alpha);
            for i in 0..40 {
                let c = 0.025 + i as f32 * 0.024;
                let m = crate::math::spherical_direction(c, 0.7);
                let a = g.d(m) as f64;
                let b = d_ref(alpha as f64, m.as_dvec3());
                assert!(
                    (a - b).abs() <= 1e-4 * b.max(1e-3),
                    "{alpha} {c}: {a} vs {b}"
                );
            }
            // ∫ D(m) cos θ_m dω = 1 (midpoint rule in θ, fine enough for the peak).
            let n = 200_000;
            let dth = std::f64::consts::FRAC_PI_2 / n as f64;
            let mut sum = 0.0f64;
            for i in 0..n {
                let th = (i as f64 + 0.5) * dth;
                let m = glam::DVec3::new(th.sin(), 0.0, th.cos());
                sum +=
                    d_ref(alpha as f64, m) * th.cos() * th.sin() * 2.0 * std::f64::consts::PI * dth;
            }
            assert!((sum - 1.0).abs() < 2e-3, "{alpha}: {sum}");
        }
    }

    /// The fused reflection terms equal D, G1 and wo·h taken from the
    /// normalised half vector, from α = 1e-4 to 1 and up to grazing angles.
    #[test]
    fn fused_reflection_terms_match_the_normalised_forms() {
        let mut rng = Rng::new(7, 3);
        let mut compared = 0;
        for &alpha in &[1e-4f32, 1e-3, 0.02, 0.3, 1.0] {
            let g = Ggx::new(alpha);
            for &ct in &[1.0f32, 0.7, 0.2, 0.02] {
                let wo = crate::math::spherical_direction(ct, 0.4);
                for _ in 0..500 {
                    // Half the pairs near the mirror direction, where D peaks.
                    let wi = if compared % 2 == 0 {
                        g.sample_reflection(wo, rng.next_2d())
                    } else {
                        crate::sampling::square_to_cosine_hemisphere(rng.next_2d())
                    };
                    if wi.z <= 0.0 {
                        continue;
                    }
                    let h = half_vector(wo, wi).unwrap();
                    let d = g.d(h);
                    let fused = g.reflection(wo, wi);
                    let Some(r) = fused else {
                        assert!(d * h.z <= 2e-20, "{alpha} {ct} {wi}: D = {d} dropped");
                        continue;
                    };
                    let pdf = d * g.g1(wo, h) / (4.0 * wo.z);
                    let close = |a: f32, b: f32| (a - b).abs() <= 2e-5 * a.abs().max(b.abs());
                    assert!(close(r.pdf, pdf), "{alpha} {ct} {wi}: {} vs {pdf}", r.pdf);
                    assert!(
                        close(r.g1_i, g.g1(wi, h)),
                        "{alpha} {ct} {wi}: {} vs {}",
                        r.g1_i,
                        g.g1(wi, h)
                    );
                    // Against wo·ĥ of the normalised inputs in f64, within a
                    // few ulp of 1 (the inputs' own length error): the f32
                    // dot of wo with ĥ cancels near grazing (off by 1.2e-6
                    // at wo·ĥ = 0.012 where l/2 is off by 6e-10).
                    let (a, b) = (wo.as_dvec3().normalize(), wi.as_dvec3().normalize());
                    let exact = a.dot((a + b).normalize());
                    assert!(
                        (r.cos_oh as f64 - exact).abs() <= 5e-7,
                        "{alpha} {ct} {wi}: {} vs {exact}",
                        r.cos_oh
                    );
                    compared += 1;
                }
            }
        }
        assert!(compared > 8000, "{compared}");
    }

    #[test]
    fn visible_normals_are_visible_and_on_the_upper_hemisphere() {
        let mut rng = Rng::new(1, 1);
        for &alpha in &[1e-4f32, 0.1, 1.0] {
            let g = Ggx::new(alpha);
            for &ct in &[1.0f32, 0.5, 1e-3] {
                let wo = crate::math::spherical_direction(ct, 1.0);
                for _ in 0..1000 {
                    let m = g.sample_visible(wo, rng.next_2d());
                    assert!(m.z >= 0.0 && (m.length() - 1.0).abs() < 1e-4);
                    assert!(wo.dot(m) >= -1e-5, "{alpha} {ct} {m:?}");
                }
            }
        }
    }
}
