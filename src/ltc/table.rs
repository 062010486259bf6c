//! The fitted GGX LTC table: binary format, loading and bilinear lookup.
//!
//! Layout (little-endian, documented in `data/README.md`):
//! a 40-byte header — magic `LTCG`, version, n_alpha, n_theta,
//! floats_per_entry, alpha parameterisation id, theta parameterisation id,
//! alpha_min, cos_theta_min (the clamp used while fitting), reserved — then
//! n_theta × n_alpha entries of `floats_per_entry` f32, theta-major:
//! entry (i_alpha, j_theta) starts at float (j_theta·n_alpha + i_alpha)·F.
//!
//! Parameterisations (chosen so that resolution follows the function):
//! - α is log-spaced, α_i = α_min^(1 − i/(n−1)): the lobe width scales with
//!   α, so equal ratios need equal spacing down to α_min = 1e-4;
//! - θ_o follows Heitz: x_j = j/(n−1) = √(1 − cos θ_o), which packs rows
//!   towards grazing angles where the fit changes fastest.
//!
//! Lookups outside the grid clamp to its edges (α < α_min behaves as α_min,
//! a grazing or back-facing ω_o as the last row).

use super::lobe::LtcParams;

pub const MAGIC: [u8; 4] = *b"LTCG";
pub const VERSION: u32 = 1;
pub const HEADER_BYTES: usize = 40;
/// m11, m22, m13, θ_avg, albedo ρ, Schlick-weighted albedo ρ5.
pub const FLOATS_PER_ENTRY: usize = 6;
pub const ALPHA_PARAM_LOG: u32 = 1;
pub const THETA_PARAM_SQRT_ONE_MINUS_COS: u32 = 1;

/// One table entry (or a bilinear blend of four).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LtcEntry {
    pub m11: f32,
    pub m22: f32,
    pub m13: f32,
    pub theta_avg: f32,
    /// Directional albedo of GGX·cos with Fresnel 1.
    pub albedo: f32,
    /// ∫ f·cos·(1 − ω_o·h)^5: with Schlick's Fresnel F0 the albedo is
    /// F0·ρ + (1 − F0)·ρ5.
    pub albedo_schlick: f32,
}

impl LtcEntry {
    pub fn params(&self) -> LtcParams {
        LtcParams {
            m11: self.m11 as f64,
            m22: self.m22 as f64,
            m13: self.m13 as f64,
            theta_avg: self.theta_avg as f64,
        }
    }
}

#[derive(Clone, Debug)]
pub struct LtcTable {
    pub n_alpha: usize,
    pub n_theta: usize,
    pub alpha_min: f32,
    pub cos_theta_min: f32,
    data: Vec<f32>,
}

/// α of grid column i.
pub fn alpha_of_index(i: usize, n: usize, alpha_min: f64) -> f64 {
    alpha_min.powf(1.0 - i as f64 / (n - 1) as f64)
}

/// cos θ_o of grid row j.
pub fn cos_theta_of_index(j: usize, n: usize) -> f64 {
    let x = j as f64 / (n - 1) as f64;
    1.0 - x * x
}

impl LtcTable {
    pub fn new(
        n_alpha: usize,
        n_theta: usize,
        alpha_min: f32,
        cos_theta_min: f32,
        data: Vec<f32>,
    ) -> Result<Self, String> {
        if n_alpha < 2 || n_theta < 2 {
            return Err(format!("table too small: {n_alpha}×{n_theta}"));
        }
        if data.len() != n_alpha * n_theta * FLOATS_PER_ENTRY {
            return Err(format!(
                "table has {} floats, expected {}",
                data.len(),
                n_alpha * n_theta * FLOATS_PER_ENTRY
            ));
        }
        if !(alpha_min > 0.0 && alpha_min < 1.0) {
            return Err(format!("alpha_min {alpha_min} out of (0, 1)"));
        }
        if data.iter().any(|v| !v.is_finite()) {
            return Err("table holds a non-finite value".into());
        }
        Ok(LtcTable {
            n_alpha,
            n_theta,
            alpha_min,
            cos_theta_min,
            data,
        })
    }

    /// The table committed under `data/`, embedded in the binary.
    pub fn load_default() -> Result<Self, String> {
        Self::from_bytes(include_bytes!("../../data/ltc_ggx.bin"))
    }

    pub fn from_bytes(bytes: &[u8]) -> Result<Self, String> {
        if bytes.len() < HEADER_BYTES || bytes[0..4] != MAGIC {
            return Err("not an LTC table (bad magic)".into());
        }
        let u32_at = |k: usize| u32::from_le_bytes(bytes[4 * k..4 * k + 4].try_into().unwrap());
        let f32_at = |k: usize| f32::from_le_bytes(bytes[4 * k..4 * k + 4].try_into().unwrap());
        let version = u32_at(1);
        if version != VERSION {
            return Err(format!("unsupported LTC table version {version}"));
        }
        let (n_alpha, n_theta, fpe) = (u32_at(2) as usize, u32_at(3) as usize, u32_at(4) as usize);
        if fpe != FLOATS_PER_ENTRY {
            return Err(format!("unsupported floats per entry {fpe}"));
        }
        if u32_at(5) != ALPHA_PARAM_LOG || u32_at(6) != THETA_PARAM_SQRT_ONE_MINUS_COS {
            return Err("unsupported table parameterisation".into());
        }
        let (alpha_min, cos_theta_min) = (f32_at(7), f32_at(8));
        let n = n_alpha * n_theta * fpe;
        if bytes.len() != HEADER_BYTES + 4 * n {
            return Err(format!(
                "LTC table is {} bytes, expected {}",
                bytes.len(),
                HEADER_BYTES + 4 * n
            ));
        }
        let data = bytes[HEADER_BYTES..]
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
            .collect();
        Self::new(n_alpha, n_theta, alpha_min, cos_theta_min, data)
    }

    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(HEADER_BYTES + 4 * self.data.len());
        out.extend_from_slice(&MAGIC);
        for v in [
            VERSION,
            self.n_alpha as u32,
            self.n_theta as u32,
            FLOATS_PER_ENTRY as u32,
            ALPHA_PARAM_LOG,
            THETA_PARAM_SQRT_ONE_MINUS_COS,
        ] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out.extend_from_slice(&self.alpha_min.to_le_bytes());
        out.extend_from_slice(&self.cos_theta_min.to_le_bytes());
        out.extend_from_slice(&0u32.to_le_bytes());
        for v in &self.data {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out
    }

    /// The stored entry at grid node (i_alpha, j_theta).
    pub fn entry(&self, i: usize, j: usize) -> LtcEntry {
        let k = (j * self.n_alpha + i) * FLOATS_PER_ENTRY;
        let d = &self.data[k..k + FLOATS_PER_ENTRY];
        LtcEntry {
            m11: d[0],
            m22: d[1],
            m13: d[2],
            theta_avg: d[3],
            albedo: d[4],
            albedo_schlick: d[5],
        }
    }

    /// Continuous grid coordinates of (α, cos θ_o), clamped to the grid.
    pub fn coords(&self, alpha: f32, cos_theta: f32) -> (f32, f32) {
        let a = if alpha.is_finite() {
            alpha.clamp(self.alpha_min, 1.0)
        } else {
            1.0
        };
        let c = if cos_theta.is_finite() {
            cos_theta.clamp(0.0, 1.0)
        } else {
            1.0
        };
        let s = 1.0 - a.ln() / self.alpha_min.ln();
        let x = (1.0 - c).sqrt();
        (
            (s * (self.n_alpha - 1) as f32).clamp(0.0, (self.n_alpha - 1) as f32),
            (x * (self.n_theta - 1) as f32).clamp(0.0, (self.n_theta - 1) as f32),
        )
    }

    /// Bilinear lookup; every field is interpolated independently.
    pub fn lookup(&self, alpha: f32, cos_theta: f32) -> LtcEntry {
        let (fa, ft) = self.coords(alpha, cos_theta);
        let i0 = (fa.floor() as usize).min(self.n_alpha - 2);
        let j0 = (ft.floor() as usize).min(self.n_theta - 2);
        let (wa, wt) = (fa - i0 as f32, ft - j0 as f32);
        let mut out = [0.0f32; FLOATS_PER_ENTRY];
        for (dj, wj) in [(0, 1.0 - wt), (1, wt)] {
            for (di, wi) in [(0, 1.0 - wa), (1, wa)] {
                let k = ((j0 + dj) * self.n_alpha + i0 + di) * FLOATS_PER_ENTRY;
                for (o, v) in out.iter_mut().zip(&self.data[k..k + FLOATS_PER_ENTRY]) {
                    *o += wj * wi * v;
                }
            }
        }
        LtcEntry {
            m11: out[0],
            m22: out[1],
            m13: out[2],
            theta_avg: out[3],
            albedo: out[4],
            albedo_schlick: out[5],
        }
    }
}
