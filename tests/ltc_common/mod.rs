//! Shared helpers of the LTC tests: shading points and an independent Monte
//! Carlo integrator over the *true* cylindrical cells.
#![allow(dead_code)]

use glam::{DMat3, DVec3, Vec3};
use ltcguide::bsdf::{GgxLobe, Lobes};
use ltcguide::directional::Cell;
use ltcguide::ltc::children::{LtcOptions, ShadingLtc};
use ltcguide::ltc::table::LtcTable;
use ltcguide::math::Frame;
use ltcguide::sampling::Rng;
use std::f64::consts::PI;
use std::sync::OnceLock;

pub fn table() -> &'static LtcTable {
    static T: OnceLock<LtcTable> = OnceLock::new();
    T.get_or_init(|| LtcTable::load_default().expect("embedded LTC table"))
}

pub fn lobes(diffuse: f32, ggx_weight: f32, alpha: f32, side: f32) -> Lobes {
    Lobes {
        diffuse,
        ggx: [GgxLobe {
            weight: ggx_weight,
            alpha,
        }],
        ggx_count: if ggx_weight > 0.0 { 1 } else { 0 },
        delta: 0.0,
        side,
    }
}

/// A shading normal that is aligned with nothing in the quadtree.
pub fn tilted_frame() -> Frame {
    Frame::from_normal(Vec3::new(0.3, -0.5, 0.8).normalize())
}

pub fn wo_at(theta_o_deg: f64) -> Vec3 {
    let t = theta_o_deg.to_radians();
    let phi = 0.7f64;
    Vec3::new(
        (t.sin() * phi.cos()) as f32,
        (t.sin() * phi.sin()) as f32,
        t.cos() as f32,
    )
}

/// `alpha = None` builds a pure diffuse shading point.
pub fn shading(
    alpha: Option<f32>,
    theta_o_deg: f64,
    frame: &Frame,
    opts: &LtcOptions,
) -> ShadingLtc {
    let l = match alpha {
        None => lobes(1.0, 0.0, 1.0, 1.0),
        Some(a) => lobes(0.0, 1.0, a, 1.0),
    };
    ShadingLtc::new(&l, frame, wo_at(theta_o_deg), table(), opts)
}

/// Options that keep every GGX lobe glossy (for tests of the LTC path at α = 1).
pub fn all_glossy() -> LtcOptions {
    LtcOptions {
        rough_as_diffuse_above: 10.0,
        ..LtcOptions::default()
    }
}

/// One normalised lobe of the mixture in f64: world → cosine-space map.
#[derive(Clone, Copy)]
pub struct Lobe64 {
    pub weight: f64,
    pub a: DMat3,
    pub a_inv: DMat3,
    pub det: f64,
}

impl Lobe64 {
    pub fn density(&self, w: DVec3) -> f64 {
        let p = self.a * w;
        let l2 = p.length_squared();
        if l2 <= 0.0 {
            return 0.0;
        }
        p.z.max(0.0) * self.det / (PI * l2 * l2)
    }
    pub fn sample(&self, rng: &mut Rng) -> DVec3 {
        let (u1, u2) = (rng.next_f64(), rng.next_f64());
        let r = u1.sqrt();
        let phi = 2.0 * PI * u2;
        let c = DVec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u1).max(0.0).sqrt());
        (self.a_inv * c).normalize()
    }
    pub fn peak(&self) -> DVec3 {
        (self.a_inv * DVec3::Z).normalize()
    }
}

pub fn lobes64(s: &ShadingLtc) -> Vec<Lobe64> {
    let mut out = Vec::new();
    if s.diffuse_weight > 0.0 {
        let f = Frame::from_normal(s.normal);
        let a = DMat3::from_cols(f.s.as_dvec3(), f.t.as_dvec3(), f.n.as_dvec3()).transpose();
        out.push(Lobe64 {
            weight: s.diffuse_weight as f64,
            a,
            a_inv: a.inverse(),
            det: a.determinant().abs(),
        });
    }
    for g in &s.glossy[..s.glossy_count] {
        out.push(Lobe64 {
            weight: g.weight as f64,
            a: g.a64,
            a_inv: g.a64.inverse(),
            det: g.a64.determinant().abs(),
        });
    }
    out
}

pub fn dir_of(u: f64, v: f64) -> DVec3 {
    let z = 2.0 * u - 1.0;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * v;
    DVec3::new(r * phi.cos(), r * phi.sin(), z)
}

pub fn square_of(d: DVec3) -> (f64, f64) {
    let u = ((d.z.clamp(-1.0, 1.0) + 1.0) * 0.5).clamp(0.0, 1.0);
    let mut phi = d.y.atan2(d.x);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    let v = phi / (2.0 * PI);
    (u, if v >= 1.0 { 0.0 } else { v })
}

pub fn cell_containing(d: DVec3, depth: u32) -> Cell {
    let (u, v) = square_of(d);
    let n = (1u64 << depth) as f64;
    let clampi = |x: f64| (x * n).floor().clamp(0.0, n - 1.0) as u32;
    Cell {
        depth,
        ix: clampi(u),
        iy: clampi(v),
    }
}

/// Unbiased MC estimate of ∫_{child k} mixture for the 4 children of `cell`,
/// with its standard error: per lobe, `n_lobe` samples of the lobe and
/// `n_cell` uniform samples in each true child, combined by the balance
/// heuristic.
pub fn mc_children(
    s: &ShadingLtc,
    cell: Cell,
    n_lobe: usize,
    n_cell: usize,
    rng: &mut Rng,
) -> ([f64; 4], [f64; 4]) {
    let mut est = [0.0; 4];
    let mut var = [0.0; 4];
    let omega = cell.child(0).solid_angle();
    let (u0, v0, size) = cell.child(0).square_bounds();
    let _ = (u0, v0);
    for lobe in lobes64(s) {
        let mut sum = [0.0; 4];
        let mut sum2 = [0.0; 4];
        let (nl, nc) = (n_lobe as f64, n_cell as f64);
        for _ in 0..n_lobe {
            let w = lobe.sample(rng);
            let (u, v) = square_of(w);
            let cu = ((u * (1u64 << (cell.depth + 1)) as f64).floor() as i64) - 2 * cell.ix as i64;
            let cv = ((v * (1u64 << (cell.depth + 1)) as f64).floor() as i64) - 2 * cell.iy as i64;
            if (0..2).contains(&cu) && (0..2).contains(&cv) {
                let k = (cu + 2 * cv) as usize;
                let d = lobe.density(w);
                let t = d / (nl * d + nc / omega);
                sum[k] += t;
                sum2[k] += t * t;
            }
        }
        for k in 0..4 {
            let (cu0, cv0, _) = cell.child(k).square_bounds();
            for _ in 0..n_cell {
                let w = dir_of(cu0 + size * rng.next_f64(), cv0 + size * rng.next_f64());
                let d = lobe.density(w);
                let t = d / (nl * d + nc / omega);
                sum[k] += t;
                sum2[k] += t * t;
            }
            est[k] += lobe.weight * sum[k];
            // Variance of a sum of two sample means, each term bounded by
            // its own second moment (a slight over-estimate).
            var[k] += lobe.weight * lobe.weight * sum2[k];
        }
    }
    (est, var.map(f64::sqrt))
}

/// The peak direction of the dominant lobe.
pub fn peak(s: &ShadingLtc) -> DVec3 {
    let l = lobes64(s);
    l.iter()
        .max_by(|a, b| a.weight.total_cmp(&b.weight))
        .map(|l| l.peak())
        .unwrap_or(DVec3::Z)
}

/// A shading frame around a random normal (uniform in a cube, normalised:
/// not uniform on the sphere, which these tests do not need).
pub fn random_frame(rng: &mut Rng) -> Frame {
    let n = Vec3::new(
        rng.next_f32() - 0.5,
        rng.next_f32() - 0.5,
        rng.next_f32() - 0.5,
    )
    .normalize();
    Frame::from_normal(n)
}
