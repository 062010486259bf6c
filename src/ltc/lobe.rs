//! A linearly transformed cosine (Heitz et al. 2016): the clamped cosine
//! D_o(ω_o) = max(0, z)/π pushed through a 3×3 matrix M. Its density is
//! D(ω) = D_o(M⁻¹ω/‖M⁻¹ω‖) · |det M⁻¹| / ‖M⁻¹ω‖³, it is sampled by mapping a
//! cosine sample through M, and it integrates to exactly 1, so a lobe of the
//! product carries its magnitude (the GGX albedo) as a separate weight.
//!
//! The GGX fit uses M = [X Y Z] · [[m11, 0, m13], [0, m22, 0], [0, 0, 1]]
//! where Z is the BRDF's average direction. With ω_o = (sin θ_o, 0, cos θ_o)
//! the lobe leans towards −x, so Z = (−sin θ_avg, 0, cos θ_avg),
//! Y = (0, 1, 0) and X = Y × Z = (cos θ_avg, 0, sin θ_avg).

use glam::{DMat3, DVec3};
use std::f64::consts::PI;

/// The four fitted numbers of a GGX LTC plus its average-direction angle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LtcParams {
    pub m11: f64,
    pub m22: f64,
    pub m13: f64,
    pub theta_avg: f64,
}

impl LtcParams {
    /// M in the frame where ω_o lies in the +x half of the xz plane.
    pub fn matrix(&self) -> DMat3 {
        let (x, z) = self.average_frame();
        DMat3::from_cols(x * self.m11, DVec3::Y * self.m22, x * self.m13 + z)
    }

    /// X and Z of the average-direction frame (Y = ŷ), as in the module
    /// documentation.
    fn average_frame(&self) -> (DVec3, DVec3) {
        let (s, c) = self.theta_avg.sin_cos();
        (DVec3::new(c, 0.0, s), DVec3::new(-s, 0.0, c))
    }

    /// M⁻¹ = K⁻¹·[X Y Z]ᵀ in closed form (K the fitted upper-triangular
    /// factor): rows (X − m13·Z)/m11, Y/m22 and Z. Every shading point of
    /// product guiding needs it; a general 3×3 inverse costs more.
    pub fn inverse_matrix(&self) -> DMat3 {
        let (x, z) = self.average_frame();
        DMat3::from_cols((x - z * self.m13) / self.m11, DVec3::Y / self.m22, z).transpose()
    }
}

/// An LTC with its inverse and the inverse's determinant precomputed.
#[derive(Clone, Copy, Debug)]
pub struct Ltc {
    pub m: DMat3,
    pub m_inv: DMat3,
    pub det_m_inv: f64,
}

impl Ltc {
    pub fn new(m: DMat3) -> Self {
        let m_inv = m.inverse();
        Ltc {
            m,
            m_inv,
            det_m_inv: m_inv.determinant().abs(),
        }
    }

    /// The clamped cosine itself (M = I): a diffuse lobe.
    pub fn cosine() -> Self {
        Ltc::new(DMat3::IDENTITY)
    }

    /// Solid-angle density at a unit direction.
    pub fn density(&self, w: DVec3) -> f64 {
        let wo = self.m_inv * w;
        let l2 = wo.length_squared();
        if !(l2 > 0.0) || !l2.is_finite() {
            return 0.0;
        }
        let l = l2.sqrt();
        let z = wo.z / l;
        if z <= 0.0 {
            return 0.0;
        }
        z / PI * self.det_m_inv / (l2 * l)
    }

    /// Density of the direction M·ω_o/‖M·ω_o‖ given the cosine-space ω_o;
    /// cheaper than [`Ltc::density`] because no inverse is applied.
    pub fn density_of_cosine_sample(&self, wo: DVec3) -> f64 {
        if wo.z <= 0.0 {
            return 0.0;
        }
        let l = (self.m * wo).length();
        // ‖M⁻¹ω‖ = 1/‖Mω_o‖ for ω = Mω_o/‖Mω_o‖.
        wo.z / PI * self.det_m_inv * l * l * l
    }

    /// Maps a point of the unit square to a direction distributed by the LTC.
    pub fn sample(&self, u1: f64, u2: f64) -> DVec3 {
        (self.m * cosine_sample(u1, u2)).normalize()
    }
}

/// Cosine-weighted hemisphere sample (polar map: it keeps the fitter's
/// stratified grid aligned with θ and φ).
pub fn cosine_sample(u1: f64, u2: f64) -> DVec3 {
    let r = u1.sqrt();
    let phi = 2.0 * PI * u2;
    DVec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u1).max(0.0).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The closed-form inverse against a general inverse, over the fitted
    /// range of the parameters (m11, m22 from near-singular to broad).
    #[test]
    fn inverse_matrix_inverts_matrix() {
        for (i, &(m11, m22, m13)) in [
            (1.0, 1.0, 0.0),
            (1e-3, 2e-3, 0.4),
            (0.3, 0.5, -0.2),
            (2.0, 0.7, 1.3),
        ]
        .iter()
        .enumerate()
        {
            let p = LtcParams {
                m11,
                m22,
                m13,
                theta_avg: 0.37 * i as f64 - 0.2,
            };
            let a = p.inverse_matrix();
            let b = p.matrix().inverse();
            let identity = a * p.matrix();
            for c in 0..3 {
                let err = (a.col(c) - b.col(c)).abs().max_element()
                    / b.col(c).abs().max_element().max(1.0);
                assert!(err < 1e-12, "{p:?}: {a:?} vs {b:?}");
                let e = identity.col(c) - DMat3::IDENTITY.col(c);
                assert!(e.abs().max_element() < 1e-12, "{identity:?}");
            }
        }
    }
}
