//! Textures with Mitsuba 3's lookup conventions (see the scene pack README):
//! `bitmap` with bilinear filtering and periodic wrap, and `checkerboard`.

use crate::math::Spectrum;
use glam::Vec2;
use std::path::Path;
use std::sync::Arc;

mod bitmap8;
pub use bitmap8::Bitmap8;
pub mod jpeg;

/// A linear-RGB image, row 0 at the top.
#[derive(Clone, Debug)]
pub struct RgbImage {
    pub width: usize,
    pub height: usize,
    pub pixels: Vec<Spectrum>,
}

impl RgbImage {
    #[inline]
    pub fn get(&self, x: usize, y: usize) -> Spectrum {
        self.pixels[y * self.width + x]
    }

    /// Counts pixels with a NaN/Inf component.
    pub fn non_finite_pixels(&self) -> usize {
        self.pixels
            .iter()
            .filter(|p| !crate::math::is_finite3(**p))
            .count()
    }
}

#[derive(Clone, Debug)]
pub enum Texture {
    Constant(Spectrum),
    Bitmap(Arc<RgbImage>),
    /// A bitmap from an 8-bit source, same lookups as `Bitmap`.
    Bitmap8(Arc<Bitmap8>),
    Checkerboard {
        color0: Spectrum,
        color1: Spectrum,
        scale: Vec2,
    },
}

impl Texture {
    #[inline]
    pub fn eval(&self, uv: Vec2) -> Spectrum {
        match self {
            Texture::Constant(c) => *c,
            Texture::Bitmap(img) => bilinear_periodic(img, uv),
            Texture::Bitmap8(img) => img.bilinear_periodic(uv),
            Texture::Checkerboard {
                color0,
                color1,
                scale,
            } => {
                let u = scale.x * uv.x;
                let v = scale.y * uv.y;
                if ((u - u.floor()) > 0.5) == ((v - v.floor()) > 0.5) {
                    *color0
                } else {
                    *color1
                }
            }
        }
    }

    /// Starts loading the texels `eval(uv)` reads (see
    /// [`Bitmap8::prefetch`]); float bitmaps are rare and left alone.
    #[inline]
    pub fn prefetch(&self, uv: Vec2) {
        if let Texture::Bitmap8(img) = self {
            img.prefetch(uv);
        }
    }

    /// A spectrum that bounds the texture from above per channel; used by the
    /// per-scene plan and by lobe weights where a texture lookup is not wanted.
    pub fn max_value(&self) -> Spectrum {
        match self {
            Texture::Constant(c) => *c,
            Texture::Bitmap(img) => img.pixels.iter().fold(Spectrum::ZERO, |a, &p| a.max(p)),
            Texture::Bitmap8(img) => img.pixels().fold(Spectrum::ZERO, |a, p| a.max(p)),
            Texture::Checkerboard { color0, color1, .. } => color0.max(*color1),
        }
    }

    pub fn is_black(&self) -> bool {
        self.max_value().max_element() <= 0.0
    }
}

/// Bilinear lookup at continuous pixel coordinates (u·W − 0.5, v·H − 0.5)
/// with periodic wrap in both directions, as Mitsuba's `bitmap`.
fn bilinear_periodic(img: &RgbImage, uv: Vec2) -> Spectrum {
    let Some(([x0, x1, y0, y1], tx, ty)) = bilinear_footprint(img.width, img.height, uv) else {
        return img.get(0, 0);
    };
    let top = img.get(x0, y0) * (1.0 - tx) + img.get(x1, y0) * tx;
    let bottom = img.get(x0, y1) * (1.0 - tx) + img.get(x1, y1) * tx;
    top * (1.0 - ty) + bottom * ty
}

/// The four texels ([x0, x1, y0, y1]) and weights (tx, ty) of a bilinear
/// lookup; `None` for a non-finite `uv`.
#[inline(always)]
fn bilinear_footprint(width: usize, height: usize, uv: Vec2) -> Option<([usize; 4], f32, f32)> {
    let (w, h) = (width as i64, height as i64);
    let x = uv.x * width as f32 - 0.5;
    let y = uv.y * height as f32 - 0.5;
    if !x.is_finite() || !y.is_finite() {
        return None;
    }
    let (fx, fy) = (x.floor(), y.floor());
    let (tx, ty) = (x - fx, y - fy);
    let x0 = wrap(fx as i64, w);
    let y0 = wrap(fy as i64, h);
    let x1 = if x0 + 1 == width { 0 } else { x0 + 1 };
    let y1 = if y0 + 1 == height { 0 } else { y0 + 1 };
    Some(([x0, x1, y0, y1], tx, ty))
}

/// `i.rem_euclid(n)` without a division in the common case: most lookups
/// fall inside the image or one period off, and the texel loads wait for
/// this index.
#[inline]
fn wrap(i: i64, n: i64) -> usize {
    let r = if (0..n).contains(&i) {
        i
    } else if (-n..0).contains(&i) {
        i + n
    } else if (n..2 * n).contains(&i) {
        i - n
    } else {
        i.rem_euclid(n)
    };
    r as usize
}

#[inline]
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

#[inline]
pub fn linear_to_srgb(c: f32) -> f32 {
    if c <= 0.0031308 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// A `bitmap` texture's image: 8-bit PNG/JPEG sources stay packed
/// ([`Bitmap8`]), everything else is loaded by [`load_image`].
pub fn load_bitmap(path: &Path, raw: bool) -> Result<Texture, String> {
    let is_exr = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    if !is_exr {
        let img = decode_file(path)?;
        use image::DynamicImage::*;
        if matches!(
            img,
            ImageLuma8(_) | ImageLumaA8(_) | ImageRgb8(_) | ImageRgba8(_)
        ) {
            let decode = |c: f32| if raw { c } else { srgb_to_linear(c) };
            return Ok(Texture::Bitmap8(Arc::new(Bitmap8::new(
                &img.to_rgb8(),
                decode,
            ))));
        }
    }
    Ok(Texture::Bitmap(Arc::new(load_image(path, raw)?)))
}

fn decode_file(path: &Path) -> Result<image::DynamicImage, String> {
    let bytes =
        std::fs::read(path).map_err(|e| format!("cannot read '{}': {e}", path.display()))?;
    // JPEGs go through libjpeg, as in Mitsuba (see [`jpeg`]).
    let img = if jpeg::is_jpeg(&bytes) {
        jpeg::decode(&bytes)
    } else {
        image::load_from_memory(&bytes).map_err(|e| e.to_string())
    }
    .map_err(|e| format!("cannot decode image '{}': {e}", path.display()))?;
    if img.width() == 0 || img.height() == 0 {
        return Err(format!("image '{}' is empty", path.display()));
    }
    Ok(img)
}

/// Loads a PNG/JPEG (sRGB-decoded unless `raw`) or EXR (linear) image.
/// Grey images are replicated to RGB and alpha is ignored.
pub fn load_image(path: &Path, raw: bool) -> Result<RgbImage, String> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .unwrap_or_default();
    if ext == "exr" {
        return crate::film::exr_io::read_rgb(path);
    }
    let img = decode_file(path)?;
    let (w, h) = (img.width() as usize, img.height() as usize);
    // 16-bit sources keep their precision through the f32 conversion.
    let rgb = img.to_rgb32f();
    let decode = |c: f32| if raw { c } else { srgb_to_linear(c) };
    let pixels = rgb
        .pixels()
        .map(|p| Spectrum::new(decode(p.0[0]), decode(p.0[1]), decode(p.0[2])))
        .collect();
    Ok(RgbImage {
        width: w,
        height: h,
        pixels,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrap_is_rem_euclid() {
        for n in [1i64, 2, 3, 7, 512] {
            for i in -4 * n - 3..4 * n + 3 {
                assert_eq!(wrap(i, n), i.rem_euclid(n) as usize, "i={i} n={n}");
            }
        }
        assert_eq!(wrap(i64::MIN, 7), i64::MIN.rem_euclid(7) as usize);
        assert_eq!(wrap(i64::MAX, 7), i64::MAX.rem_euclid(7) as usize);
    }

    #[test]
    fn checkerboard_follows_mitsuba_parity_rule() {
        let t = Texture::Checkerboard {
            color0: Spectrum::splat(1.0),
            color1: Spectrum::splat(0.0),
            scale: Vec2::new(2.0, 2.0),
        };
        // (0.1,0.1) → frac(0.2)=0.2 both ≤ 0.5 → color0
        assert_eq!(t.eval(Vec2::new(0.1, 0.1)).x, 1.0);
        assert_eq!(t.eval(Vec2::new(0.3, 0.1)).x, 0.0);
        assert_eq!(t.eval(Vec2::new(0.3, 0.3)).x, 1.0);
    }

    #[test]
    fn bilinear_wraps_periodically_and_hits_pixel_centres() {
        let img = Arc::new(RgbImage {
            width: 2,
            height: 1,
            pixels: vec![Spectrum::splat(0.0), Spectrum::splat(1.0)],
        });
        let t = Texture::Bitmap(img);
        assert!((t.eval(Vec2::new(0.25, 0.5)).x - 0.0).abs() < 1e-6);
        assert!((t.eval(Vec2::new(0.75, 0.5)).x - 1.0).abs() < 1e-6);
        // halfway between the last and (wrapped) first pixel
        assert!((t.eval(Vec2::new(1.0, 0.5)).x - 0.5).abs() < 1e-6);
        assert!((t.eval(Vec2::new(0.0, 0.5)).x - 0.5).abs() < 1e-6);
    }
}
