//! The accumulation film: per-pixel sums of samples and of their squares,
//! so every image comes with a variance estimate (used by the inverse-
//! variance combination of guiding iterations and by the experiments).

use crate::math::Spectrum;

#[derive(Clone, Debug)]
pub struct Film {
    pub width: usize,
    pub height: usize,
    pub sum: Vec<Spectrum>,
    pub sum_sq: Vec<Spectrum>,
    /// Samples per pixel accumulated so far.
    pub spp: u32,
}

impl Film {
    pub fn new(width: usize, height: usize) -> Self {
        Film {
            width,
            height,
            sum: vec![Spectrum::ZERO; width * height],
            sum_sq: vec![Spectrum::ZERO; width * height],
            spp: 0,
        }
    }

    /// Adds one pass (one sample per pixel) given as a row-major image.
    pub fn add_pass(&mut self, pass: &[Spectrum]) {
        for ((s, q), &v) in self.sum.iter_mut().zip(self.sum_sq.iter_mut()).zip(pass) {
            *s += v;
            *q += v * v;
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

    pub fn mean(&self) -> Vec<Spectrum> {
        let inv = if self.spp > 0 {
            1.0 / self.spp as f32
        } else {
            0.0
        };
        self.sum.iter().map(|&s| s * inv).collect()
    }

    pub fn image(&self) -> Image {
        Image {
            width: self.width,
            height: self.height,
            pixels: self.mean(),
        }
    }

    /// Per-pixel variance of the mean (sample variance / spp), averaged over channels.
    pub fn variance_of_mean(&self) -> Vec<f32> {
        let n = self.spp as f64;
        self.sum
            .iter()
            .zip(&self.sum_sq)
            .map(|(s, q)| {
                if n < 2.0 {
                    return f32::INFINITY;
                }
                let mut v = 0.0f64;
                for c in 0..3 {
                    let mean = s[c] as f64 / n;
                    let var = ((q[c] as f64 / n) - mean * mean).max(0.0) * n / (n - 1.0);
                    v += var / n;
                }
                (v / 3.0) as f32
            })
            .collect()
    }
}

/// A finished image (linear RGB, row-major, top row first).
#[derive(Clone, Debug)]
pub struct Image {
    pub width: usize,
    pub height: usize,
    pub pixels: Vec<Spectrum>,
}

impl Image {
    pub fn mean_rgb(&self) -> Spectrum {
        let s: glam::DVec3 = self.pixels.iter().map(|p| p.as_dvec3()).sum();
        (s / self.pixels.len().max(1) as f64).as_vec3()
    }
}
