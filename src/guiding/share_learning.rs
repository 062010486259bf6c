//! The radiance share β learned per spatial leaf, alongside the BSDF
//! fraction α (`super::adam`) and under the same loss.
//!
//! At a product-weighted vertex the renderer samples the nested mixture
//!   p = α·p_bsdf + (1 − α)·[(1 − β)·p_product + β·p_radiance]
//! (`super::defensive`). A fixed β trades the product's gain where its
//! lobe is right against its loss where the tree's blurred radiance hides
//! a small light inside a cell (docs/results-reading.md, session 52): the
//! best β differs from leaf to leaf, so each leaf learns its own.
//!
//! β = sigmoid(θ_β), and θ_β follows Adam on the same KL divergence
//! D_KL(F ‖ p) that α minimises. Only p depends on β, so
//!   ∂D_KL/∂β = −∫ F · (∂p/∂β)/p dω = −∫ F · (1 − α)(p_radiance − p_product)/p dω,
//! estimated from one sample ω drawn from the mixture actually used as
//!   −(F(ω)/p_used(ω)) · (1 − α)(p_radiance(ω) − p_product(ω)) / p(ω),
//! with α, β the current values in p (as for α: the samples of a call are
//! learned from after it, while θ moves), and dβ/dθ = β(1 − β). The
//! normalisation of F is the BSDF fraction's running ∫F, so both learn at
//! the same scale.
//!
//! The KL divergence weighs a direction by F, the estimator's variance by
//! F²/p: a light the product's lobe misses inside a blurred cell is a rare
//! sample of large F/p, which the variance counts and the KL hardly does.
//! So β may instead follow the gradient of the second moment ∫F²/p dω,
//!   ∂/∂β ∫ F²/p dω = −∫ F² · (∂p/∂β)/p² dω,
//! whose one-sample estimate is the KL's times F(ω)/p(ω)
//! ([`ShareLearning::Variance`]; Rath et al. 2020 learn their fraction so).
//! It is normalised by the square of the running ∫F.
//!
//! Adam, which bounds each sample's step, follows a heavy-tailed gradient
//! poorly: the rare large-F/p samples that carry the case for a share move
//! θ_β by about as much as one of the many ordinary samples that favour
//! the product. [`ShareLearning::VarianceGrid`] therefore skips the
//! gradient: for every share β_k of a small grid it sums the unbiased
//! estimate (F/p_used)²·p_used/p_k of ∫F²/p_k over all the leaf's
//! training samples, and takes the least.
//!
//! The L2 term pulls θ_β towards the starting share's logit, not towards
//! ½: the starting share is what measured best without learning, and a
//! leaf with few samples should stay there.
//!
//! β is kept in [`SHARE_MIN`, `SHARE_MAX`] (the gradient flows through
//! the clamp, as for α): below, a leaf whose product looked right in
//! training would lose the defensive bound that motivates the share;
//! above, the product would no longer be sampled.

use super::adam::{AdamConfig, AdamMoments, AdamStats, NonFiniteGradient, sigmoid, sigmoid_f32};
use super::moment_grid::SecondMomentGrid;

/// Smallest learned share: the product's pdf then stays at least 5 % of
/// radiance guiding's, as α_min keeps 5 % of the BSDF's.
pub const SHARE_MIN: f32 = 0.05;
/// Largest learned share.
pub const SHARE_MAX: f32 = 0.95;

/// How a leaf learns its share.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
pub enum ShareLearning {
    /// Adam on D_KL(F ‖ p), as the BSDF fraction.
    #[default]
    Kl,
    /// Adam on the estimator's second moment ∫F²/p.
    Variance,
    /// The share of [`SHARE_GRID`] whose second moment, estimated from
    /// all the leaf's training samples so far, is least.
    VarianceGrid,
}

/// The shares [`ShareLearning::VarianceGrid`] chooses from.
pub const SHARE_GRID: [f32; 8] = [0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.7, 0.9];

/// One leaf's learned radiance share.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LearnedShare {
    theta: f64,
    /// The logit the L2 term pulls towards (the starting share's).
    prior: f64,
    /// sigmoid(θ) clamped to the bounds, read by every product vertex.
    share: f32,
    moments: AdamMoments,
    /// The second moment per share of [`SHARE_GRID`]
    /// ([`ShareLearning::VarianceGrid`]).
    grid: SecondMomentGrid<{ SHARE_GRID.len() }>,
}

fn logit(p: f32) -> f64 {
    let p = p.clamp(SHARE_MIN, SHARE_MAX) as f64;
    (p / (1.0 - p)).ln()
}

impl LearnedShare {
    /// A fresh state at the share `start` (brought into the bounds).
    pub fn starting_at(start: f32) -> Self {
        let theta = logit(start);
        LearnedShare {
            theta,
            prior: theta,
            share: clamp_share(sigmoid_f32(theta as f32)),
            moments: AdamMoments::default(),
            grid: SecondMomentGrid::default(),
        }
    }

    #[inline]
    pub fn share(&self) -> f32 {
        self.share
    }

    pub fn theta(&self) -> f64 {
        self.theta
    }

    /// Adam steps taken, or samples summed for the grid.
    pub fn steps(&self) -> u64 {
        self.moments.steps() + self.grid.samples()
    }

    /// The grid's estimates of ∫F²/p_k (unnormalised), once it has samples.
    pub fn grid_second_moments(&self) -> Option<[f64; SHARE_GRID.len()]> {
        self.grid.second_moments()
    }

    /// Adds one recorded sample of a vertex that mixed to the grid's sums,
    /// each share's mixture taken at the leaf's current α; a sample with
    /// a non-finite term, or whose mixture pdf is not positive, is refused
    /// and counted.
    pub fn add_to_grid(
        &mut self,
        sample: &ShareSample,
        alpha_now: f32,
        stats: &mut AdamStats,
    ) -> Result<(), NonFiniteGradient> {
        let usable = sample.is_finite()
            && alpha_now.is_finite()
            && sample.share_used > 0.0
            && sample.share_used < 1.0;
        let a = alpha_now as f64;
        let added = usable
            && self
                .grid
                .add(sample.product as f64, sample.used_pdf(), |k| {
                    a * sample.bsdf_pdf as f64 + (1.0 - a) * sample.guide_pdf_at(SHARE_GRID[k])
                });
        if !added {
            stats.rejected_non_finite += 1;
            return Err(NonFiniteGradient);
        }
        stats.steps += 1;
        Ok(())
    }

    /// Takes the grid's share of least estimated second moment, once the
    /// leaf has [`super::moment_grid::GRID_MIN_SAMPLES`]; the first of
    /// equals.
    pub fn choose_from_grid(&mut self) {
        if let Some(best) = self.grid.least() {
            self.share = SHARE_GRID[best];
            self.theta = logit(self.share);
        }
    }

    /// One Adam step on one recorded sample of a vertex that mixed, at the
    /// leaf's current α. `normaliser` is the leaf's running ∫F
    /// ([`super::adam::BsdfFraction::product_mean`]).
    pub fn step_sample(
        &mut self,
        cfg: &AdamConfig,
        loss: ShareLearning,
        sample: &ShareSample,
        alpha_now: f32,
        normaliser: Option<f64>,
        stats: &mut AdamStats,
    ) -> Result<(), NonFiniteGradient> {
        let Some(g) = share_gradient_theta(loss, self.theta, self.share, alpha_now, sample) else {
            stats.rejected_non_finite += 1;
            return Err(NonFiniteGradient);
        };
        let g = match (normaliser, loss) {
            (Some(mean), ShareLearning::Kl) if mean > 0.0 => g / mean,
            (Some(mean), ShareLearning::Variance) if mean > 0.0 => g / (mean * mean),
            _ => g,
        };
        let g = g + cfg.l2 * (self.theta - self.prior);
        self.theta = self.moments.step(cfg, self.theta, g, stats)?;
        self.share = clamp_share(sigmoid_f32(self.theta as f32));
        Ok(())
    }
}

fn clamp_share(s: f32) -> f32 {
    s.clamp(SHARE_MIN, SHARE_MAX)
}

/// What a recorded sample tells the share.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShareSample {
    /// F(ω)/p_used(ω).
    pub product: f32,
    pub bsdf_pdf: f32,
    /// The guide's mixture pdf at the share used.
    pub guide_pdf: f32,
    /// The radiance descent's pdf.
    pub radiance_pdf: f32,
    pub share_used: f32,
    pub alpha_used: f32,
}

impl ShareSample {
    /// The product descent's pdf, recovered from the mixture the guide
    /// returned: (p_guide − β·p_radiance)/(1 − β), in f64. Where the
    /// product's part is tiny against β·p_radiance this cancels, but its
    /// absolute error stays at f32 rounding of p_guide, which is all the
    /// gradient's difference p_radiance − p_product resolves anyway.
    pub fn product_pdf(&self) -> f64 {
        let b = self.share_used as f64;
        ((self.guide_pdf as f64 - b * self.radiance_pdf as f64) / (1.0 - b)).max(0.0)
    }

    fn is_finite(&self) -> bool {
        [
            self.product,
            self.bsdf_pdf,
            self.guide_pdf,
            self.radiance_pdf,
            self.share_used,
            self.alpha_used,
        ]
        .iter()
        .all(|x| x.is_finite())
    }

    /// The whole mixture's pdf the sample was drawn from.
    pub fn used_pdf(&self) -> f64 {
        let a = self.alpha_used as f64;
        a * self.bsdf_pdf as f64 + (1.0 - a) * self.guide_pdf as f64
    }

    /// The guide's mixture pdf at another share.
    pub fn guide_pdf_at(&self, share: f32) -> f64 {
        let b = share as f64;
        (1.0 - b) * self.product_pdf() + b * self.radiance_pdf as f64
    }
}

/// The loss's ∂/∂θ_β from one sample (see the module docs) at logit
/// `theta`, whose clamped share is `share_now`, with the leaf's current
/// α; `None` when an input or the result is not finite, the share used is
/// outside (0, 1), or a mixture's pdf is not positive.
pub fn share_gradient_theta(
    loss: ShareLearning,
    theta: f64,
    share_now: f32,
    alpha_now: f32,
    s: &ShareSample,
) -> Option<f64> {
    if !(s.is_finite() && share_now.is_finite() && alpha_now.is_finite() && theta.is_finite()) {
        return None;
    }
    if !(s.share_used > 0.0 && s.share_used < 1.0) {
        return None;
    }
    let a = alpha_now as f64;
    let p_now = a * s.bsdf_pdf as f64 + (1.0 - a) * s.guide_pdf_at(share_now);
    let p_used = s.used_pdf();
    if !(p_now > 0.0 && p_used > 0.0) {
        return None;
    }
    let sig = sigmoid(theta);
    let dp_dbeta = (1.0 - a) * (s.radiance_pdf as f64 - s.product_pdf());
    let kl = -(s.product as f64) * dp_dbeta / p_now * (sig * (1.0 - sig));
    let g = match loss {
        ShareLearning::Kl => kl,
        // F/p_now = (F/p_used)·p_used/p_now.
        ShareLearning::Variance | ShareLearning::VarianceGrid => {
            kl * s.product as f64 * p_used / p_now
        }
    };
    (g.is_finite() && (g * g).is_finite()).then_some(g)
}

/// What the leaves learned, for `--stats-json`: over the leaves that took
/// a step, the share weighted by their steps, and its spread.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct LearnedShareSummary {
    pub steps: u64,
    pub rejected_non_finite: u64,
    pub leaves: usize,
    pub mean: f64,
    pub p10: f64,
    pub median: f64,
    pub p90: f64,
}

impl LearnedShareSummary {
    pub fn of<'a>(shares: impl Iterator<Item = &'a LearnedShare>, stats: AdamStats) -> Self {
        let mut learned: Vec<(f32, u64)> = shares
            .filter(|l| l.steps() > 0)
            .map(|l| (l.share(), l.steps()))
            .collect();
        if learned.is_empty() {
            return LearnedShareSummary {
                steps: stats.steps,
                rejected_non_finite: stats.rejected_non_finite,
                ..Default::default()
            };
        }
        learned.sort_by(|a, b| a.0.total_cmp(&b.0));
        let total: u64 = learned.iter().map(|l| l.1).sum();
        let mean = learned.iter().map(|l| l.0 as f64 * l.1 as f64).sum::<f64>() / total as f64;
        let quantile = |q: f64| learned[((learned.len() - 1) as f64 * q).round() as usize].0 as f64;
        LearnedShareSummary {
            steps: stats.steps,
            rejected_non_finite: stats.rejected_non_finite,
            leaves: learned.len(),
            mean,
            p10: quantile(0.1),
            median: quantile(0.5),
            p90: quantile(0.9),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A discrete "sphere" of four directions: the integrand and the three
    /// sampling pdfs (each sums to 1).
    const F: [f64; 4] = [0.0, 3.0, 1.0, 0.5];
    const P_BSDF: [f32; 4] = [0.4, 0.3, 0.2, 0.1];
    const P_PRODUCT: [f32; 4] = [0.1, 0.2, 0.6, 0.1];
    const P_RADIANCE: [f32; 4] = [0.1, 0.5, 0.2, 0.2];

    fn guide(share: f64, i: usize) -> f64 {
        (1.0 - share) * P_PRODUCT[i] as f64 + share * P_RADIANCE[i] as f64
    }

    fn mixture(alpha: f64, share: f64, i: usize) -> f64 {
        alpha * P_BSDF[i] as f64 + (1.0 - alpha) * guide(share, i)
    }

    /// The record of direction i, integrand `f`, drawn from the mixture
    /// at (α_used, β_used).
    fn drawn(f: f64, i: usize, alpha_used: f32, share_used: f32) -> ShareSample {
        ShareSample {
            product: (f / mixture(alpha_used as f64, share_used as f64, i)) as f32,
            bsdf_pdf: P_BSDF[i],
            guide_pdf: guide(share_used as f64, i) as f32,
            radiance_pdf: P_RADIANCE[i],
            share_used,
            alpha_used,
        }
    }

    /// Each loss as a function of θ_β, up to terms free of β.
    fn loss(kind: ShareLearning, alpha: f64, theta: f64) -> f64 {
        let share = sigmoid(theta);
        (0..4)
            .map(|i| match kind {
                ShareLearning::Kl => -F[i] * mixture(alpha, share, i).ln(),
                ShareLearning::Variance | ShareLearning::VarianceGrid => {
                    F[i] * F[i] / mixture(alpha, share, i)
                }
            })
            .sum()
    }

    /// The expectation of the one-sample gradient over directions drawn
    /// from the mixture used (α_used, β_used), evaluated at the current
    /// (α, θ_β), is the loss's derivative at (α, θ_β).
    #[test]
    fn the_one_sample_gradient_is_unbiased_for_both_losses() {
        let (alpha_used, share_used) = (0.3f32, 0.6f32);
        for kind in [ShareLearning::Kl, ShareLearning::Variance] {
            for (alpha, theta) in [(0.3f32, 0.4f64), (0.1, -1.5), (0.7, 2.0)] {
                let share_now = sigmoid(theta) as f32;
                let expected_gradient: f64 = (0..4)
                    .map(|i| {
                        let s = drawn(F[i], i, alpha_used, share_used);
                        let g = share_gradient_theta(kind, theta, share_now, alpha, &s).unwrap();
                        s.used_pdf() * g
                    })
                    .sum();
                let h = 1e-5;
                let numeric = (loss(kind, alpha as f64, theta + h)
                    - loss(kind, alpha as f64, theta - h))
                    / (2.0 * h);
                assert!(
                    (expected_gradient - numeric).abs() < 1e-4 * numeric.abs().max(1e-3),
                    "{kind:?} at α {alpha}, θ {theta}: {expected_gradient} against {numeric}"
                );
            }
        }
    }

    /// Directions drawn from the mixture used: the grid's estimate of each
    /// share's second moment agrees with the exact sum, and the share it
    /// chooses is the exact least of the grid.
    #[test]
    fn the_grid_estimates_each_shares_variance_and_takes_the_least() {
        // Light on the directions each descent favours: some of each is best.
        const F_GRID: [f64; 4] = [0.0, 2.0, 2.0, 0.5];
        let (alpha_used, share_used, alpha) = (0.3f32, 0.6f32, 0.2f32);
        let exact = SHARE_GRID.map(|b| {
            (0..4)
                .map(|i| F_GRID[i] * F_GRID[i] / mixture(alpha as f64, b as f64, i))
                .sum::<f64>()
        });
        let mut l = LearnedShare::starting_at(0.3);
        let mut stats = AdamStats::default();
        let mut rng = crate::sampling::Rng::new(7, 3);
        let n = 200_000;
        let draws = crate::sampling::Distribution1D::new(
            &[0, 1, 2, 3].map(|i| mixture(alpha_used as f64, share_used as f64, i) as f32),
        );
        for _ in 0..n {
            let (i, _, _) = draws.sample_discrete(rng.next_f32());
            l.add_to_grid(
                &drawn(F_GRID[i], i, alpha_used, share_used),
                alpha,
                &mut stats,
            )
            .unwrap();
        }
        let estimate = l.grid_second_moments().unwrap();
        let least = crate::guiding::moment_grid::assert_estimates_and_interior_least(
            &estimate,
            &exact,
            &SHARE_GRID,
        );
        l.choose_from_grid();
        assert_eq!(l.share(), SHARE_GRID[least]);
        assert_eq!(stats.steps, n);
        // Too few samples keep the starting share; a NaN is refused.
        let mut few = LearnedShare::starting_at(0.3);
        let s = sample(1.0, 3.0, 0.3);
        few.add_to_grid(&s, 0.2, &mut stats).unwrap();
        few.choose_from_grid();
        assert!((few.share() - 0.3).abs() < 1e-6);
        let mut nan = s;
        nan.product = f32::NAN;
        assert!(few.add_to_grid(&nan, 0.2, &mut stats).is_err());
        assert_eq!(stats.rejected_non_finite, 1);
    }

    fn sample(product_pdf: f32, radiance_pdf: f32, share_used: f32) -> ShareSample {
        let guide = (1.0 - share_used) * product_pdf + share_used * radiance_pdf;
        ShareSample {
            product: 1.0,
            bsdf_pdf: 0.5,
            guide_pdf: guide,
            radiance_pdf,
            share_used,
            alpha_used: 0.2,
        }
    }

    /// A sample where the radiance descent was the likelier one lowers the
    /// loss as β grows (negative gradient); unusable samples are refused.
    #[test]
    fn the_gradient_favours_the_descent_that_matches_the_integrand() {
        let s = sample(1.0, 3.0, 0.3);
        assert!((s.product_pdf() - 1.0).abs() < 1e-6);
        let (alpha, share, theta) = (0.2f32, 0.5f32, 0.0);
        for kind in [ShareLearning::Kl, ShareLearning::Variance] {
            let g = share_gradient_theta(kind, theta, share, alpha, &s).unwrap();
            assert!(g < 0.0, "{kind:?}");
            let g = share_gradient_theta(kind, theta, share, alpha, &sample(3.0, 1.0, 0.3));
            assert!(g.unwrap() > 0.0);
            assert!(
                share_gradient_theta(kind, theta, share, alpha, &sample(1.0, 1.0, 0.0)).is_none()
            );
            let mut nan = s;
            nan.radiance_pdf = f32::NAN;
            assert!(share_gradient_theta(kind, theta, share, alpha, &nan).is_none());
        }
    }

    /// A leaf whose integrand the radiance descent matches (the product's
    /// lobe peaks away from the light) learns a share near the top, one
    /// where the product matches learns one near the bottom; the share
    /// stays in its bounds, and a refused sample changes nothing.
    #[test]
    fn a_leaf_learns_the_share_its_samples_favour() {
        let cfg = AdamConfig::default();
        let mut stats = AdamStats::default();
        // Two directions, drawn in turn (each with probability ½); the
        // integrand is 1 on the first and 0 on the second. Under the
        // radiance descent the first holds `radiance_first` of the mass.
        let learn = |kind: ShareLearning, radiance_first: f32, product_first: f32| {
            let mut l = LearnedShare::starting_at(0.3);
            let mut stats = AdamStats::default();
            for i in 0..4000 {
                let b = l.share();
                let (pr, pp) = if i % 2 == 0 {
                    (radiance_first, product_first)
                } else {
                    (1.0 - radiance_first, 1.0 - product_first)
                };
                // α used = 1 with a BSDF pdf of ½ states the draw's
                // probability; the current α of 0 learns the guide alone.
                let s = ShareSample {
                    product: if i % 2 == 0 { 2.0 } else { 0.0 },
                    bsdf_pdf: 0.5,
                    guide_pdf: (1.0 - b) * pp + b * pr,
                    radiance_pdf: pr,
                    share_used: b,
                    alpha_used: 1.0,
                };
                l.step_sample(&cfg, kind, &s, 0.0, Some(1.0), &mut stats)
                    .unwrap();
                assert!((SHARE_MIN..=SHARE_MAX).contains(&l.share()));
            }
            l.share()
        };
        for kind in [ShareLearning::Kl, ShareLearning::Variance] {
            let towards_radiance = learn(kind, 0.9, 0.1);
            let towards_product = learn(kind, 0.1, 0.9);
            assert!(towards_radiance > 0.8, "{kind:?}: {towards_radiance}");
            assert!(towards_product < 0.1, "{kind:?}: {towards_product}");
        }
        let mut l = LearnedShare::starting_at(0.3);
        assert!((l.share() - 0.3).abs() < 1e-6);
        let bad = sample(1.0, f32::INFINITY, 0.3);
        assert_eq!(
            l.step_sample(&cfg, ShareLearning::Kl, &bad, 0.2, None, &mut stats),
            Err(NonFiniteGradient)
        );
        assert_eq!(stats.rejected_non_finite, 1);
        assert_eq!(l, LearnedShare::starting_at(0.3));
        assert_eq!(LearnedShare::starting_at(0.0).share(), SHARE_MIN);
    }

    #[test]
    fn the_summary_weighs_leaves_by_their_steps() {
        let cfg = AdamConfig::default();
        let mut stats = AdamStats::default();
        let mut a = LearnedShare::starting_at(0.2);
        let b = LearnedShare::starting_at(0.6);
        let s = sample(1.0, 3.0, 0.3);
        for _ in 0..3 {
            a.step_sample(&cfg, ShareLearning::Kl, &s, 0.2, None, &mut stats)
                .unwrap();
        }
        let summary = LearnedShareSummary::of([a, b].iter(), stats);
        assert_eq!((summary.leaves, summary.steps), (1, 3));
        assert_eq!(summary.mean, a.share() as f64);
        let none = LearnedShareSummary::of([b].iter(), AdamStats::default());
        assert_eq!(none.leaves, 0);
    }
}
