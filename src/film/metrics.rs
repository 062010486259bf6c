//! Error metrics of DESIGN.md §6, computed in f64.

use super::image::Image;
use crate::math::Spectrum;

/// ε of relMSE's normaliser R² + ε (DESIGN §6): keeps dark pixels from
/// dominating.
pub const RELMSE_EPSILON: f64 = 1e-2;

/// relMSE's term of one channel: (I − R)² / (R² + 1e-2).
#[inline]
fn relative_squared_error(i: f32, r: f32) -> f64 {
    let (iv, rv) = (i as f64, r as f64);
    (iv - rv).powi(2) / (rv * rv + RELMSE_EPSILON)
}

/// relMSE = mean over pixels and channels of (I − R)² / (R² + 1e-2).
pub fn relmse(image: &Image, reference: &Image) -> Result<f64, String> {
    check_sizes(image, reference)?;
    let mut acc = 0.0f64;
    for (i, r) in image.pixels.iter().zip(&reference.pixels) {
        for c in 0..3 {
            acc += relative_squared_error(i[c], r[c]);
        }
    }
    Ok(acc / (3 * image.pixels.len()) as f64)
}

/// MAE (the paper's L1) = mean over pixels and channels of |I − R|.
pub fn mae(image: &Image, reference: &Image) -> Result<f64, String> {
    check_sizes(image, reference)?;
    let mut acc = 0.0f64;
    for (i, r) in image.pixels.iter().zip(&reference.pixels) {
        for c in 0..3 {
            acc += (i[c] as f64 - r[c] as f64).abs();
        }
    }
    Ok(acc / (3 * image.pixels.len()) as f64)
}

/// Where relMSE sits: the worst `worst_pixels` pixels' share of it, and
/// relMSE over the remaining pixels. Path-traced error is heavy tailed (one
/// firefly can carry most of an image's relMSE), so two images with the
/// same relMSE can differ in everything but a few pixels; this tells which.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RelmseTail {
    pub worst_pixels: usize,
    /// In [0, 1]; 0 for an image equal to its reference.
    pub worst_share: f64,
    /// relMSE with the worst pixels left out.
    pub without_worst: f64,
}

/// The worst pixels' fraction that `error` reports the relMSE share of, and
/// that `compare` leaves out of its trimmed relMSE: 0.1 %, the outlier
/// rule of several path-guiding papers' error tables.
pub const WORST_PIXEL_FRACTION: f64 = 1e-3;

/// relMSE without the worst [`WORST_PIXEL_FRACTION`] of the pixels, or
/// `None` where that is undefined (an image of one pixel, or one holding
/// NaN or Inf, whose plain relMSE then shows it). A comparison's relMSE can
/// be a few fireflies; this figure says whether the rest of the image
/// agrees.
pub fn relmse_trimmed(image: &Image, reference: &Image) -> Result<Option<f64>, String> {
    // Checked here so that the `ok()` below turns only the undefined cases
    // into `None`, never a size mismatch.
    check_sizes(image, reference)?;
    Ok(relmse_tail(image, reference, WORST_PIXEL_FRACTION)
        .ok()
        .map(|t| t.without_worst))
}

/// [`RelmseTail`] for the worst `fraction` of the pixels (at least one,
/// and at least one left), ranked by their relative squared error summed
/// over channels.
pub fn relmse_tail(image: &Image, reference: &Image, fraction: f64) -> Result<RelmseTail, String> {
    check_sizes(image, reference)?;
    if !(fraction > 0.0 && fraction < 1.0) {
        return Err(format!(
            "the worst-pixel fraction must lie in (0, 1), not {fraction}"
        ));
    }
    let mut per_pixel: Vec<f64> = image
        .pixels
        .iter()
        .zip(&reference.pixels)
        .map(|(i, r)| (0..3).map(|c| relative_squared_error(i[c], r[c])).sum())
        .collect();
    let n = per_pixel.len();
    if n < 2 {
        return Err("an image of one pixel has no tail".into());
    }
    let worst = ((fraction * n as f64).ceil() as usize).clamp(1, n - 1);
    // Largest errors first.
    per_pixel.select_nth_unstable_by(worst - 1, |a, b| b.total_cmp(a));
    let worst_sum: f64 = per_pixel[..worst].iter().sum();
    let rest_sum: f64 = per_pixel[worst..].iter().sum();
    let total = worst_sum + rest_sum;
    // A NaN or Inf pixel has no share to report (its relMSE is NaN or Inf too).
    if !total.is_finite() {
        return Err("the image or the reference holds NaN or Inf pixels".into());
    }
    Ok(RelmseTail {
        worst_pixels: worst,
        worst_share: if total > 0.0 { worst_sum / total } else { 0.0 },
        without_worst: rest_sum / (3 * (n - worst)) as f64,
    })
}

/// Whether an image is brighter or darker than its reference beyond their
/// noise. relMSE and MAE cannot tell a noisy image from a biased one; the
/// mean difference can, if its noise is known. Neighbouring pixels' errors
/// are correlated (shared paths, filter, guiding structures), so the noise
/// is estimated from the means of square blocks of pixels, not from single
/// pixels: with n blocks of means d_b, the standard error is the spread of
/// the d_b over √n. The reference's own noise is part of that spread.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeanBias {
    /// Mean over pixels and channels of the image.
    pub image_mean: f64,
    /// The same for the reference.
    pub reference_mean: f64,
    /// Standard error of `image_mean − reference_mean`.
    pub standard_error: f64,
    /// Number of blocks the standard error was estimated from.
    pub blocks: usize,
}

impl MeanBias {
    pub fn difference(&self) -> f64 {
        self.image_mean - self.reference_mean
    }

    /// image mean / reference mean.
    pub fn ratio(&self) -> f64 {
        self.image_mean / self.reference_mean
    }

    /// The difference in standard errors: beyond ±4 the two means differ by
    /// more than this estimate of their noise explains. 0 for equal means,
    /// ±∞ for different means without noise.
    pub fn z(&self) -> f64 {
        let d = self.difference();
        if d == 0.0 {
            0.0
        } else {
            d / self.standard_error
        }
    }
}

/// [`MeanBias`] with blocks of `block`×`block` pixels (partial blocks at the
/// right and bottom edges are left out of the standard error, not of the
/// means). Needs at least 8 whole blocks, finite pixels, and a reference
/// with a positive mean.
pub fn mean_bias(image: &Image, reference: &Image, block: usize) -> Result<MeanBias, String> {
    check_sizes(image, reference)?;
    if block == 0 {
        return Err("the block size must be at least 1 pixel".into());
    }
    let (bw, bh) = (image.width / block, image.height / block);
    if bw * bh < 8 {
        return Err(format!(
            "a {}×{} image holds {} whole blocks of {block}×{block} pixels; the standard error needs 8",
            image.width,
            image.height,
            bw * bh
        ));
    }
    let channel_mean = |p: &Spectrum| (p.x as f64 + p.y as f64 + p.z as f64) / 3.0;
    let n = image.pixels.len() as f64;
    let image_mean = image.pixels.iter().map(channel_mean).sum::<f64>() / n;
    let reference_mean = reference.pixels.iter().map(channel_mean).sum::<f64>() / n;
    if !(image_mean.is_finite() && reference_mean.is_finite()) {
        return Err("the image or the reference holds NaN or Inf pixels".into());
    }
    if !(reference_mean > 0.0) {
        return Err("the reference is black: its mean is not positive".into());
    }
    let mut block_means = Vec::with_capacity(bw * bh);
    for by in 0..bh {
        for bx in 0..bw {
            let mut sum = 0.0;
            for y in by * block..(by + 1) * block {
                let row = y * image.width;
                for x in bx * block..(bx + 1) * block {
                    sum += channel_mean(&image.pixels[row + x])
                        - channel_mean(&reference.pixels[row + x]);
                }
            }
            block_means.push(sum / (block * block) as f64);
        }
    }
    let m = block_means.len() as f64;
    let mean = block_means.iter().sum::<f64>() / m;
    let variance = block_means.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / (m - 1.0);
    Ok(MeanBias {
        image_mean,
        reference_mean,
        standard_error: (variance / m).sqrt(),
        blocks: block_means.len(),
    })
}

fn check_sizes(image: &Image, reference: &Image) -> Result<(), String> {
    if image.width != reference.width || image.height != reference.height {
        return Err(format!(
            "image is {}×{} but the reference is {}×{}",
            image.width, image.height, reference.width, reference.height
        ));
    }
    if image.pixels.is_empty() {
        return Err("empty image".into());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn metrics_match_hand_computed_values() {
        let reference = Image {
            width: 2,
            height: 1,
            pixels: vec![Vec3::new(1.0, 0.0, 0.5), Vec3::splat(0.1)],
        };
        let image = Image {
            width: 2,
            height: 1,
            pixels: vec![Vec3::new(1.5, 0.1, 0.5), Vec3::splat(0.1)],
        };
        // |diffs| = 0.5, 0.1, 0, 0, 0, 0 → MAE = 0.6 / 6
        assert!((mae(&image, &reference).unwrap() - 0.1).abs() < 1e-7);
        // 0.25/(1+0.01) + 0.01/(0+0.01) = 0.247525 + 1 → /6
        let expected = (0.25 / 1.01 + 0.01f64 / 0.01) / 6.0;
        assert!((relmse(&image, &reference).unwrap() - expected).abs() < 1e-6);
        let small = Image {
            width: 1,
            height: 1,
            pixels: vec![Vec3::ZERO],
        };
        assert!(mae(&small, &reference).is_err());
    }

    #[test]
    fn tail_separates_one_firefly_from_broad_noise() {
        let n = 1000;
        let reference = Image {
            width: n,
            height: 1,
            pixels: vec![Vec3::splat(1.0); n],
        };
        // Broad noise: every pixel off by 0.1; one firefly off by 30.
        let mut image = Image {
            width: n,
            height: 1,
            pixels: vec![Vec3::splat(1.1); n],
        };
        image.pixels[417] = Vec3::splat(31.0);
        let total = relmse(&image, &reference).unwrap();
        let tail = relmse_tail(&image, &reference, 1e-3).unwrap();
        assert_eq!(tail.worst_pixels, 1);
        // 900 against 999 × 0.01: the firefly holds ≈ 99 % of relMSE.
        let firefly = 900.0 / 1.01;
        let broad = 0.01 / 1.01;
        let expected_share = firefly / (firefly + (n - 1) as f64 * broad);
        // (1.1 and 31 in f32 are off by ~2e-8, 2e-6 relative in the squares.)
        assert!((tail.worst_share - expected_share).abs() < 1e-5, "{tail:?}");
        assert!((tail.without_worst / broad - 1.0).abs() < 1e-5, "{tail:?}");
        // The parts add up to relMSE.
        let recombined = tail.without_worst * (n - 1) as f64 / n as f64 / (1.0 - tail.worst_share);
        assert!(
            (recombined / total - 1.0).abs() < 1e-9,
            "{recombined} {total}"
        );
        // An exact image has no tail; a bad fraction is refused.
        let exact = relmse_tail(&reference, &reference, 0.01).unwrap();
        assert_eq!((exact.worst_share, exact.without_worst), (0.0, 0.0));
        assert!(relmse_tail(&image, &reference, 0.0).is_err());
        assert!(relmse_tail(&image, &reference, f64::NAN).is_err());
        assert!(relmse_tail(&image, &reference, 1.0).is_err());
        // compare's trimmed relMSE is the tail's rest at 0.1 %.
        assert_eq!(
            relmse_trimmed(&image, &reference).unwrap(),
            Some(tail.without_worst)
        );
        image.pixels[3] = Vec3::new(f32::NAN, 1.0, 1.0);
        assert!(relmse_tail(&image, &reference, 1e-3).is_err());
        // Undefined, not an error, for a NaN image (its relMSE shows the
        // NaN) and for one pixel; a size mismatch is refused.
        assert_eq!(relmse_trimmed(&image, &reference).unwrap(), None);
        let one = Image {
            width: 1,
            height: 1,
            pixels: vec![Vec3::ONE],
        };
        assert_eq!(relmse_trimmed(&one, &one).unwrap(), None);
        assert!(relmse_trimmed(&one, &reference).is_err());
    }

    /// A deterministic stand-in for zero-mean noise: uniform in [-1, 1).
    fn noise(i: usize) -> f32 {
        let h = (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0xD1B5_4A32_D192_ED03;
        let h = h.wrapping_mul(0xBF58_476D_1CE4_E5B9);
        ((h >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
    }

    #[test]
    fn mean_bias_tells_a_biased_image_from_a_noisy_one() {
        let (w, h) = (128, 96);
        let reference = Image {
            width: w,
            height: h,
            pixels: (0..w * h)
                .map(|i| Vec3::splat(0.5 + 0.4 * ((i % w) as f32 / w as f32)))
                .collect(),
        };
        let noisy = |scale: f32, amplitude: f32| Image {
            width: w,
            height: h,
            pixels: reference
                .pixels
                .iter()
                .enumerate()
                .map(|(i, r)| *r * scale + Vec3::splat(amplitude * noise(i)))
                .collect(),
        };
        // Zero-mean noise of amplitude 0.3: no bias at any block size.
        for block in [1, 8, 16] {
            let b = mean_bias(&noisy(1.0, 0.3), &reference, block).unwrap();
            assert!(b.z().abs() < 4.0, "block {block}: {b:?} z {}", b.z());
            assert!((b.ratio() - 1.0).abs() < 0.01, "{b:?}");
        }
        // 2 % brighter under the same noise: found, and measured.
        let b = mean_bias(&noisy(1.02, 0.3), &reference, 16).unwrap();
        assert!(b.z() > 4.0, "{b:?} z {}", b.z());
        assert!((b.ratio() - 1.02).abs() < 0.005, "{b:?}");
        assert_eq!(b.blocks, 8 * 6);
        // Noise 30× larger hides the same 2 %.
        let b = mean_bias(&noisy(1.02, 9.0), &reference, 16).unwrap();
        assert!(b.z().abs() < 4.0, "{b:?} z {}", b.z());
        // Equal images: no difference and no noise.
        let same = mean_bias(&reference, &reference, 16).unwrap();
        assert_eq!((same.difference(), same.z()), (0.0, 0.0));
        // Bad input is refused with a reason.
        assert!(mean_bias(&reference, &reference, 0).is_err());
        assert!(mean_bias(&reference, &reference, 64).is_err());
        let black = Image {
            width: w,
            height: h,
            pixels: vec![Vec3::ZERO; w * h],
        };
        assert!(mean_bias(&reference, &black, 16).is_err());
        let mut bad = reference.clone();
        bad.pixels[5] = Vec3::splat(f32::INFINITY);
        assert!(mean_bias(&bad, &reference, 16).is_err());
    }
}
