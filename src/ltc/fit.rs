//! The fitter behind `ltcguide fit-ltc` (Heitz et al. 2016, §4).
//!
//! For every (α, θ_o) node it
//! 1. estimates the GGX albedo and the BRDF's average direction by VNDF
//!    sampling on a stratified grid (the average direction fixes the frame
//!    of M, as in Heitz's fitter);
//! 2. minimises, with Nelder–Mead over (ln m11, ln m22, m13/m11), the L1
//!    distance ∫|f·cos/ρ − D_ltc| dω between the *normalised* target and the
//!    LTC density. The integral is estimated with multiple importance
//!    sampling: a fixed stratified set of LTC samples and one of VNDF
//!    samples, both weighted by the balance heuristic 1/(p_ltc + p_brdf).
//!    Heitz minimises the cube of the difference; we minimise the L1 norm
//!    itself because that is the quantity guiding pays for (a density off by
//!    ε in L1 costs ε in sampling efficiency), and the one we report;
//! 3. warm-starts from the neighbouring entry: the θ_o = 0 column is fitted
//!    first, isotropically, from α = 1 down to α_min; then every α row walks
//!    from θ_o = 0 to grazing, starting each node from the previous one.
//!    Rows are independent, so they run in parallel without making the
//!    result depend on the thread count.
//!
//! The target is GGX·cos with Fresnel 1 and height-correlated Smith G2
//! (see [`super::ggx`]). The per-node L1 error is re-estimated with an
//! independent, denser sample set and written next to the table.

use super::ggx;
use super::lobe::{Ltc, LtcParams, cosine_sample};
use super::table::{FLOATS_PER_ENTRY, LtcTable, alpha_of_index, cos_theta_of_index};
use glam::{DMat3, DVec3};
use rayon::prelude::*;
use std::path::PathBuf;
use std::time::Instant;

/// Options of `ltcguide fit-ltc`.
#[derive(Clone, Debug)]
pub struct FitOptions {
    /// Directory receiving `ltc_ggx.bin` and the error summaries.
    pub out_dir: PathBuf,
    /// Nodes per axis (the paper uses 128).
    pub resolution: usize,
    /// Worker threads; 0 lets rayon decide.
    pub threads: usize,
    /// Smallest tabulated α (the table is log-spaced in α).
    pub alpha_min: f64,
    /// Samples per axis of each stratified set used inside the optimiser.
    pub fit_samples: usize,
    /// Samples per axis of the independent error estimate.
    pub eval_samples: usize,
    /// Objective evaluations per node (split over one restart).
    pub max_evals: usize,
    /// Print a line per finished α row.
    pub verbose: bool,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            out_dir: PathBuf::from("data"),
            resolution: 128,
            threads: 0,
            alpha_min: 1e-4,
            fit_samples: 24,
            eval_samples: 48,
            max_evals: 360,
            verbose: false,
        }
    }
}

#[derive(Clone, Debug)]
pub struct FitReport {
    pub table_path: PathBuf,
    pub csv_path: PathBuf,
    pub summary_path: PathBuf,
    pub seconds: f64,
    pub mean_l1: f64,
    pub median_l1: f64,
    pub p95_l1: f64,
    pub max_l1: f64,
    /// (α, θ_o in degrees) of the worst node.
    pub worst: (f64, f64),
}

/// The fitting clamp on cos θ_o: at exactly 90° GGX·cos degenerates.
pub const COS_THETA_MIN: f64 = 1e-3;

/// Result of fitting one node.
#[derive(Clone, Copy, Debug)]
pub struct NodeFit {
    pub params: LtcParams,
    /// Optimiser coordinates (ln m11, ln m22, m13/m11), for warm starts.
    pub x: [f64; 3],
    pub albedo: f64,
    pub albedo_schlick: f64,
}

/// ω_o at angle θ_o in the xz plane, on the +x side.
pub fn wo_of_cos(cos_theta: f64) -> DVec3 {
    let c = cos_theta.clamp(COS_THETA_MIN, 1.0);
    DVec3::new((1.0 - c * c).max(0.0).sqrt(), 0.0, c)
}

/// Average direction angle of GGX·cos (positive towards −x), Heitz-style.
pub fn average_direction_angle(alpha: f64, wo: DVec3, n: usize) -> f64 {
    let mut sum = DVec3::ZERO;
    let g1_inv = 1.0 + ggx::lambda(alpha, wo.z);
    for j in 0..n {
        for i in 0..n {
            let wi = ggx::sample_vndf(
                alpha,
                wo,
                (i as f64 + 0.5) / n as f64,
                (j as f64 + 0.5) / n as f64,
            );
            if wi.z > 0.0 {
                let w = g1_inv / (1.0 + ggx::lambda(alpha, wo.z) + ggx::lambda(alpha, wi.z));
                sum += w * wi;
            }
        }
    }
    (-sum.x).atan2(sum.z.max(1e-12))
}

/// MIS estimate of ∫|f·cos/ρ − D_M| dω from stratified n×n sets of LTC and
/// VNDF samples; `offset` shifts the strata so that an evaluation can be
/// independent of the sets used while fitting.
pub fn l1_error(m: DMat3, alpha: f64, wo: DVec3, albedo: f64, n: usize, offset: f64) -> f64 {
    let ltc = Ltc::new(m);
    let mut sum = 0.0;
    for j in 0..n {
        for i in 0..n {
            let u1 = ((i as f64 + offset) / n as f64).fract();
            let u2 = ((j as f64 + offset) / n as f64).fract();
            let w = ltc.sample(u1, u2);
            sum += mis_term(&ltc, alpha, wo, albedo, w);
            let w = ggx::sample_vndf(alpha, wo, u1, u2);
            sum += mis_term(&ltc, alpha, wo, albedo, w);
        }
    }
    sum / (n * n) as f64
}

fn mis_term(ltc: &Ltc, alpha: f64, wo: DVec3, albedo: f64, w: DVec3) -> f64 {
    let d = ltc.density(w);
    let p = ggx::pdf_vndf(alpha, wo, w);
    let f = ggx::eval_cos(alpha, wo, w) / albedo;
    if d + p > 0.0 {
        (f - d).abs() / (d + p)
    } else {
        0.0
    }
}

/// The objective of one node with its fixed sample sets.
struct Objective {
    alpha: f64,
    wo: DVec3,
    albedo: f64,
    theta_avg: f64,
    isotropic: bool,
    /// Cosine-space samples (fixed); mapped through M at every evaluation.
    cosine: Vec<DVec3>,
    /// VNDF samples with their normalised target value and density.
    brdf: Vec<(DVec3, f64, f64)>,
}

impl Objective {
    fn new(alpha: f64, wo: DVec3, albedo: f64, theta_avg: f64, isotropic: bool, n: usize) -> Self {
        let mut cosine = Vec::with_capacity(n * n);
        let mut brdf = Vec::with_capacity(n * n);
        for j in 0..n {
            for i in 0..n {
                let (u1, u2) = ((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
                cosine.push(cosine_sample(u1, u2));
                let wi = ggx::sample_vndf(alpha, wo, u1, u2);
                brdf.push((
                    wi,
                    ggx::eval_cos(alpha, wo, wi) / albedo,
                    ggx::pdf_vndf(alpha, wo, wi),
                ));
            }
        }
        Objective {
            alpha,
            wo,
            albedo,
            theta_avg,
            isotropic,
            cosine,
            brdf,
        }
    }

    fn params(&self, x: &[f64; 3]) -> LtcParams {
        let m11 = x[0].clamp(-30.0, 3.0).exp();
        if self.isotropic {
            LtcParams {
                m11,
                m22: m11,
                m13: 0.0,
                theta_avg: 0.0,
            }
        } else {
            LtcParams {
                m11,
                m22: x[1].clamp(-30.0, 3.0).exp(),
                m13: x[2] * m11,
                theta_avg: self.theta_avg,
            }
        }
    }

    fn eval(&self, x: &[f64; 3]) -> f64 {
        let ltc = Ltc::new(self.params(x).matrix());
        if !ltc.det_m_inv.is_finite() {
            return f64::INFINITY;
        }
        let mut sum = 0.0;
        for &c in &self.cosine {
            let w = (ltc.m * c).normalize();
            let d = ltc.density_of_cosine_sample(c);
            let f = ggx::eval_cos(self.alpha, self.wo, w) / self.albedo;
            let p = ggx::pdf_vndf(self.alpha, self.wo, w);
            if d + p > 0.0 {
                sum += (f - d).abs() / (d + p);
            }
        }
        for &(w, f, p) in &self.brdf {
            let d = ltc.density(w);
            if d + p > 0.0 {
                sum += (f - d).abs() / (d + p);
            }
        }
        let e = sum / self.cosine.len() as f64;
        if e.is_finite() { e } else { f64::INFINITY }
    }
}

/// Nelder–Mead on the first `dim` coordinates; returns (best x, best f).
pub fn nelder_mead(
    f: impl Fn(&[f64; 3]) -> f64,
    start: [f64; 3],
    step: [f64; 3],
    dim: usize,
    max_evals: usize,
    tol: f64,
) -> ([f64; 3], f64) {
    let mut simplex: Vec<([f64; 3], f64)> = Vec::with_capacity(dim + 1);
    simplex.push((start, f(&start)));
    for k in 0..dim {
        let mut x = start;
        x[k] += step[k];
        simplex.push((x, f(&x)));
    }
    let mut evals = dim + 1;
    let lerp = |a: &[f64; 3], b: &[f64; 3], t: f64| {
        let mut r = *a;
        for k in 0..3 {
            r[k] = a[k] + t * (b[k] - a[k]);
        }
        r
    };
    while evals < max_evals {
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        let (best, worst) = (simplex[0].1, simplex[dim].1);
        if (worst - best).abs() <= tol * (best.abs() + 1e-12) {
            break;
        }
        let mut centroid = [0.0; 3];
        for (x, _) in &simplex[..dim] {
            for k in 0..3 {
                centroid[k] += x[k] / dim as f64;
            }
        }
        let xw = simplex[dim].0;
        let xr = lerp(&centroid, &xw, -1.0);
        let fr = f(&xr);
        evals += 1;
        if fr < best {
            let xe = lerp(&centroid, &xw, -2.0);
            let fe = f(&xe);
            evals += 1;
            simplex[dim] = if fe < fr { (xe, fe) } else { (xr, fr) };
        } else if fr < simplex[dim - 1].1 {
            simplex[dim] = (xr, fr);
        } else {
            let (xc, fc) = if fr < worst {
                let xc = lerp(&centroid, &xr, 0.5);
                (xc, f(&xc))
            } else {
                let xc = lerp(&centroid, &xw, 0.5);
                (xc, f(&xc))
            };
            evals += 1;
            if fc < worst.min(fr) {
                simplex[dim] = (xc, fc);
            } else {
                let x0 = simplex[0].0;
                for s in simplex.iter_mut().skip(1) {
                    s.0 = lerp(&x0, &s.0, 0.5);
                    s.1 = f(&s.0);
                }
                evals += dim;
            }
        }
    }
    simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
    (simplex[0].0, simplex[0].1)
}

/// Fits one node, warm-started from `start` (optimiser coordinates).
pub fn fit_node(alpha: f64, cos_theta: f64, start: [f64; 3], opts: &FitOptions) -> NodeFit {
    let wo = wo_of_cos(cos_theta);
    let isotropic = cos_theta >= 1.0;
    let (albedo, albedo_schlick) = ggx::albedo(alpha, wo, 2 * opts.fit_samples);
    let theta_avg = if isotropic {
        0.0
    } else {
        average_direction_angle(alpha, wo, 2 * opts.fit_samples)
    };
    let obj = Objective::new(alpha, wo, albedo, theta_avg, isotropic, opts.fit_samples);
    let dim = if isotropic { 1 } else { 3 };
    let step = [0.1, 0.1, 0.1];
    let half = opts.max_evals / 2;
    let (x1, _) = nelder_mead(|x| obj.eval(x), start, step, dim, half, 1e-7);
    // One restart around the first optimum escapes most premature collapses.
    let (x, _) = nelder_mead(|x| obj.eval(x), x1, [0.03; 3], dim, half, 1e-7);
    NodeFit {
        params: obj.params(&x),
        x,
        albedo,
        albedo_schlick,
    }
}

/// Fits the whole table; returns it with the per-node independent L1 errors
/// (theta-major, like the table).
pub fn fit_table(opts: &FitOptions) -> Result<(LtcTable, Vec<f64>), String> {
    let n = opts.resolution;
    if n < 2 {
        return Err("resolution must be at least 2".into());
    }
    // θ_o = 0 column, sequential from the roughest α down (warm start).
    let mut column: Vec<NodeFit> = Vec::with_capacity(n);
    let mut start = [0.0, 0.0, 0.0];
    for i in (0..n).rev() {
        let alpha = alpha_of_index(i, n, opts.alpha_min);
        let fit = fit_node(alpha, 1.0, start, opts);
        start = [fit.x[0], fit.x[0], 0.0];
        column.push(fit);
    }
    column.reverse();
    let rows: Vec<Vec<(NodeFit, f64)>> = (0..n)
        .into_par_iter()
        // A row per job: rows differ in cost, and rayon cannot split a run
        // of rows once a thread has started it.
        .with_max_len(1)
        .map(|i| {
            let alpha = alpha_of_index(i, n, opts.alpha_min);
            let mut row = Vec::with_capacity(n);
            let mut prev = column[i];
            let mut x = [prev.x[0], prev.x[0], 0.0];
            for j in 0..n {
                let cos_theta = cos_theta_of_index(j, n);
                let fit = if j == 0 {
                    prev
                } else {
                    fit_node(alpha, cos_theta, x, opts)
                };
                x = if j == 0 {
                    [fit.x[0], fit.x[0], 0.0]
                } else {
                    fit.x
                };
                prev = fit;
                let err = l1_error(
                    fit.params.matrix(),
                    alpha,
                    wo_of_cos(cos_theta),
                    fit.albedo,
                    opts.eval_samples,
                    0.29,
                );
                row.push((fit, err));
            }
            if opts.verbose {
                eprintln!("fit-ltc: row {i}/{n} (alpha {alpha:.3e}) done");
            }
            row
        })
        .collect();
    let mut data = vec![0.0f32; n * n * FLOATS_PER_ENTRY];
    let mut errors = vec![0.0; n * n];
    for (i, row) in rows.iter().enumerate() {
        for (j, (fit, err)) in row.iter().enumerate() {
            let k = (j * n + i) * FLOATS_PER_ENTRY;
            let p = fit.params;
            data[k..k + FLOATS_PER_ENTRY].copy_from_slice(&[
                p.m11 as f32,
                p.m22 as f32,
                p.m13 as f32,
                p.theta_avg as f32,
                fit.albedo as f32,
                fit.albedo_schlick as f32,
            ]);
            errors[j * n + i] = *err;
        }
    }
    let table = LtcTable::new(n, n, opts.alpha_min as f32, COS_THETA_MIN as f32, data)?;
    Ok((table, errors))
}

/// `ltcguide fit-ltc`: fits, writes `ltc_ggx.bin`, the per-node error CSV
/// and a text summary into `opts.out_dir`.
pub fn run_fit(opts: &FitOptions) -> Result<FitReport, String> {
    let t0 = Instant::now();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.threads)
        .build()
        .map_err(|e| e.to_string())?;
    let (table, errors) = pool.install(|| fit_table(opts))?;
    let seconds = t0.elapsed().as_secs_f64();
    let n = opts.resolution;
    std::fs::create_dir_all(&opts.out_dir).map_err(|e| e.to_string())?;
    let table_path = opts.out_dir.join("ltc_ggx.bin");
    std::fs::write(&table_path, table.to_bytes()).map_err(|e| e.to_string())?;

    let mut csv = String::from(
        "i_alpha,j_theta,alpha,theta_deg,m11,m22,m13,theta_avg,albedo,albedo_schlick,l1_error\n",
    );
    let mut worst = (0.0, 0.0);
    let mut max_l1 = 0.0f64;
    for j in 0..n {
        for i in 0..n {
            let e = table.entry(i, j);
            let alpha = alpha_of_index(i, n, opts.alpha_min);
            let theta = cos_theta_of_index(j, n).clamp(0.0, 1.0).acos().to_degrees();
            let err = errors[j * n + i];
            if err > max_l1 {
                max_l1 = err;
                worst = (alpha, theta);
            }
            csv.push_str(&format!(
                "{i},{j},{alpha:.6e},{theta:.4},{},{},{},{},{},{},{err:.6}\n",
                e.m11, e.m22, e.m13, e.theta_avg, e.albedo, e.albedo_schlick
            ));
        }
    }
    let csv_path = opts.out_dir.join("ltc_ggx_fit_errors.csv");
    std::fs::write(&csv_path, csv).map_err(|e| e.to_string())?;

    let mut sorted = errors.clone();
    sorted.sort_by(|a, b| a.total_cmp(b));
    let q = |p: f64| sorted[((sorted.len() - 1) as f64 * p).round() as usize];
    let mean_l1 = errors.iter().sum::<f64>() / errors.len() as f64;
    let threads = if opts.threads == 0 {
        rayon::current_num_threads()
    } else {
        opts.threads
    };
    let (fit_samples, max_evals, eval_samples) =
        (opts.fit_samples, opts.max_evals, opts.eval_samples);
    let (median, p95, alpha_min) = (q(0.5), q(0.95), opts.alpha_min);
    let mut summary = format!(
        "LTC fit of GGX·cos (Fresnel 1, height-correlated Smith G2)\n\
         grid {n}x{n}: alpha log-spaced in [{alpha_min:.0e}, 1], theta_o with sqrt(1-cos) uniform in [0, 1]\n\
         fit samples {fit_samples}^2 LTC + {fit_samples}^2 VNDF per objective, <= {max_evals} evaluations per node\n\
         error = MIS estimate of the integral of |f cos/albedo - D_ltc| with an independent {eval_samples}^2 + {eval_samples}^2 set (0 = perfect, 2 = disjoint)\n\
         fit time {seconds:.1} s on {threads} threads\n\
         L1 mean {mean_l1:.4}, median {median:.4}, p95 {p95:.4}, max {max_l1:.4} at alpha {:.3e}, theta_o {:.2} deg\n\n",
        worst.0, worst.1,
    );
    summary.push_str("mean L1 error by alpha band (rows) and theta_o band (columns):\n");
    let bands = 8;
    summary.push_str("alpha \\ theta_o");
    for b in 0..bands {
        let j = (b * n) / bands;
        summary.push_str(&format!(
            " {:>7.1}°",
            cos_theta_of_index(j, n).clamp(0.0, 1.0).acos().to_degrees()
        ));
    }
    summary.push('\n');
    for a in 0..bands {
        let (i0, i1) = (a * n / bands, (a + 1) * n / bands);
        summary.push_str(&format!("{:>15.2e}", alpha_of_index(i0, n, opts.alpha_min)));
        for b in 0..bands {
            let (j0, j1) = (b * n / bands, (b + 1) * n / bands);
            let mut s = 0.0;
            for j in j0..j1 {
                for i in i0..i1 {
                    s += errors[j * n + i];
                }
            }
            summary.push_str(&format!(" {:>8.4}", s / ((i1 - i0) * (j1 - j0)) as f64));
        }
        summary.push('\n');
    }
    let summary_path = opts.out_dir.join("ltc_ggx_fit_summary.txt");
    std::fs::write(&summary_path, summary).map_err(|e| e.to_string())?;
    Ok(FitReport {
        table_path,
        csv_path,
        summary_path,
        seconds,
        mean_l1,
        median_l1: q(0.5),
        p95_l1: q(0.95),
        max_l1,
        worst,
    })
}
