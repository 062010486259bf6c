//! The inverse-variance combination of the training iterations' images
//! (Müller 2019; DESIGN.md §5), made free of the bias of weights measured
//! on the samples they weigh.
//!
//! Weighting iteration i by 1/v̂_i, with v̂_i measured from iteration i's
//! own samples, correlates each weight with the image it weighs. Where
//! rare, bright paths carry much of the mean (caustics of a small light),
//! an iteration that happened to find none looks quiet, takes most of the
//! weight, and pulls the image low. On `scenes/stiff` at 512 spp a 16-spp
//! iteration took 57 % of the weight and the 449-spp final one 3 %, and
//! both guided methods came out 15 % below path tracing and Mitsuba
//! (0.347 against 0.406 and 0.411, four seeds each).
//!
//! Two measures, one for the expectation and one for the typical outcome:
//! - **Weights from the other pixels.** The pixels are split as a
//!   checkerboard, and each colour's pixels are combined with the weights
//!   measured on the other colour's. Pixels are independent given the
//!   guide, so a pixel's image is independent of the weights that combine
//!   it, and the combination's expectation is the iterations' whatever the
//!   weights. The two colours see the same scene at one pixel's offset, so
//!   their weights nearly agree. What remains is second order: an
//!   iteration's samples train the guide that later iterations, and so
//!   their weights, are rendered with.
//! - **No iteration measured quieter than the largest.** Unbiased is not
//!   enough where the estimator is skewed: a short iteration usually misses
//!   the rare paths everywhere, so both colours measure it quiet and its
//!   image low, and weighting it up makes the typical image low while the
//!   expectation is kept by rare images far too high. A short iteration's
//!   variance is the least reliable measurement (heavy tails are the ones
//!   few samples miss), the guide only improves with training, so an
//!   earlier iteration's per-sample variance is no lower than the last's in
//!   truth. Each iteration's per-sample variance is therefore floored at
//!   the one measured on the film with the most samples.
//!
//! Everything is computed in f64 from the films' f64 sums, so a finite
//! sample can never make a variance infinite; an iteration whose sums are
//! not finite is left out and counted ([`combine_counting`]).

use crate::film::image::{Film, Image};
use glam::DVec3;

/// The pooled per-pixel mean of several films (all samples of all films).
pub(super) fn pooled_mean(films: &[&Film]) -> Vec<DVec3> {
    let n: u32 = films.iter().map(|f| f.spp).sum();
    let inv = if n > 0 { 1.0 / n as f64 } else { 0.0 };
    let len = films.first().map_or(0, |f| f.sum.len());
    (0..len)
        .map(|i| films.iter().map(|f| f.sum[i]).sum::<DVec3>() * inv)
        .collect()
}

/// Per-pixel single-sample variance of `film` about the mean `mu` (channel
/// average): Σ (x − μ)² / n from the film's sums. Measuring the spread
/// about the pooled mean of all iterations rather than the film's own mean
/// keeps it meaningful for 1- and 2-spp iterations, whose own sample
/// variance is zero or nearly so in most pixels of a hard scene.
fn sample_variance_about(film: &Film, mu: &[DVec3]) -> Vec<f64> {
    let n = film.spp.max(1) as f64;
    film.sum
        .iter()
        .zip(&film.sum_sq)
        .zip(mu)
        .map(|((s, q), m)| {
            let mut v = 0.0f64;
            for c in 0..3 {
                let d = (q[c] - 2.0 * m[c] * s[c]) / n + m[c] * m[c];
                // Not `max`: it would turn a NaN into a silent 0.
                v += if d < 0.0 { 0.0 } else { d };
            }
            v / 3.0
        })
        .collect()
}

/// Mean over `pixels` of the per-pixel single-sample variances; ∞ if any
/// of them is not finite.
fn mean_sample_variance(sample_var: &[f64], pixels: impl Iterator<Item = usize>) -> f64 {
    let (mut total, mut count) = (0.0f64, 0usize);
    for i in pixels {
        let v = sample_var[i];
        total += if v.is_finite() { v } else { f64::INFINITY };
        count += 1;
    }
    total / count.max(1) as f64
}

/// Mean over pixels of the variance of the film's pixel means, and the
/// per-pixel single-sample variance it averages.
///
/// Deliberately unclamped. A per-pixel clamp of the sample variance s² at
/// some C makes the estimate depend on the sample count: one firefly x in n
/// samples adds x²/n to s², so it is clamped at 1 spp and counted at 64 spp.
/// On veach-ajar that made the measured per-sample variance of the same
/// (pure BSDF) estimator grow 13.7 → 25.9 → 41.4 → 65.7 from 4 to 33 spp,
/// which stopped training after 8 spp and gave noisy early iterations too
/// much weight. Unclamped, the mean over all pixels is a consistent estimate
/// of the mean per-sample variance at any n, fireflies included, which is
/// what relMSE pays for. A non-finite pixel variance (only from a film
/// whose sums are non-finite: finite f32 samples cannot overflow the f64
/// sums) makes the whole iteration unusable (∞), and [`combine_counting`]
/// counts it.
pub(super) fn iteration_variance(film: &Film, mu: &[DVec3]) -> (f64, Vec<f64>) {
    let sample_var = sample_variance_about(film, mu);
    let mean = mean_sample_variance(&sample_var, 0..sample_var.len()) / film.spp.max(1) as f64;
    (mean, sample_var)
}

/// Checkerboard colour of pixel `i` of an image `width` wide.
fn colour(i: usize, width: usize) -> usize {
    (i % width.max(1) + i / width.max(1)) & 1
}

/// Inverse-variance weights of the usable films, normalised, from their
/// mean variances; by sample count where no variance is measurable; `None`
/// when no film is usable.
fn normalised_weights(variances: &[f64], films: &[&Film], usable: &[bool]) -> Option<Vec<f64>> {
    let mut weights: Vec<f64> = variances
        .iter()
        .zip(usable)
        .map(|(&v, &u)| {
            if u && v.is_finite() && v > 0.0 {
                1.0 / v
            } else {
                0.0
            }
        })
        .collect();
    if weights.iter().all(|&w| w == 0.0) {
        // Noise-free (or unmeasurable): weigh the usable ones by sample count.
        weights = films
            .iter()
            .zip(usable)
            .map(|(f, &u)| if u { f.spp as f64 } else { 0.0 })
            .collect();
    }
    let total: f64 = weights.iter().sum();
    (total > 0.0).then(|| weights.iter().map(|w| w / total).collect())
}

/// Inverse-variance combination of iteration images (weights 1/mean
/// variance, DESIGN.md §5), with the per-pixel variance of the combination
/// and the films' weights (averaged over the pixels, so that they sum to 1).
pub fn combine(films: &[&Film]) -> Option<(Image, Vec<f64>, Vec<f64>)> {
    combine_counting(films, &mut 0)
}

/// [`combine`], adding to `dropped` the films left out for a non-finite
/// variance. Each checkerboard colour's pixels take the weights measured on
/// the other colour's (on their own in an image of one pixel), and no
/// film's per-sample variance is taken below that of the usable film with
/// the most samples (see the module's notes).
pub fn combine_counting(films: &[&Film], dropped: &mut u64) -> Option<(Image, Vec<f64>, Vec<f64>)> {
    let first = films.first()?;
    let films: Vec<&Film> = films.iter().copied().filter(|f| f.spp > 0).collect();
    if films.is_empty() {
        return None;
    }
    // A film with non-finite sums would also spoil the pooled mean, and
    // with it every other film's variance.
    let finite_sums = |f: &Film| f.sum.iter().chain(&f.sum_sq).all(|v| v.is_finite());
    let trusted: Vec<&Film> = films.iter().copied().filter(|f| finite_sums(f)).collect();
    if trusted.is_empty() {
        *dropped += films.len() as u64;
        return None;
    }
    let (width, n) = (first.width, first.width * first.height);
    let mu = pooled_mean(&trusted);
    let sample_vars: Vec<Vec<f64>> = films
        .iter()
        .map(|f| sample_variance_about(f, &mu))
        .collect();
    let usable: Vec<bool> = sample_vars
        .iter()
        .map(|sv| sv.iter().all(|v| v.is_finite()))
        .collect();
    *dropped += usable.iter().filter(|&&u| !u).count() as u64;
    // The usable film with the most samples measures its variance most
    // reliably (`max_by_key` keeps the last of equals: the latest iteration).
    let reference = (0..films.len())
        .filter(|&k| usable[k])
        .max_by_key(|&k| films[k].spp);
    let measured_on = |c: usize| -> Option<Vec<f64>> {
        let per_sample: Vec<f64> = sample_vars
            .iter()
            .map(|sv| mean_sample_variance(sv, (0..n).filter(|&i| colour(i, width) == c)))
            .collect();
        let floor = reference.map_or(0.0, |r| per_sample[r]);
        let variances: Vec<f64> = per_sample
            .iter()
            .zip(&films)
            .map(|(&v, f)| v.max(floor) / f.spp as f64)
            .collect();
        normalised_weights(&variances, &films, &usable)
    };
    // applied[c]: the weights that combine colour c's pixels (pixel 1 is
    // of colour 1 in any image of more than one pixel).
    let applied: [Vec<f64>; 2] = if n > 1 {
        [measured_on(1)?, measured_on(0)?]
    } else {
        let own = measured_on(0)?;
        [own.clone(), own]
    };
    let mut pixels = vec![DVec3::ZERO; n];
    let mut variance = vec![0f64; n];
    for (k, (f, sample_var)) in films.iter().zip(&sample_vars).enumerate() {
        let inv_spp = 1.0 / f.spp as f64;
        for i in 0..n {
            let a = applied[colour(i, width)][k];
            if a == 0.0 {
                continue;
            }
            pixels[i] += f.sum[i] * (a * inv_spp);
            variance[i] += a * a * sample_var[i] * inv_spp;
        }
    }
    let share = |c: usize| (0..n).filter(|&i| colour(i, width) == c).count() as f64 / n as f64;
    let (share0, share1) = (share(0), share(1));
    let mean_weights = (0..films.len())
        .map(|k| share0 * applied[0][k] + share1 * applied[1][k])
        .collect();
    Some((
        Image {
            width: first.width,
            height: first.height,
            pixels: pixels.iter().map(|p| p.as_vec3()).collect(),
        },
        variance,
        mean_weights,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Spectrum;
    use crate::sampling::Rng;

    fn film(samples: &[f32]) -> Film {
        let mut f = Film::new(1, 1);
        for &x in samples {
            f.add_pass(&[Spectrum::splat(x)]);
        }
        f
    }

    /// Per-sample variance measured from `n`-spp films of a heavy-tailed
    /// estimator (1 almost always, 1000 with probability 1e-3).
    fn measured_per_sample_variance(n: u32) -> f64 {
        let (w, h) = (200, 200);
        let mut film = Film::new(w, h);
        let mut rng = Rng::new(9, n as u64);
        for _ in 0..n {
            let pass: Vec<Spectrum> = (0..w * h)
                .map(|_| Spectrum::splat(if rng.next_f32() < 1e-3 { 1000.0 } else { 1.0 }))
                .collect();
            film.add_pass(&pass);
        }
        let nf = n as f64;
        iteration_variance(&film, &pooled_mean(&[&film])).0 * nf / (nf - 1.0) * nf
    }

    #[test]
    fn iteration_variance_does_not_depend_on_the_sample_count() {
        // True variance: 1e-3·(1000 − 1.999)² + (1 − 1e-3)·(1 − 1.999)² ≈ 997.
        let truth = 1e-3 * 998.001f64.powi(2) + 0.999 * 0.999f64.powi(2);
        for n in [4, 64] {
            let v = measured_per_sample_variance(n);
            assert!((v / truth - 1.0).abs() < 0.25, "n = {n}: {v} vs {truth}");
        }
    }

    /// A huge finite sample (1e20: its square overflows f32) leaves its
    /// iteration a finite variance and a weight; with f32 sums of squares
    /// the variance was ∞ and the iteration silently got weight 0.
    #[test]
    fn a_huge_finite_sample_keeps_its_iteration_in_the_combination() {
        // 10 samples: the pooled mean 1e19 keeps A's spread about it (1e38)
        // within f32, while B's sum of squares (1e40) is not.
        let (a, b) = (film(&[1.0; 8]), film(&[1e20, 0.0]));
        let mut dropped = 0;
        let (image, variance, weights) = combine_counting(&[&a, &b], &mut dropped).unwrap();
        assert!(weights[1] > 0.0 && weights[0] > weights[1], "{weights:?}");
        assert!(crate::math::is_finite3(image.pixels[0]), "{image:?}");
        assert!(variance[0].is_finite(), "{variance:?}");
        assert_eq!(dropped, 0);
    }

    /// An iteration whose sums are not finite is left out of the image and
    /// counted, including where the others would be weighed by spp.
    #[test]
    fn an_iteration_with_non_finite_variance_is_dropped_and_counted() {
        let (a, mut b, c) = (film(&[1.0, 3.0]), film(&[2.0, 2.0]), film(&[2.0, 2.0]));
        b.sum[0] = DVec3::splat(f64::NAN);
        b.sum_sq[0] = DVec3::splat(f64::INFINITY);
        let mut dropped = 0;
        let (image, _, weights) = combine_counting(&[&a, &b], &mut dropped).unwrap();
        assert_eq!((dropped, weights[1]), (1, 0.0));
        assert_eq!(image.pixels[0], Spectrum::splat(2.0));
        // C alone has zero variance about the pooled mean: spp weights.
        let (image, _, weights) = combine_counting(&[&c, &b], &mut dropped).unwrap();
        assert_eq!((dropped, weights[1]), (2, 0.0));
        assert_eq!(image.pixels[0], Spectrum::splat(2.0));
        assert!(combine_counting(&[&b], &mut dropped).is_none());
        assert_eq!(dropped, 3);
    }

    /// Films of iterations of 1, 2, 4, … spp of an estimator that is 0 almost
    /// always and 1/p with probability p (mean 1 in every pixel): rare
    /// bright paths carry the whole mean, as caustics of a small light do.
    fn firefly_iterations(seed: u64, w: usize, h: usize, p: f32) -> Vec<Film> {
        let mut rng = Rng::new(seed, 0);
        (0..6)
            .map(|k| {
                let mut film = Film::new(w, h);
                for _ in 0..1u32 << k {
                    let pass: Vec<Spectrum> = (0..w * h)
                        .map(|_| Spectrum::splat(if rng.next_f32() < p { 1.0 / p } else { 0.0 }))
                        .collect();
                    film.add_pass(&pass);
                }
                film
            })
            .collect()
    }

    /// Weights measured on the images they weigh pull a firefly-carried
    /// mean low; measured on the other checkerboard colour, they do not.
    /// The self-weighted combination is the control: it must show the bias
    /// this test is sensitive to. The floor at the largest film's variance
    /// keeps the typical image (the median) at the mean too: without it the
    /// median is 0.875, with it 1.002.
    #[test]
    fn combination_is_unbiased_and_typical_where_fireflies_carry_the_mean() {
        let (w, h, p) = (16, 16, 2e-3);
        let self_weighted = |films: &[&Film]| -> f64 {
            let mu = pooled_mean(films);
            let v: Vec<f64> = films.iter().map(|f| iteration_variance(f, &mu).0).collect();
            let wts = normalised_weights(&v, films, &vec![true; films.len()]).unwrap();
            let mut total = 0.0;
            for (f, wt) in films.iter().zip(&wts) {
                let mean: f64 =
                    f.sum.iter().map(|s| s.x).sum::<f64>() / (f.spp as f64 * (w * h) as f64);
                total += wt * mean;
            }
            total
        };
        let (mut checker, mut own) = (Vec::new(), Vec::new());
        for seed in 0..400 {
            let films = firefly_iterations(seed, w, h, p);
            let refs: Vec<&Film> = films.iter().collect();
            let (image, _, weights) = combine(&refs).unwrap();
            assert!((weights.iter().sum::<f64>() - 1.0).abs() < 1e-9);
            checker.push(image.pixels.iter().map(|s| s[0] as f64).sum::<f64>() / (w * h) as f64);
            own.push(self_weighted(&refs));
        }
        let mean_and_error = |x: &[f64]| {
            let n = x.len() as f64;
            let m = x.iter().sum::<f64>() / n;
            let var = x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1.0);
            (m, (var / n).sqrt())
        };
        let (m_checker, e_checker) = mean_and_error(&checker);
        let (m_own, e_own) = mean_and_error(&own);
        let median = |x: &mut Vec<f64>| {
            x.sort_by(f64::total_cmp);
            x[x.len() / 2]
        };
        let (med_checker, med_own) = (median(&mut checker.clone()), median(&mut own.clone()));
        eprintln!(
            "checkerboard {m_checker:.4} ± {e_checker:.4} (median {med_checker:.4}), \
             own weights {m_own:.4} ± {e_own:.4} (median {med_own:.4})"
        );
        assert!(
            (m_checker - 1.0).abs() < 4.0 * e_checker,
            "checkerboard weights: mean {m_checker} ± {e_checker}"
        );
        // The typical image, too, is the mean's, not a skewed low one.
        assert!(
            (med_checker - 1.0).abs() < 0.05,
            "median combination {med_checker}"
        );
        assert!(
            m_own < 1.0 - 4.0 * e_own,
            "the control shows no bias: {m_own} ± {e_own}"
        );
    }
}
