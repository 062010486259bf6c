//! Error metrics of DESIGN.md §6, computed in f64.

use super::image::Image;

/// relMSE = mean over pixels and channels of (I − R)² / (R² + 1e-2).
pub fn relmse(image: &Image, reference: &Image) -> Result<f64, String> {
    check_sizes(image, reference)?;
    let mut acc = 0.0f64;
    for (i, r) in image.pixels.iter().zip(&reference.pixels) {
        for c in 0..3 {
            let (iv, rv) = (i[c] as f64, r[c] as f64);
            acc += (iv - rv).powi(2) / (rv * rv + 1e-2);
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
}
