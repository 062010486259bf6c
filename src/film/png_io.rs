//! The tonemapped sRGB PNG preview: linear radiance clamped to [0, 1] and
//! sRGB-encoded, with no exposure change (the pack's `preview.png` rule).

use super::image::Image;
use crate::texture::linear_to_srgb;
use std::path::Path;

pub fn write_png(path: &Path, image: &Image) -> Result<(), String> {
    let mut bytes = Vec::with_capacity(image.pixels.len() * 3);
    for p in &image.pixels {
        for c in 0..3 {
            let v = if p[c].is_finite() { p[c] } else { 0.0 };
            bytes.push((linear_to_srgb(v.clamp(0.0, 1.0)) * 255.0 + 0.5) as u8);
        }
    }
    write_png_rgb8(path, image.width, image.height, &bytes)
}

/// Writes 8-bit RGB atomically (temporary file, then rename).
pub fn write_png_rgb8(path: &Path, width: usize, height: usize, rgb: &[u8]) -> Result<(), String> {
    let tmp = super::temp_path_for(path);
    let res = image::save_buffer_with_format(
        &tmp,
        rgb,
        width as u32,
        height as u32,
        image::ExtendedColorType::Rgb8,
        image::ImageFormat::Png,
    );
    match res {
        Ok(()) => super::commit_temp(&tmp, path),
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(format!("cannot write PNG '{}': {e}", path.display()))
        }
    }
}
