//! A mixture weight chosen from a small fixed grid by the estimator's
//! second moment, for the learned fractions of a spatial leaf (the BSDF
//! fraction α of `super::adam`, the radiance share β of
//! `super::share_learning`).
//!
//! A sample ω drawn from the mixture p_used with integrand F(ω) gives, for
//! any other mixture p_k whose support covers F's,
//!   E[(F/p_used)² · p_used/p_k] = ∫ F²/p_k dω,
//! the second moment of the one-sample estimator under p_k. Summing that
//! term for every weight of the grid over all of a leaf's training samples
//! compares the weights on common samples, and the least sum picks the
//! weight of least variance.
//!
//! Why not a gradient: Adam bounds each sample's step, so it follows the
//! heavy-tailed gradient of ∫F²/p poorly — the rare samples of large F/p
//! that carry the case for a defensive weight move the parameter by about
//! as much as one of the many ordinary samples (docs/results-reading.md,
//! sessions 41 and 53). A sum weighs every sample by its term.

/// Training samples a leaf needs before its grid's choice replaces the
/// weight it started from.
pub const GRID_MIN_SAMPLES: u64 = 64;

/// Σ (F/p_used)²·p_used/p_k per grid weight k, and the samples summed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SecondMomentGrid<const N: usize> {
    sums: [f64; N],
    samples: u64,
}

impl<const N: usize> Default for SecondMomentGrid<N> {
    fn default() -> Self {
        SecondMomentGrid {
            sums: [0.0; N],
            samples: 0,
        }
    }
}

impl<const N: usize> SecondMomentGrid<N> {
    /// Samples summed so far.
    pub fn samples(&self) -> u64 {
        self.samples
    }

    /// Adds one sample: `product` = F(ω)/p_used(ω), `p_used` the pdf it was
    /// drawn with, `pdf_at(k)` the mixture's pdf at grid weight k. Returns
    /// false, and adds nothing, when `p_used` is not positive or a term is
    /// not finite and non-negative (the caller counts the refusal).
    pub fn add(&mut self, product: f64, p_used: f64, pdf_at: impl Fn(usize) -> f64) -> bool {
        if !(product.is_finite() && p_used > 0.0 && p_used.is_finite()) {
            return false;
        }
        let weight = product * product * p_used;
        // A zero integrand adds nothing to any weight, whatever its pdfs.
        let terms: [f64; N] = std::array::from_fn(|k| {
            if weight == 0.0 {
                0.0
            } else {
                weight / pdf_at(k)
            }
        });
        if !terms.iter().all(|t| t.is_finite() && *t >= 0.0) {
            return false;
        }
        for (sum, t) in self.sums.iter_mut().zip(terms) {
            *sum += t;
        }
        self.samples += 1;
        true
    }

    /// The estimates of ∫F²/p_k (in the integrand's units), once a sample
    /// has been added.
    pub fn second_moments(&self) -> Option<[f64; N]> {
        (self.samples > 0).then(|| self.sums.map(|m| m / self.samples as f64))
    }

    /// The grid index of least estimated second moment (the first of
    /// equals), once [`GRID_MIN_SAMPLES`] have been added.
    pub fn least(&self) -> Option<usize> {
        if self.samples < GRID_MIN_SAMPLES {
            return None;
        }
        (0..N).min_by(|&i, &j| self.sums[i].total_cmp(&self.sums[j]))
    }
}

/// Test support for the grids' users: asserts that every estimate is
/// within 2 % of its exact second moment, and returns the index of the
/// exact least, which must lie inside the grid (an optimum at a bound would
/// not test the choice).
#[cfg(test)]
pub(crate) fn assert_estimates_and_interior_least(
    estimate: &[f64],
    exact: &[f64],
    weights: &[impl std::fmt::Display],
) -> usize {
    for k in 0..weights.len() {
        assert!(
            (estimate[k] - exact[k]).abs() < 0.02 * exact[k],
            "weight {}: {} against {}",
            weights[k],
            estimate[k],
            exact[k]
        );
    }
    let least = (0..weights.len())
        .min_by(|&i, &j| exact[i].total_cmp(&exact[j]))
        .unwrap();
    assert!(least > 0 && least < weights.len() - 1, "{least}");
    least
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A discrete sphere of three directions: the estimates converge to
    /// the exact second moments of each mixture weight, and the least is
    /// the exact least.
    #[test]
    fn sums_estimate_each_weights_second_moment_and_pick_the_least() {
        const F: [f64; 3] = [2.0, 1.5, 0.0];
        const P_A: [f64; 3] = [0.2, 0.5, 0.3];
        const P_B: [f64; 3] = [0.7, 0.1, 0.2];
        const WEIGHTS: [f64; 5] = [0.05, 0.25, 0.5, 0.75, 0.95];
        let mix = |w: f64, i: usize| w * P_A[i] + (1.0 - w) * P_B[i];
        let exact = WEIGHTS.map(|w| (0..3).map(|i| F[i] * F[i] / mix(w, i)).sum::<f64>());
        let used = 0.5;
        let mut grid = SecondMomentGrid::<5>::default();
        let mut rng = crate::sampling::Rng::new(11, 5);
        let draws = crate::sampling::Distribution1D::new(&[0, 1, 2].map(|i| mix(used, i) as f32));
        for n in 0..100_000u64 {
            let (i, _, _) = draws.sample_discrete(rng.next_f32());
            let p_used = mix(used, i);
            assert!(grid.add(F[i] / p_used, p_used, |k| mix(WEIGHTS[k], i)));
            if n + 1 < GRID_MIN_SAMPLES {
                assert_eq!(grid.least(), None);
            }
        }
        let estimate = grid.second_moments().unwrap();
        let least = assert_estimates_and_interior_least(&estimate, &exact, &WEIGHTS);
        assert_eq!(grid.least(), Some(least));
    }

    #[test]
    fn unusable_samples_change_nothing() {
        let mut grid = SecondMomentGrid::<2>::default();
        assert!(!grid.add(f64::NAN, 1.0, |_| 1.0));
        assert!(!grid.add(1.0, 0.0, |_| 1.0));
        assert!(!grid.add(1.0, 1.0, |k| if k == 0 { 0.0 } else { 1.0 }));
        assert!(!grid.add(1.0, 1.0, |_| f64::NAN));
        assert_eq!(grid, SecondMomentGrid::default());
        // A zero integrand counts as a sample with zero terms, even where a
        // weight's pdf vanishes.
        assert!(grid.add(0.0, 1.0, |_| 0.0));
        assert_eq!(grid.second_moments(), Some([0.0, 0.0]));
    }
}
