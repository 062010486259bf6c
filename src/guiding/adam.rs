//! Learned BSDF-sampling fraction α per spatial leaf (Müller, "Practical
//! path guiding in production", 2019, §"Learning the BSDF sampling fraction").
//!
//! α = sigmoid(θ) and θ is trained by Adam to minimise the KL divergence
//! D_KL(F ‖ p_mix) between the normalised integrand F ∝ f·L (f includes the
//! cosine) and the one-sample MIS mixture p_mix = α·p_bsdf + (1−α)·p_guide.
//!
//! Derivation. D_KL = ∫ F log(F/p_mix) dω; only p_mix depends on α, so
//!   ∂D_KL/∂α = −∫ F · (∂p_mix/∂α) / p_mix dω = −∫ F · (p_bsdf − p_guide)/p_mix dω.
//! The direction ω was drawn from the mixture p_used the renderer used
//! (α_used), which is not the current one: θ moves with every step, and a
//! render call may trace several passes before their records are learned
//! from. The unbiased estimate weighs by the sampling pdf once and keeps
//! the current mixture p_mix (α = the current, clamped σ(θ)) in the
//! derivative's denominator:
//!   ∂D_KL/∂α ≈ −(F(ω)/p_used(ω)) · (p_bsdf(ω) − p_guide(ω)) / p_mix(ω),
//! and dα/dθ = σ(θ)(1−σ(θ)). The unknown normalisation of F only scales the
//! gradient, which Adam's second-moment normalisation divides out (up to its
//! interplay with the L2 term). F(ω)/p_used(ω) is the record's `product`
//! f·L/p_used, so
//!   ∂L/∂θ = −product · (p_bsdf − p_guide)/p_mix · σ(θ)(1−σ(θ)) + λ·θ.
//! Dividing by p_used twice, as this module did before, biased the step
//! towards the α the samples came from: with several passes per call,
//! staircase's floor learned α ≈ 0.1 instead of ≈ 0.5 and its variance
//! per sample rose 18 %.
//!
//! Normalisation (on by default). The loss is defined on the normalised
//! integrand F/∫F, so the exact one-sample gradient carries a factor
//! 1/∫F; the formula above omits it. Without it the gradient is in the
//! scene's radiance units while the L2 term λθ is not: in a dim region the
//! regulariser dominates and pins α near ½, in a bright one it does
//! nothing. Each leaf therefore keeps the running mean of `product` (an
//! unbiased estimate of ∫F under any mixture) and divides by it, which
//! makes learning rate and regulariser scale-free. `normalize_gradient =
//! false` gives the raw formula.
//!
//! The α the renderer uses is clamped to [α_min, α_max]; the gradient still
//! flows through σ(θ) (a straight-through clamp), so θ keeps learning while
//! the clamp is active instead of stalling at zero derivative.
//!
//! α_min: the default is 0.05 (Müller's θ ∈ [−20, 20] allows α ≈ 2·10⁻⁹).
//! The guide can miss directions where the integrand is non-zero (late-found
//! light, cells pruned for low flux, product approximations); there the
//! estimator's weight is 1/(α·p_bsdf), so α_min bounds it by 20× that of
//! pure BSDF sampling (defensive importance sampling, Hesterberg 1995). The
//! cost when the guide is perfect is at most 5 % of the samples.
//!
//! Optionally ([`FractionLearning::VarianceGrid`]) a leaf skips Adam and
//! takes the fraction of [`FRACTION_GRID`] whose estimated second moment
//! ∫F²/p_mix over all its training samples is least
//! (`super::moment_grid`). The KL divergence weighs a direction by F, the
//! estimator's variance by F²/p: where the guide misses part of the
//! integrand (a light blurred over a leaf, light found late), the
//! defensive BSDF samples that the variance asks for are what the KL
//! hardly sees. Pulling α towards ½ helped both guided methods on two of
//! the pack's scenes and hurt the product on a third (session 41); the
//! grid lets each leaf ask its own samples.

use super::moment_grid::SecondMomentGrid;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdamConfig {
    pub learning_rate: f64,
    pub beta1: f64,
    pub beta2: f64,
    pub epsilon: f64,
    /// λ of the L2 regulariser ½λθ², whose gradient λθ pulls α towards ½.
    pub l2: f64,
    /// θ is kept in [−theta_max, theta_max].
    pub theta_max: f64,
    pub alpha_min: f32,
    pub alpha_max: f32,
    /// Divide the one-sample gradient by the leaf's running estimate of
    /// ∫F (the mean of `product`), i.e. use the gradient of the KL to the
    /// *normalised* integrand. See the module docs.
    pub normalize_gradient: bool,
    /// Adam on the KL divergence, or the grid of least second moment.
    pub learning: FractionLearning,
}

/// How a leaf learns its BSDF fraction.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
pub enum FractionLearning {
    /// Adam on D_KL(F ‖ p_mix) (Müller 2019).
    #[default]
    Kl,
    /// The fraction of [`FRACTION_GRID`] of least estimated ∫F²/p_mix.
    VarianceGrid,
}

impl std::fmt::Display for FractionLearning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            FractionLearning::Kl => "kl",
            FractionLearning::VarianceGrid => "variance-grid",
        })
    }
}

/// The fractions [`FractionLearning::VarianceGrid`] chooses from (within
/// [α_min, α_max] as the renderer clamps them).
pub const FRACTION_GRID: [f32; 12] = [
    0.05, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 0.95,
];

impl Default for AdamConfig {
    fn default() -> Self {
        AdamConfig {
            learning_rate: 0.01,
            beta1: 0.9,
            beta2: 0.999,
            epsilon: 1e-8,
            l2: 0.01,
            theta_max: 20.0,
            alpha_min: 0.05,
            alpha_max: 1.0,
            normalize_gradient: true,
            learning: FractionLearning::Kl,
        }
    }
}

/// Refuses an L2 weight λ (`--bsdf-fraction-l2`) that is negative or not
/// finite: a negative λ would push α away from ½ without bound, and a NaN
/// would reach every leaf's θ.
pub fn check_l2(lambda: f64) -> Result<(), String> {
    if lambda >= 0.0 && lambda.is_finite() {
        Ok(())
    } else {
        Err(format!(
            "--bsdf-fraction-l2 must be a finite number ≥ 0, got {lambda}"
        ))
    }
}

/// Outcome counters of optimisation steps.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AdamStats {
    pub steps: u64,
    pub rejected_non_finite: u64,
}

impl AdamStats {
    pub fn merge(&mut self, o: &AdamStats) {
        self.steps += o.steps;
        self.rejected_non_finite += o.rejected_non_finite;
    }
}

/// The gradient could not be used; nothing was applied.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NonFiniteGradient;

/// Adam's moment estimates for one scalar parameter, shared by the
/// learned fractions (this BSDF fraction and the radiance share of
/// `super::share_learning`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdamMoments {
    m: f64,
    v: f64,
    t: u64,
    /// β₁ᵗ and β₂ᵗ for the bias corrections, as running products (a powf
    /// per recorded sample is measurable).
    beta1_t: f64,
    beta2_t: f64,
}

impl Default for AdamMoments {
    fn default() -> Self {
        AdamMoments {
            m: 0.0,
            v: 0.0,
            t: 0,
            beta1_t: 1.0,
            beta2_t: 1.0,
        }
    }
}

impl AdamMoments {
    pub fn steps(&self) -> u64 {
        self.t
    }

    /// One Adam step from `theta` on the full gradient `g` (regulariser
    /// included): the new θ, clamped to ±θ_max, or nothing changed when
    /// any value turns non-finite (counted in `stats`).
    pub fn step(
        &mut self,
        cfg: &AdamConfig,
        theta: f64,
        g: f64,
        stats: &mut AdamStats,
    ) -> Result<f64, NonFiniteGradient> {
        let g2 = g * g;
        if !(g.is_finite() && g2.is_finite()) {
            stats.rejected_non_finite += 1;
            return Err(NonFiniteGradient);
        }
        let m = cfg.beta1 * self.m + (1.0 - cfg.beta1) * g;
        let v = cfg.beta2 * self.v + (1.0 - cfg.beta2) * g2;
        let (beta1_t, beta2_t) = (self.beta1_t * cfg.beta1, self.beta2_t * cfg.beta2);
        let m_hat = m / (1.0 - beta1_t);
        let v_hat = v / (1.0 - beta2_t);
        let next = theta - cfg.learning_rate * m_hat / (v_hat.sqrt() + cfg.epsilon);
        if !(next.is_finite() && m.is_finite() && v.is_finite()) {
            stats.rejected_non_finite += 1;
            return Err(NonFiniteGradient);
        }
        (self.beta1_t, self.beta2_t) = (beta1_t, beta2_t);
        self.m = m;
        self.v = v;
        self.t += 1;
        stats.steps += 1;
        Ok(next.clamp(-cfg.theta_max, cfg.theta_max))
    }
}

/// Adam state of one spatial leaf. θ starts at 0 (α = ½).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfFraction {
    theta: f64,
    /// sigmoid(θ), kept with θ: every guided vertex reads α, and an f64
    /// exponential per vertex is measurable.
    sigmoid_theta: f32,
    moments: AdamMoments,
    /// Σ product and count over every sample offered: product = F/p_mix is
    /// an unbiased estimate of ∫F whatever the mixture, so the running mean
    /// estimates the normaliser.
    product_sum: f64,
    product_count: u64,
    /// The second moment per fraction of [`FRACTION_GRID`]
    /// ([`FractionLearning::VarianceGrid`]).
    grid: SecondMomentGrid<{ FRACTION_GRID.len() }>,
}

impl Default for BsdfFraction {
    fn default() -> Self {
        BsdfFraction::with_theta(0.0)
    }
}

#[inline]
pub(crate) fn sigmoid(x: f64) -> f64 {
    1.0 / (1.0 + (-x).exp())
}

/// α itself needs only f32 (θ ∈ [−20, 20] keeps it normal).
#[inline]
pub(crate) fn sigmoid_f32(x: f32) -> f32 {
    1.0 / (1.0 + (-x).exp())
}

/// ∂D_KL/∂θ from one sample (see module docs) at logit `theta`, whose
/// clamped α is `alpha_now`, or `None` when any input or the result is
/// non-finite, or either mixture's pdf ≤ 0 (a sample whose own mixture pdf
/// was 0 cannot have been drawn).
pub fn kl_gradient_theta(
    theta: f64,
    alpha_now: f32,
    product: f32,
    bsdf_pdf: f32,
    guide_pdf: f32,
    alpha_used: f32,
) -> Option<f64> {
    let (f, pb, pg, a, a_now) = (
        product as f64,
        bsdf_pdf as f64,
        guide_pdf as f64,
        alpha_used as f64,
        alpha_now as f64,
    );
    let inputs = [f, pb, pg, a, a_now, theta];
    if !inputs.iter().all(|x| x.is_finite()) {
        return None;
    }
    let p_used = a * pb + (1.0 - a) * pg;
    let p_mix = a_now * pb + (1.0 - a_now) * pg;
    if !(p_used > 0.0 && p_mix > 0.0) {
        return None;
    }
    let s = sigmoid(theta);
    let g = -f * (pb - pg) / p_mix * (s * (1.0 - s));
    (g.is_finite() && (g * g).is_finite()).then_some(g)
}

impl BsdfFraction {
    /// A fresh optimiser state at logit θ.
    pub fn with_theta(theta: f64) -> Self {
        BsdfFraction {
            theta,
            sigmoid_theta: sigmoid_f32(theta as f32),
            moments: AdamMoments::default(),
            product_sum: 0.0,
            product_count: 0,
            grid: SecondMomentGrid::default(),
        }
    }

    pub fn theta(&self) -> f64 {
        self.theta
    }

    /// Adam steps taken, or samples summed for the grid.
    pub fn steps(&self) -> u64 {
        self.moments.steps() + self.grid.samples()
    }

    /// The grid's estimates of ∫F²/p_mix per fraction of
    /// [`FRACTION_GRID`], once it has samples.
    pub fn grid_second_moments(&self) -> Option<[f64; FRACTION_GRID.len()]> {
        self.grid.second_moments()
    }

    /// The running estimate of ∫F the gradients are divided by (see the
    /// module docs), once a sample has been offered.
    pub fn product_mean(&self) -> Option<f64> {
        (self.product_count > 0).then(|| self.product_sum / self.product_count as f64)
    }

    /// The BSDF-sampling fraction the renderer should use.
    #[inline]
    pub fn alpha(&self, cfg: &AdamConfig) -> f32 {
        self.sigmoid_theta
            .clamp(cfg.alpha_min, cfg.alpha_max.max(cfg.alpha_min))
    }

    /// One Adam step on the KL gradient of one recorded sample.
    pub fn step_sample(
        &mut self,
        cfg: &AdamConfig,
        product: f32,
        bsdf_pdf: f32,
        guide_pdf: f32,
        alpha_used: f32,
        stats: &mut AdamStats,
    ) -> Result<(), NonFiniteGradient> {
        let alpha_now = self.alpha(cfg);
        match kl_gradient_theta(
            self.theta, alpha_now, product, bsdf_pdf, guide_pdf, alpha_used,
        ) {
            Some(g) => {
                let sum = self.product_sum + product as f64;
                let count = self.product_count + 1;
                let mean = sum / count as f64;
                let g = if cfg.normalize_gradient && mean > 0.0 {
                    g / mean
                } else {
                    g
                };
                self.step_gradient(cfg, g, stats)?;
                self.product_sum = sum;
                self.product_count = count;
                Ok(())
            }
            None => {
                stats.rejected_non_finite += 1;
                Err(NonFiniteGradient)
            }
        }
    }

    /// Adds one recorded sample to the grid's sums
    /// ([`FractionLearning::VarianceGrid`]). It was drawn from
    /// p_used = α_used·p_bsdf + (1 − α_used)·`guide_pdf_used`; each
    /// fraction's mixture takes the guide's pdf at the leaf's current
    /// share, `guide_pdf_now` (the two differ only where the share is
    /// learned). A refused sample is counted and changes nothing.
    pub fn add_to_grid(
        &mut self,
        product: f32,
        bsdf_pdf: f32,
        guide_pdf_used: f32,
        guide_pdf_now: f32,
        alpha_used: f32,
        stats: &mut AdamStats,
    ) -> Result<(), NonFiniteGradient> {
        let (pb, pg_used, pg_now, a) = (
            bsdf_pdf as f64,
            guide_pdf_used as f64,
            guide_pdf_now as f64,
            alpha_used as f64,
        );
        let inputs_finite = [pb, pg_used, pg_now, a].iter().all(|x| x.is_finite());
        let p_used = a * pb + (1.0 - a) * pg_used;
        let added = inputs_finite
            && self.grid.add(product as f64, p_used, |k| {
                let f = FRACTION_GRID[k] as f64;
                f * pb + (1.0 - f) * pg_now
            });
        if !added {
            stats.rejected_non_finite += 1;
            return Err(NonFiniteGradient);
        }
        self.product_sum += product as f64;
        self.product_count += 1;
        stats.steps += 1;
        Ok(())
    }

    /// Takes the grid's fraction of least estimated second moment (the
    /// first of equals), once the leaf has
    /// [`super::moment_grid::GRID_MIN_SAMPLES`]; before, α stays where it
    /// started.
    pub fn choose_from_grid(&mut self) {
        if let Some(best) = self.grid.least() {
            let alpha = FRACTION_GRID[best];
            self.theta = (alpha as f64 / (1.0 - alpha as f64)).ln();
            self.sigmoid_theta = alpha;
        }
    }

    /// One Adam step on a given ∂L/∂θ (without the L2 term, added here).
    pub fn step_gradient(
        &mut self,
        cfg: &AdamConfig,
        gradient: f64,
        stats: &mut AdamStats,
    ) -> Result<(), NonFiniteGradient> {
        let g = gradient + cfg.l2 * self.theta;
        self.theta = self.moments.step(cfg, self.theta, g, stats)?;
        self.sigmoid_theta = sigmoid_f32(self.theta as f32);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gradient_sign_favours_the_pdf_that_matches_the_integrand() {
        // At a direction the BSDF samples well (p_b > p_g) with positive
        // integrand, the loss decreases as α grows: negative gradient.
        let g = kl_gradient_theta(0.0, 0.5, 1.0, 2.0, 0.5, 0.5).unwrap();
        assert!((g - (-(1.5 / 1.25) * 0.25)).abs() < 1e-12, "{g}");
        assert!(kl_gradient_theta(0.0, 0.5, 1.0, 0.0, 0.0, 0.5).is_none());
        assert!(kl_gradient_theta(0.0, 0.5, f32::NAN, 1.0, 1.0, 0.5).is_none());
        // Drawn with α_used = 0.9, learned at α = 0.5: the derivative's
        // denominator is the current mixture, 0.5·2 + 0.5·0.5.
        let g = kl_gradient_theta(0.0, 0.5, 1.0, 2.0, 0.5, 0.9).unwrap();
        assert!((g - (-(1.5 / 1.25) * 0.25)).abs() < 1e-12, "{g}");
        // A sample its own mixture could not have drawn is refused.
        assert!(kl_gradient_theta(0.0, 0.5, 1.0, 3.0, 0.0, 0.0).is_none());
    }

    /// Directions drawn from one mixture (α_used, guide pdf used): the
    /// leaf's grid estimates every fraction's second moment under the
    /// guide's pdf now, takes a fraction within 1 % of the exact least (its
    /// neighbours on the grid are 0.4 % and 3 % above it), and α reads it.
    #[test]
    fn the_grid_takes_the_fraction_of_least_second_moment() {
        // A discrete sphere: the guide misses the third direction, which
        // the BSDF covers, so some BSDF sampling pays off, but not most.
        const F: [f64; 4] = [3.0, 1.0, 1.0, 0.0];
        const P_BSDF: [f32; 4] = [0.25, 0.25, 0.25, 0.25];
        const GUIDE_USED: [f32; 4] = [0.5, 0.3, 0.1, 0.1];
        const GUIDE_NOW: [f32; 4] = [0.7, 0.25, 0.02, 0.03];
        let alpha_used = 0.5f64;
        let p_used =
            |i: usize| alpha_used * P_BSDF[i] as f64 + (1.0 - alpha_used) * GUIDE_USED[i] as f64;
        let exact = FRACTION_GRID.map(|a| {
            let a = a as f64;
            (0..4)
                .map(|i| F[i] * F[i] / (a * P_BSDF[i] as f64 + (1.0 - a) * GUIDE_NOW[i] as f64))
                .sum::<f64>()
        });
        let mut fraction = BsdfFraction::default();
        let mut stats = AdamStats::default();
        let mut rng = crate::sampling::Rng::new(5, 9);
        let n = 200_000;
        let draws = crate::sampling::Distribution1D::new(&[0, 1, 2, 3].map(|i| p_used(i) as f32));
        for _ in 0..n {
            let (i, _, _) = draws.sample_discrete(rng.next_f32());
            fraction
                .add_to_grid(
                    (F[i] / p_used(i)) as f32,
                    P_BSDF[i],
                    GUIDE_USED[i],
                    GUIDE_NOW[i],
                    alpha_used as f32,
                    &mut stats,
                )
                .unwrap();
        }
        let estimate = fraction.grid_second_moments().unwrap();
        let least = crate::guiding::moment_grid::assert_estimates_and_interior_least(
            &estimate,
            &exact,
            &FRACTION_GRID,
        );
        // α still where it started until the grid chooses.
        let cfg = AdamConfig::default();
        assert_eq!(fraction.alpha(&cfg), 0.5);
        fraction.choose_from_grid();
        let chosen = FRACTION_GRID
            .iter()
            .position(|&a| a == fraction.alpha(&cfg))
            .expect("α is a grid fraction");
        assert!(
            exact[chosen] <= 1.01 * exact[least],
            "chose α {} at {}, the least is α {} at {}",
            FRACTION_GRID[chosen],
            exact[chosen],
            FRACTION_GRID[least],
            exact[least]
        );
        assert_eq!((stats.steps, fraction.steps()), (n, n));
        // Every sample also feeds the normaliser: the mean of F/p_used is ∫F.
        let integral: f64 = F.iter().sum();
        assert!((fraction.product_mean().unwrap() - integral).abs() < 0.02 * integral);
        // A refused sample changes nothing and is counted.
        let before = fraction;
        assert!(
            fraction
                .add_to_grid(1.0, f32::NAN, 0.5, 0.5, 0.5, &mut stats)
                .is_err()
        );
        assert!(
            fraction
                .add_to_grid(1.0, 0.0, 0.0, 0.5, 0.5, &mut stats)
                .is_err()
        );
        assert_eq!(fraction, before);
        assert_eq!(stats.rejected_non_finite, 2);
    }

    #[test]
    fn steps_move_theta_by_about_the_learning_rate_and_clamp() {
        let cfg = AdamConfig::default();
        let mut a = BsdfFraction::default();
        let mut stats = AdamStats::default();
        a.step_gradient(&cfg, -5.0, &mut stats).unwrap();
        assert!((a.theta() - 0.01).abs() < 1e-6);
        for _ in 0..5000 {
            a.step_gradient(&cfg, -1e6, &mut stats).unwrap();
        }
        assert_eq!(a.theta(), 20.0);
        assert_eq!(a.alpha(&cfg), 1.0);
        assert_eq!(
            a.step_gradient(&cfg, f64::INFINITY, &mut stats),
            Err(NonFiniteGradient)
        );
        assert_eq!(stats.rejected_non_finite, 1);
        assert_eq!(a.theta(), 20.0);
        let low = BsdfFraction::with_theta(-20.0);
        assert_eq!(low.alpha(&cfg), cfg.alpha_min);
    }
}
