//! Error metrics of DESIGN.md §6, computed in f64.

use super::image::Image;

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
        image.pixels[3] = Vec3::new(f32::NAN, 1.0, 1.0);
        assert!(relmse_tail(&image, &reference, 1e-3).is_err());
    }
}
