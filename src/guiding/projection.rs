//! What falling back to path tracing would cost a guided run
//! (`super::trial`): the run's projected final efficiency, image precision
//! over total seconds, when it keeps guiding and when it falls back.
//!
//! A more efficient path tracer is not enough to fall back: a fallback also
//! discards the guided passes already rendered, and the budget left may be
//! too short to recover them. On living-room at 45 CPU s, runs that fell
//! back when path tracing led by 1.06–1.20× after 60 % of their budget
//! imaged a third of path tracing's samples, at 2.7–3.05× its relMSE
//! (docs/results-reading.md, sessions 47–48).
//!
//! Noise is measured about the pooled mean of every film so far ([`Mean`]).

use super::combine::{iteration_variance, pooled_mean};
use crate::film::image::Film;
use glam::DVec3;

/// What is left of the run's budget when the trial decides.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Rest {
    /// Seconds on the run's clock.
    Seconds(f64),
    /// Passes of a sample budget.
    Passes(u64),
}

/// The run around the trial, for the value of what a fallback discards.
#[derive(Clone, Copy, Debug)]
pub struct RunSoFar<'a> {
    /// The finished iterations' films.
    pub films: &'a [Film],
    /// Seconds the run has spent, the trial's calls included.
    pub seconds: f64,
    /// What is left after the trial's last call.
    pub rest: Rest,
}

/// One strategy's measured cost and noise.
#[derive(Clone, Copy, Debug)]
pub(super) struct Measured {
    /// Variance of one pass's estimate, mean over pixels ([`Mean`]).
    pub per_sample_variance: f64,
    pub seconds_per_pass: f64,
}

impl Measured {
    /// The noise of `film`, rendered in `seconds`, measured about `mean`.
    pub fn of(film: &Film, seconds: f64, mean: &Mean) -> Self {
        Measured {
            per_sample_variance: mean.per_sample_variance(film),
            seconds_per_pass: seconds / film.spp.max(1) as f64,
        }
    }

    /// 1 / (variance per sample × seconds per sample), 0 where not
    /// measurable.
    pub fn efficiency(&self) -> f64 {
        let e = 1.0 / (self.per_sample_variance * self.seconds_per_pass);
        if e.is_finite() { e } else { 0.0 }
    }

    /// Precision (inverse variance of the mean) and seconds of rendering
    /// `rest` with this side.
    fn render(&self, rest: Rest) -> (f64, f64) {
        match rest {
            Rest::Seconds(t) => (t / (self.per_sample_variance * self.seconds_per_pass), t),
            Rest::Passes(n) => (
                n as f64 / self.per_sample_variance,
                n as f64 * self.seconds_per_pass,
            ),
        }
    }
}

/// The run's projected final efficiency, image precision over total
/// seconds, when it keeps guiding and when it falls back.
///
/// The precision of a film is its spp over its per-sample variance, and the
/// inverse-variance combination (`super::combine`) sums the iterations'.
/// Two floors keep the guided work from being overrated:
/// - a finished iteration is worth no more per sample than the guide the
///   trial measured, as the combination floors every iteration's
///   per-sample variance at the most-sampled film's (an earlier guide is no
///   better, and a few-spp film misses its rare fireflies);
/// - the trial's passes join one film as a plain mean, so a kept trial
///   iteration is worth N² / Σ nₛ·vₛ, path tracing's noisier passes included.
///
/// A fallback images the trial's path-tracing passes and its rest alone.
/// With a time budget both take the same seconds and only precision
/// differs; with a sample budget the rest's seconds differ too.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Projection {
    pub keep: f64,
    pub fallback: f64,
}

impl Projection {
    /// The projection for a run whose trial sides measured `sides` (spp
    /// and noise each), whose best guided side measured `guided`, and whose
    /// path-tracing side rendered `unguided` (spp and noise).
    pub(super) fn of(
        run: &RunSoFar,
        mean: &Mean,
        sides: &[(u32, Measured)],
        guided: Measured,
        unguided: (u32, Measured),
    ) -> Self {
        let floor = guided.per_sample_variance;
        // NaN compares false, so it takes the no-worth branch.
        let floored = |v: f64| {
            if v >= floor {
                v
            } else if v < floor {
                floor
            } else {
                f64::INFINITY
            }
        };
        let finished_work: f64 = run
            .films
            .iter()
            .filter(|f| f.spp > 0)
            .map(|f| f.spp as f64 / floored(mean.per_sample_variance(f)))
            .sum();
        let (mut passes, mut spread) = (0.0, 0.0);
        for (spp, side) in sides {
            let n = *spp as f64;
            passes += n;
            spread += n * side.per_sample_variance;
        }
        let trial_kept = (passes * passes / spread).min(passes / floor);
        let (rest_precision, rest_seconds) = guided.render(run.rest);
        let keep = (finished_work + trial_kept + rest_precision) / (run.seconds + rest_seconds);
        let (unguided_spp, unguided) = unguided;
        let (rest_precision, rest_seconds) = unguided.render(run.rest);
        let fallback = (unguided_spp as f64 / unguided.per_sample_variance + rest_precision)
            / (run.seconds + rest_seconds);
        Projection { keep, fallback }
    }

    /// Whether the projection forbids a fallback that efficiency alone
    /// would take. Unmeasurable projections forbid nothing.
    pub(super) fn keeps_guiding(&self) -> bool {
        self.keep.is_finite() && self.fallback.is_finite() && self.keep >= self.fallback
    }
}

/// The pooled mean of every film so far: the variances are measured about
/// it, which stays meaningful at a few spp.
///
/// The variance is absolute, though runs are judged by relMSE. Relative
/// variance (each channel's over μ² + ε, with a robust local μ) was tried
/// and measured worse: at a few spp it swung 500-fold between seeds of one
/// scene, and on veach-mis it kept guiding in runs that ended with up to
/// 9× path tracing's relMSE (docs/results-reading.md, session 48).
pub(super) struct Mean {
    pooled: Vec<DVec3>,
}

impl Mean {
    /// The mean of `films`, all of one size.
    pub fn of(films: &[&Film]) -> Self {
        Mean {
            pooled: pooled_mean(films),
        }
    }

    /// Variance of one of `film`'s passes about the mean, mean over pixels.
    pub fn per_sample_variance(&self, film: &Film) -> f64 {
        iteration_variance(film, &self.pooled).0 * film.spp.max(1) as f64
    }
}
