//! The accumulation film: per-pixel sums of samples and of their squares,
//! so every image comes with a variance estimate (used by the inverse-
//! variance combination of guiding iterations and by the experiments).

use crate::math::Spectrum;
use glam::DVec3;

#[derive(Clone, Debug)]
pub struct Film {
    pub width: usize,
    pub height: usize,
    /// In f64: the square of a finite f32 sample above ~1.8e19, or a sum of
    /// a few near f32::MAX, overflows f32, and one ∞ made the pixel's
    /// variance, and with it a whole iteration's weight, unusable.
    pub sum: Vec<DVec3>,
    pub sum_sq: Vec<DVec3>,
    /// Samples per pixel accumulated so far.
    pub spp: u32,
}

impl Film {
    pub fn new(width: usize, height: usize) -> Self {
        Film {
            width,
            height,
            sum: vec![DVec3::ZERO; width * height],
            sum_sq: vec![DVec3::ZERO; width * height],
            spp: 0,
        }
    }

    /// Adds one pass (one sample per pixel) given as a row-major image.
    pub fn add_pass(&mut self, pass: &[Spectrum]) {
        for ((s, q), &v) in self.sum.iter_mut().zip(self.sum_sq.iter_mut()).zip(pass) {
            add_sample(s, q, v);
        }
        self.spp += 1;
    }

    pub fn merge(&mut self, other: &Film) {
        for i in 0..self.sum.len() {
            self.sum[i] += other.sum[i];
            self.sum_sq[i] += other.sum_sq[i];
        }
        self.spp += other.spp;
    }

    /// Finite for finite samples: a mean of f32 values stays in f32's range.
    pub fn mean(&self) -> Vec<Spectrum> {
        let inv = if self.spp > 0 {
            1.0 / self.spp as f64
        } else {
            0.0
        };
        self.sum.iter().map(|&s| (s * inv).as_vec3()).collect()
    }

    pub fn image(&self) -> Image {
        Image {
            width: self.width,
            height: self.height,
            pixels: self.mean(),
        }
    }

    /// Per-pixel variance of the mean (sample variance / spp), averaged over channels.
    pub fn variance_of_mean(&self) -> Vec<f64> {
        let n = self.spp as f64;
        self.sum
            .iter()
            .zip(&self.sum_sq)
            .map(|(s, q)| {
                if n < 2.0 {
                    return f64::INFINITY;
                }
                let mut v = 0.0f64;
                for c in 0..3 {
                    let mean = s[c] / n;
                    let var = ((q[c] / n) - mean * mean).max(0.0) * n / (n - 1.0);
                    v += var / n;
                }
                v / 3.0
            })
            .collect()
    }
}

/// Adds the sample `v` to a pixel's sums, as [`Film::add_pass`] does.
#[inline]
pub fn add_sample(sum: &mut DVec3, sum_sq: &mut DVec3, v: Spectrum) {
    let v = v.as_dvec3();
    *sum += v;
    *sum_sq += v * v;
}

/// A finished image (linear RGB, row-major, top row first).
#[derive(Clone, Debug)]
pub struct Image {
    pub width: usize,
    pub height: usize,
    pub pixels: Vec<Spectrum>,
}

impl Image {
    /// Refuses an image with a NaN, Inf or negative channel, against which
    /// an error metric is NaN or meaningless: the error names the image
    /// (`what`), how many pixels are bad, and the first of them.
    pub fn check_valid(&self, what: &str) -> Result<(), String> {
        let bad = |p: &Spectrum| !crate::math::is_finite3(*p) || p.min_element() < 0.0;
        let Some(first) = self.pixels.iter().position(bad) else {
            return Ok(());
        };
        let count = self.pixels.iter().filter(|p| bad(p)).count();
        let w = self.width.max(1);
        let p = self.pixels[first];
        Err(format!(
            "{what} has {count} pixels with NaN, Inf or negative values, the first at ({}, {}): ({}, {}, {})",
            first % w,
            first / w,
            p.x,
            p.y,
            p.z
        ))
    }

    pub fn mean_rgb(&self) -> Spectrum {
        let s: glam::DVec3 = self.pixels.iter().map(|p| p.as_dvec3()).sum();
        (s / self.pixels.len().max(1) as f64).as_vec3()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Samples near f32::MAX sum without overflow: the mean stays finite;
    /// and a sample whose square overflows f32 (2e19² = 4e38) leaves a
    /// variance of the mean that f32 holds (~1e38) finite.
    #[test]
    fn huge_finite_samples_keep_mean_and_variance_finite() {
        let film = |samples: &[f32]| {
            let mut film = Film::new(1, 1);
            for &x in samples {
                film.add_pass(&[Spectrum::splat(x)]);
            }
            film
        };
        let mean = film(&[3e38, 3e38, 1e20]).mean()[0];
        assert!(crate::math::is_finite3(mean) && mean.x > 1e38, "{mean}");
        let variance = film(&[2e19, 0.0, 0.0, 0.0]).variance_of_mean()[0];
        assert!((variance / 2.5e37 - 1.0).abs() < 1e-6, "{variance}");
    }
}
