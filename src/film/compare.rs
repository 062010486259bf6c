//! Statistical comparison of two noisy images (or a noisy image and a noisy
//! reference): block means with their standard errors, turned into z-scores.
//!
//! A pixel's Monte Carlo estimate is too noisy, and too heavy-tailed, for a
//! per-pixel test at low spp; averaging B×B blocks makes each block mean the
//! mean of B²·spp samples, close enough to normal for a z-test. The variance
//! of a block mean is the sum of its pixels' variances of the mean / B⁴.

use super::image::Image;

/// Block z-scores of the luminance of `a` against `b`, given each image's
/// per-pixel variance of the mean (averaged over channels, as
/// [`Film::variance_of_mean`](super::image::Film::variance_of_mean) returns).
#[derive(Clone, Debug)]
pub struct BlockComparison {
    pub z: Vec<f64>,
    pub mean_a: f64,
    pub mean_b: f64,
    /// z-score of the difference of the whole-image means.
    pub z_global: f64,
}

impl BlockComparison {
    /// Mean of z² over blocks: ≈ 1 when the images agree and the variances are right.
    pub fn mean_z2(&self) -> f64 {
        self.z.iter().map(|z| z * z).sum::<f64>() / self.z.len().max(1) as f64
    }

    /// Median of z² over blocks: ≈ 0.455 (the χ²₁ median) when the images
    /// agree. Unlike the mean it survives a few blocks whose variance was
    /// underestimated, which heavy-tailed estimators (roulette with large
    /// weights) produce at low sample counts.
    pub fn median_z2(&self) -> f64 {
        let mut z2: Vec<f64> = self.z.iter().map(|z| z * z).collect();
        if z2.is_empty() {
            return 0.0;
        }
        z2.sort_by(f64::total_cmp);
        let n = z2.len();
        if n % 2 == 1 {
            z2[n / 2]
        } else {
            0.5 * (z2[n / 2 - 1] + z2[n / 2])
        }
    }

    pub fn max_abs_z(&self) -> f64 {
        self.z.iter().fold(0.0f64, |m, z| m.max(z.abs()))
    }

    /// Fraction of blocks with |z| above `k`.
    pub fn fraction_above(&self, k: f64) -> f64 {
        self.z.iter().filter(|z| z.abs() > k).count() as f64 / self.z.len().max(1) as f64
    }
}

/// Relative rounding of f32 image data accumulated over many samples.
const RELATIVE_ROUNDING: f64 = 1e-5;

fn lum(p: glam::Vec3) -> f64 {
    (0.212671 * p.x + 0.715160 * p.y + 0.072169 * p.z) as f64
}

/// Compares block means. Variances are per pixel, of the mean, per channel
/// average; luminance variance is approximated by that average. That is
/// exact for grey noise (channels equal and fully correlated), an
/// over-estimate where the channels' noise is independent (luminance's
/// weights have Σw² = 0.56), and an under-estimate by up to 3·0.715² = 1.53×
/// where the noise is all in green (|z| up to 1.24× too large): an error
/// towards failing an agreement test, never towards passing a biased image.
pub fn compare_blocks(
    a: &Image,
    var_a: &[f64],
    b: &Image,
    var_b: &[f64],
    block: usize,
) -> Result<BlockComparison, String> {
    if a.width != b.width || a.height != b.height {
        return Err(format!(
            "sizes differ: {}×{} vs {}×{}",
            a.width, a.height, b.width, b.height
        ));
    }
    let (w, h) = (a.width, a.height);
    let (bw, bh) = (w / block, h / block);
    if bw == 0 || bh == 0 {
        return Err("block larger than the image".into());
    }
    let mut z = Vec::with_capacity(bw * bh);
    let (mut sa, mut sb, mut sv) = (0.0f64, 0.0f64, 0.0f64);
    let n_total = (bw * bh * block * block) as f64;
    for by in 0..bh {
        for bx in 0..bw {
            let (mut ma, mut mb, mut v) = (0.0f64, 0.0f64, 0.0f64);
            for y in by * block..(by + 1) * block {
                for x in bx * block..(bx + 1) * block {
                    let i = y * w + x;
                    ma += lum(a.pixels[i]);
                    mb += lum(b.pixels[i]);
                    v += var_a[i] + var_b[i];
                }
            }
            sa += ma;
            sb += mb;
            sv += v;
            let n = (block * block) as f64;
            let (ma, mb, v) = (ma / n, mb / n, v / (n * n));
            // Float rounding (e.g. of a directly seen, constant emitter in an
            // f32 file) is not noise the variance sees: floor it.
            let v = v + (RELATIVE_ROUNDING * mb.abs().max(ma.abs())).powi(2);
            z.push(if v > 0.0 { (ma - mb) / v.sqrt() } else { 0.0 });
        }
    }
    let z_global = if sv > 0.0 { (sa - sb) / sv.sqrt() } else { 0.0 };
    Ok(BlockComparison {
        z,
        mean_a: sa / n_total,
        mean_b: sb / n_total,
        z_global,
    })
}

#[cfg(test)]
mod tests {
    use super::BlockComparison;

    #[test]
    fn median_z2_matches_hand_computed_values() {
        let c = |z: Vec<f64>| BlockComparison {
            z,
            mean_a: 0.0,
            mean_b: 0.0,
            z_global: 0.0,
        };
        // z² = 9, 1, 4 → median 4; one huge outlier does not move it much.
        assert_eq!(c(vec![3.0, -1.0, 2.0]).median_z2(), 4.0);
        assert_eq!(c(vec![3.0, -1.0, 2.0, 1e6]).median_z2(), 6.5);
        assert_eq!(c(vec![]).median_z2(), 0.0);
    }
}
