//! Pearson's χ² goodness-of-fit test of a sampler against its own density.
//!
//! Samples are binned on the unit square; the expected count of every bin is
//! the density integrated over the bin by adaptive Simpson quadrature (so a
//! peaked density does not fool a midpoint rule); bins with too few expected
//! samples are pooled, as in Mitsuba's `chi2` module. The p-value comes from
//! the regularised incomplete gamma function.
//!
//! Directional samplers are tested through [`SphereMap`], an equal-area map
//! from the square to the sphere around a chosen axis, optionally with its
//! polar coordinate warped so that a narrow lobe around that axis spreads
//! over many bins.

use crate::math::{Frame, PI};
use glam::{DVec2, Vec2, Vec3};

/// Outcome of a test; `passed` compares `p_value` with the significance level.
#[derive(Clone, Debug)]
pub struct Chi2Outcome {
    pub statistic: f64,
    pub dof: usize,
    pub p_value: f64,
    pub passed: bool,
    /// Samples that fell outside the domain or carried a non-finite value.
    pub invalid_samples: usize,
    /// Σ expected / N: the integral of the density over the domain.
    pub pdf_integral: f64,
    pub message: String,
}

/// Test configuration.
#[derive(Clone, Copy, Debug)]
pub struct Chi2Config {
    pub res_x: usize,
    pub res_y: usize,
    pub samples: usize,
    /// Significance level before any multiple-test correction by the caller.
    pub significance: f64,
    /// Bins expecting fewer samples than this are pooled together.
    pub min_expected: f64,
}

impl Default for Chi2Config {
    fn default() -> Self {
        Chi2Config {
            res_x: 16,
            res_y: 32,
            samples: 200_000,
            significance: 0.01,
            min_expected: 5.0,
        }
    }
}

/// Runs the test on the unit square. `sample` returns a point in [0,1)² (or
/// `None` for a sampler failure, which counts as zero mass); `pdf` is the
/// density with respect to area on the square.
pub fn chi2_square(
    cfg: &Chi2Config,
    mut sample: impl FnMut() -> Option<Vec2>,
    pdf: impl Fn(DVec2) -> f64,
) -> Chi2Outcome {
    let (rx, ry) = (cfg.res_x, cfg.res_y);
    let mut observed = vec![0f64; rx * ry];
    let mut invalid = 0usize;
    for _ in 0..cfg.samples {
        match sample() {
            Some(p) if p.x.is_finite() && p.y.is_finite() => {
                if !(0.0..=1.0).contains(&p.x) || !(0.0..=1.0).contains(&p.y) {
                    invalid += 1;
                    continue;
                }
                let ix = ((p.x * rx as f32) as usize).min(rx - 1);
                let iy = ((p.y * ry as f32) as usize).min(ry - 1);
                observed[iy * rx + ix] += 1.0;
            }
            Some(_) => invalid += 1,
            None => {}
        }
    }
    let mut expected = vec![0f64; rx * ry];
    for iy in 0..ry {
        for ix in 0..rx {
            let x0 = ix as f64 / rx as f64;
            let x1 = (ix + 1) as f64 / rx as f64;
            let y0 = iy as f64 / ry as f64;
            let y1 = (iy + 1) as f64 / ry as f64;
            let integral = adaptive_simpson_2d(&pdf, x0, x1, y0, y1, 1e-7, 7);
            expected[iy * rx + ix] = integral * cfg.samples as f64;
        }
    }
    finish(cfg, &observed, &expected, invalid)
}

/// Runs the test on the unit square with known bin probabilities
/// (`expected[iy * res_x + ix]`, summing to at most 1), for densities whose
/// structure allows exact integration (e.g. piecewise-constant quadtrees
/// with cells far smaller than a quadrature rule could resolve).
pub fn chi2_square_expected(
    cfg: &Chi2Config,
    mut sample: impl FnMut() -> Option<Vec2>,
    expected: &[f64],
) -> Chi2Outcome {
    let (rx, ry) = (cfg.res_x, cfg.res_y);
    assert_eq!(expected.len(), rx * ry);
    let mut observed = vec![0f64; rx * ry];
    let mut invalid = 0usize;
    for _ in 0..cfg.samples {
        match sample() {
            Some(p)
                if p.x.is_finite()
                    && p.y.is_finite()
                    && (0.0..=1.0).contains(&p.x)
                    && (0.0..=1.0).contains(&p.y) =>
            {
                let ix = ((p.x * rx as f32) as usize).min(rx - 1);
                let iy = ((p.y * ry as f32) as usize).min(ry - 1);
                observed[iy * rx + ix] += 1.0;
            }
            Some(_) => invalid += 1,
            None => {}
        }
    }
    let expected: Vec<f64> = expected.iter().map(|p| p * cfg.samples as f64).collect();
    finish(cfg, &observed, &expected, invalid)
}

fn finish(cfg: &Chi2Config, observed: &[f64], expected: &[f64], invalid: usize) -> Chi2Outcome {
    let pdf_integral = expected.iter().sum::<f64>() / cfg.samples as f64;
    let mut order: Vec<usize> = (0..expected.len()).collect();
    order.sort_by(|&a, &b| expected[a].partial_cmp(&expected[b]).unwrap());
    let mut pooled_obs = 0.0;
    let mut pooled_exp = 0.0;
    let mut statistic = 0.0;
    let mut dof = 0usize;
    let mut message = String::new();
    for &i in &order {
        let (o, e) = (observed[i], expected[i]);
        if e <= 0.0 {
            if o > 0.0 {
                message = format!("bin {i}: {o} samples where the pdf integrates to zero");
                return Chi2Outcome {
                    statistic: f64::INFINITY,
                    dof,
                    p_value: 0.0,
                    passed: false,
                    invalid_samples: invalid,
                    pdf_integral,
                    message,
                };
            }
            continue;
        }
        if e < cfg.min_expected {
            pooled_obs += o;
            pooled_exp += e;
        } else {
            statistic += (o - e) * (o - e) / e;
            dof += 1;
        }
    }
    if pooled_exp > 0.0 {
        if pooled_exp < cfg.min_expected && dof > 0 {
            // Too little mass to stand on its own: it only adds noise.
            message.push_str("pooled low-expectation bins dropped; ");
        } else {
            statistic += (pooled_obs - pooled_exp).powi(2) / pooled_exp;
            dof += 1;
        }
    }
    let dof = dof.saturating_sub(1).max(1);
    let p_value = gamma_q(dof as f64 / 2.0, statistic / 2.0);
    let passed = p_value >= cfg.significance && invalid == 0;
    message.push_str(&format!(
        "chi2 = {statistic:.1}, dof = {dof}, p = {p_value:.4}, invalid = {invalid}, ∫pdf = {pdf_integral:.5}"
    ));
    Chi2Outcome {
        statistic,
        dof,
        p_value,
        passed,
        invalid_samples: invalid,
        pdf_integral,
        message,
    }
}

fn simpson_1d(f: &dyn Fn(f64) -> f64, a: f64, b: f64, eps: f64, depth: u32) -> f64 {
    let m = 0.5 * (a + b);
    let (fa, fm, fb) = (f(a), f(m), f(b));
    let whole = (b - a) / 6.0 * (fa + 4.0 * fm + fb);
    simpson_rec(f, a, b, fa, fm, fb, whole, eps, depth)
}

#[allow(clippy::too_many_arguments)]
fn simpson_rec(
    f: &dyn Fn(f64) -> f64,
    a: f64,
    b: f64,
    fa: f64,
    fm: f64,
    fb: f64,
    whole: f64,
    eps: f64,
    depth: u32,
) -> f64 {
    let m = 0.5 * (a + b);
    let lm = 0.5 * (a + m);
    let rm = 0.5 * (m + b);
    let (flm, frm) = (f(lm), f(rm));
    let left = (m - a) / 6.0 * (fa + 4.0 * flm + fm);
    let right = (b - m) / 6.0 * (fm + 4.0 * frm + fb);
    let delta = left + right - whole;
    if depth == 0 || delta.abs() <= 15.0 * eps {
        left + right + delta / 15.0
    } else {
        simpson_rec(f, a, m, fa, flm, fm, left, eps / 2.0, depth - 1)
            + simpson_rec(f, m, b, fm, frm, fb, right, eps / 2.0, depth - 1)
    }
}

/// Nested adaptive Simpson: each bin is first split 4×4 so that a narrow peak
/// is seen by at least one node before adaptivity takes over.
fn adaptive_simpson_2d(
    f: &dyn Fn(DVec2) -> f64,
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
    eps: f64,
    depth: u32,
) -> f64 {
    const SPLIT: usize = 4;
    let mut total = 0.0;
    for j in 0..SPLIT {
        let ya = y0 + (y1 - y0) * j as f64 / SPLIT as f64;
        let yb = y0 + (y1 - y0) * (j + 1) as f64 / SPLIT as f64;
        for i in 0..SPLIT {
            let xa = x0 + (x1 - x0) * i as f64 / SPLIT as f64;
            let xb = x0 + (x1 - x0) * (i + 1) as f64 / SPLIT as f64;
            let inner = |y: f64| simpson_1d(&|x: f64| f(DVec2::new(x, y)), xa, xb, eps, depth);
            total += simpson_1d(&inner, ya, yb, eps, depth);
        }
    }
    total
}

/// Equal-area map between the unit square and the sphere: u ↦ cos θ′ of a
/// warped polar angle around `axis`, v ↦ φ. With `sharpness = 1` the map is
/// the plain (cos θ, φ) map; larger values stretch the cap around the axis so
/// that a lobe of angular width ~1/sharpness covers many bins.
#[derive(Clone, Copy, Debug)]
pub struct SphereMap {
    pub frame: Frame,
    pub sharpness: f64,
}

impl SphereMap {
    pub fn new(axis: Vec3, sharpness: f64) -> Self {
        SphereMap {
            frame: Frame::from_normal(axis.normalize()),
            sharpness: sharpness.max(1.0),
        }
    }

    // s = (1 - cos θ)/2 ∈ [0,1] is uniform in solid angle; u = s^(1/k) spreads
    // small s (near the axis) over more of the square.
    fn u_of_s(&self, s: f64) -> f64 {
        s.max(0.0).powf(1.0 / self.sharpness)
    }

    /// Square coordinates of a world direction.
    pub fn to_square(&self, d: Vec3) -> Vec2 {
        let l = self.frame.to_local(d).as_dvec3();
        let l = l / l.length();
        // (1 − cos θ)/2 cancels catastrophically near the axis; on the upper
        // half use the equivalent r²/(2(1 + z)), which does not.
        let r2 = l.x * l.x + l.y * l.y;
        let s = if l.z > 0.0 {
            r2 / (2.0 * (1.0 + l.z))
        } else {
            0.5 * (1.0 - l.z)
        };
        let mut phi = l.y.atan2(l.x);
        if phi < 0.0 {
            phi += 2.0 * std::f64::consts::PI;
        }
        Vec2::new(
            self.u_of_s(s) as f32,
            (phi / (2.0 * std::f64::consts::PI)) as f32,
        )
    }

    /// World direction and d(solid angle)/d(area on the square) at a square point.
    pub fn from_square(&self, p: DVec2) -> (Vec3, f64) {
        let k = self.sharpness;
        let s = p.x.max(0.0).powf(k);
        let ds_du = if k == 1.0 {
            1.0
        } else {
            k * p.x.max(0.0).powf(k - 1.0)
        };
        let cos_t = 1.0 - 2.0 * s;
        let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
        let phi = 2.0 * std::f64::consts::PI * p.y;
        let local = glam::DVec3::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t);
        let world = self.frame.to_world(local.as_vec3());
        // dω = dcosθ dφ = 2 ds · 2π dv
        (world, 4.0 * std::f64::consts::PI * ds_du)
    }
}

/// χ² test of a directional sampler. `sample` returns a unit world direction
/// (or `None`), `pdf` the solid-angle density of a direction.
pub fn chi2_sphere(
    cfg: &Chi2Config,
    map: &SphereMap,
    mut sample: impl FnMut() -> Option<Vec3>,
    pdf: impl Fn(Vec3) -> f64,
) -> Chi2Outcome {
    chi2_square(
        cfg,
        || sample().map(|d| map.to_square(d)),
        |p| {
            let (d, jac) = map.from_square(p);
            pdf(d) * jac
        },
    )
}

/// ln Γ(x) for x > 0 (Lanczos, g = 7, n = 9).
pub fn ln_gamma(x: f64) -> f64 {
    const G: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        return (PI as f64 / (PI as f64 * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = G[0];
    let t = x + 7.5;
    for (i, g) in G.iter().enumerate().skip(1) {
        a += g / (x + i as f64);
    }
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// Regularised upper incomplete gamma Q(a, x) = Γ(a, x)/Γ(a): the χ² survival
/// function is Q(dof/2, χ²/2).
pub fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    if !x.is_finite() {
        return 0.0;
    }
    if x < a + 1.0 {
        // series for P
        let mut sum = 1.0 / a;
        let mut term = sum;
        let mut ap = a;
        for _ in 0..10_000 {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * 1e-15 {
                break;
            }
        }
        let p = sum * (-x + a * x.ln() - ln_gamma(a)).exp();
        (1.0 - p).clamp(0.0, 1.0)
    } else {
        // Lentz continued fraction for Q
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let delta = d * c;
            h *= delta;
            if (delta - 1.0).abs() < 1e-15 {
                break;
            }
        }
        (h * (-x + a * x.ln() - ln_gamma(a)).exp()).clamp(0.0, 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{Rng, cosine_hemisphere_pdf, square_to_cosine_hemisphere};

    #[test]
    fn gamma_q_matches_known_values() {
        // χ² survival: dof 2 → exp(-x/2)
        for x in [0.5f64, 2.0, 10.0] {
            assert!((gamma_q(1.0, x / 2.0) - (-x / 2.0).exp()).abs() < 1e-12);
        }
        // dof 10, χ² = 18.307 is the 5% critical value
        assert!((gamma_q(5.0, 18.307 / 2.0) - 0.05).abs() < 1e-4);
        assert!((ln_gamma(5.0) - 24f64.ln()).abs() < 1e-12);
    }

    #[test]
    fn accepts_a_correct_sampler_and_rejects_a_wrong_one() {
        let cfg = Chi2Config::default();
        let map = SphereMap::new(Vec3::Z, 1.0);
        let mut rng = Rng::new(3, 0);
        let good = chi2_sphere(
            &cfg,
            &map,
            || Some(square_to_cosine_hemisphere(rng.next_2d())),
            |d| cosine_hemisphere_pdf(d.z) as f64,
        );
        assert!(good.passed, "{}", good.message);
        assert!((good.pdf_integral - 1.0).abs() < 1e-3, "{}", good.message);
        // Claim a uniform hemisphere pdf for a cosine sampler.
        let bad = chi2_sphere(
            &cfg,
            &map,
            || Some(square_to_cosine_hemisphere(rng.next_2d())),
            |d| {
                if d.z > 0.0 {
                    1.0 / (2.0 * PI as f64)
                } else {
                    0.0
                }
            },
        );
        assert!(!bad.passed, "{}", bad.message);
    }

    #[test]
    fn sharpened_map_resolves_a_narrow_lobe() {
        // A narrow Phong-like lobe around an oblique axis, sampled exactly.
        let axis = Vec3::new(0.3, -0.2, 0.9).normalize();
        let n = 2000.0f64;
        let map = SphereMap::new(axis, 6.0);
        let frame = Frame::from_normal(axis);
        let mut rng = Rng::new(5, 0);
        let out = chi2_sphere(
            &Chi2Config::default(),
            &map,
            || {
                let u = rng.next_2d();
                let cos_t = (u.x as f64).powf(1.0 / (n + 1.0));
                Some(frame.to_world(crate::math::spherical_direction(
                    cos_t as f32,
                    2.0 * PI * u.y,
                )))
            },
            |d| {
                let c = (d.dot(axis) as f64).max(0.0);
                (n + 1.0) / (2.0 * std::f64::consts::PI) * c.powf(n)
            },
        );
        assert!(out.passed, "{}", out.message);
    }
}
