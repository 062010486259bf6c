//! The inverse-variance combination of the iterations' images (DESIGN.md
//! §5), and the per-iteration variance it and the strategy trial weigh
//! iterations by. Everything is computed in f64 from the films' f64 sums,
//! so a finite sample can never make a variance infinite.

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
    let spp = film.spp.max(1) as f64;
    let total: f64 = sample_var
        .iter()
        .map(|&v| if v.is_finite() { v } else { f64::INFINITY })
        .sum();
    (total / sample_var.len().max(1) as f64 / spp, sample_var)
}

/// Efficiency 1 / (variance per sample × seconds per sample) of `film`
/// rendered in `seconds`, its variance measured about `mu`. The spp cancel:
/// it is 1 / (variance of the film's mean × seconds).
pub(super) fn efficiency(film: &Film, seconds: f64, mu: &[DVec3]) -> f64 {
    1.0 / (iteration_variance(film, mu).0 * seconds)
}

/// Inverse-variance combination of iteration images (weights 1/mean
/// variance, DESIGN.md §5), with the per-pixel variance of the combination
/// and the normalised weights.
pub fn combine(films: &[&Film]) -> Option<(Image, Vec<f32>, Vec<f64>)> {
    combine_counting(films, &mut 0)
}

/// [`combine`], adding to `dropped` the iterations left out because their
/// variance is not finite (their sums could not be trusted in the image).
pub fn combine_counting(films: &[&Film], dropped: &mut u64) -> Option<(Image, Vec<f32>, Vec<f64>)> {
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
    let mu = pooled_mean(&trusted);
    let per_film: Vec<(f64, Vec<f64>)> = films.iter().map(|f| iteration_variance(f, &mu)).collect();
    let usable: Vec<bool> = per_film.iter().map(|(v, _)| v.is_finite()).collect();
    *dropped += usable.iter().filter(|&&u| !u).count() as u64;
    let mut weights: Vec<f64> = per_film
        .iter()
        .map(|(v, _)| {
            if v.is_finite() && *v > 0.0 {
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
            .zip(&usable)
            .map(|(f, &u)| if u { f.spp as f64 } else { 0.0 })
            .collect();
    }
    let total: f64 = weights.iter().sum();
    if !(total > 0.0) {
        return None;
    }
    let n = first.width * first.height;
    let mut pixels = vec![DVec3::ZERO; n];
    let mut variance = vec![0f64; n];
    for ((f, (_, sample_var)), &w) in films.iter().zip(&per_film).zip(&weights) {
        if w == 0.0 {
            continue;
        }
        let a = w / total;
        let inv_spp = 1.0 / f.spp as f64;
        for i in 0..n {
            pixels[i] += f.sum[i] * (a * inv_spp);
            variance[i] += a * a * sample_var[i] * inv_spp;
        }
    }
    let normalized: Vec<f64> = weights.iter().map(|w| w / total).collect();
    Some((
        Image {
            width: first.width,
            height: first.height,
            pixels: pixels.iter().map(|p| p.as_vec3()).collect(),
        },
        variance.iter().map(|&v| v as f32).collect(),
        normalized,
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
}
