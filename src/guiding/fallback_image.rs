//! What a run images once its strategy trial (`super::trial`) has fallen
//! back to path tracing: path tracing's passes alone, the trial's and every
//! later one, as one film.
//!
//! The guided passes before the decision are left out. They are rendered
//! without NEE (the paper's setting), and at a few spp their measured
//! variance misses the rare fireflies that dominate their error, so the
//! inverse-variance combination (`super::combine::combine`) weighs them far
//! more than they deserve: on veach-mis, under 3 % of the weight on 13 guided
//! spp made the image's relMSE 26–31× path tracing's at 30 s
//! (docs/results-reading.md, sessions 17–18). Path tracing's passes are
//! all one estimator, so one film weighs them equally, which is optimal
//! for them and needs no variance estimate at all. What is left out is
//! counted (`GuidingStats::left_out_spp`) and reported per iteration
//! (`IterationSummary::image_spp`).

use super::train::IterationSummary;
use crate::film::image::Film;

pub struct FallbackImage {
    film: Film,
    /// Index of the iteration whose trial decided.
    decided_in: usize,
}

impl FallbackImage {
    /// Starts the image from the trial's path-tracing passes, decided in
    /// iteration `decided_in` (0-based).
    pub fn new(trial_unguided: &Film, decided_in: usize) -> Self {
        FallbackImage {
            film: trial_unguided.clone(),
            decided_in,
        }
    }

    /// Adds a call rendered after the decision.
    pub fn add(&mut self, call: &Film) {
        self.film.merge(call);
    }

    pub fn film(&self) -> &Film {
        &self.film
    }

    /// Sets each iteration's passes in the image and its weight (its share
    /// of them), given the runs' `films` per iteration; returns the passes
    /// left out.
    pub fn account(&self, summaries: &mut [IterationSummary], films: &[Film]) -> u32 {
        let total = self.film.spp;
        let mut left_out = 0;
        for (k, s) in summaries.iter_mut().enumerate() {
            s.image_spp = if k < self.decided_in {
                0
            } else if k == self.decided_in {
                // The trial's path tracing and whatever followed it in the
                // deciding iteration: all but the later iterations' passes.
                let later: u32 = films[k + 1..].iter().map(|f| f.spp).sum();
                total.saturating_sub(later)
            } else {
                s.spp
            };
            left_out += s.spp - s.image_spp.min(s.spp);
            s.weight = s.image_spp as f64 / total.max(1) as f64;
        }
        left_out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Spectrum;

    fn film(spp: u32, value: f32) -> Film {
        let mut f = Film::new(2, 1);
        for _ in 0..spp {
            f.add_pass(&[Spectrum::splat(value), Spectrum::splat(2.0 * value)]);
        }
        f
    }

    fn summary(iteration: u32, spp: u32) -> IterationSummary {
        IterationSummary {
            iteration,
            spp,
            seconds: 1.0,
            training: true,
            mean_variance: 0.0,
            image_spp: spp,
            weight: 0.0,
        }
    }

    /// Iterations of 1, 2, 4 guided passes, a check iteration of 6 guided
    /// and 2 path-tracing passes that decides to fall back, then 16 and 13
    /// path-tracing passes: the image holds the 31 path-tracing passes, each
    /// once, and the 13 guided ones are left out.
    #[test]
    fn the_image_holds_exactly_the_passes_after_the_decision() {
        let guided_value = 100.0;
        let mut films: Vec<Film> = [1, 2, 4].iter().map(|&n| film(n, guided_value)).collect();
        let trial_pt = film(2, 1.0);
        let mut check = film(6, guided_value);
        check.merge(&trial_pt);
        let mut image = FallbackImage::new(&trial_pt, films.len());
        films.push(check);
        for n in [16, 13] {
            // Two calls per iteration.
            let (a, b) = (film(n / 2, 1.0), film(n - n / 2, 1.0));
            let mut it = Film::new(2, 1);
            for call in [&a, &b] {
                it.merge(call);
                image.add(call);
            }
            films.push(it);
        }
        assert_eq!(image.film().spp, 31);
        // Only path tracing's value (1, 2) is in the image.
        let mean = image.film().mean();
        assert_eq!(
            (mean[0], mean[1]),
            (Spectrum::splat(1.0), Spectrum::splat(2.0))
        );
        let mut summaries: Vec<IterationSummary> = films
            .iter()
            .enumerate()
            .map(|(k, f)| summary(k as u32, f.spp))
            .collect();
        let left_out = image.account(&mut summaries, &films);
        assert_eq!(left_out, 1 + 2 + 4 + 6);
        let image_spp: Vec<u32> = summaries.iter().map(|s| s.image_spp).collect();
        assert_eq!(image_spp, [0, 0, 0, 2, 16, 13]);
        let weights: Vec<f64> = summaries.iter().map(|s| s.weight).collect();
        assert_eq!(weights[..3], [0.0; 3]);
        assert!((weights.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        assert!((weights[4] - 16.0 / 31.0).abs() < 1e-12);
    }

    /// A trial at the start of the final iteration (training ended first):
    /// the deciding iteration is the last, and its path tracing is all of
    /// the image.
    #[test]
    fn a_decision_in_the_final_iteration_keeps_its_path_tracing() {
        let trial_pt = film(2, 1.0);
        let mut image = FallbackImage::new(&trial_pt, 2);
        let later = film(20, 1.0);
        image.add(&later);
        let mut last = film(6, 50.0);
        last.merge(&trial_pt);
        last.merge(&later);
        let films = vec![film(1, 50.0), film(2, 50.0), last];
        let mut summaries: Vec<IterationSummary> = films
            .iter()
            .enumerate()
            .map(|(k, f)| summary(k as u32, f.spp))
            .collect();
        assert_eq!(image.account(&mut summaries, &films), 1 + 2 + 6);
        assert_eq!(summaries[2].image_spp, 22);
        assert_eq!(summaries[2].weight, 1.0);
    }
}
