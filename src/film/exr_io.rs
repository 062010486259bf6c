//! Float RGB OpenEXR input and output through the `exr` crate.

use crate::math::Spectrum;
use crate::texture::RgbImage;
use std::path::Path;

/// Reads the first RGB(A) layer of an EXR as linear RGB (alpha ignored).
/// A decoder panic on a corrupt file is turned into an error: bad input must
/// never take the process down.
pub fn read_rgb(path: &Path) -> Result<RgbImage, String> {
    use exr::prelude::*;
    let path_buf = path.to_path_buf();
    let result = std::panic::catch_unwind(move || {
        read_first_rgba_layer_from_file(
            &path_buf,
            |resolution, _| RgbImage {
                width: resolution.width(),
                height: resolution.height(),
                pixels: vec![Spectrum::ZERO; resolution.width() * resolution.height()],
            },
            |img: &mut RgbImage, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
                let w = img.width;
                img.pixels[pos.y() * w + pos.x()] = Spectrum::new(r, g, b);
            },
        )
    });
    match result {
        Ok(Ok(image)) => {
            // A data window that is not the whole display window places its
            // pixels somewhere in the frame; read from the origin, they
            // would be compared with the wrong pixels of a reference.
            let display = image.attributes.display_window;
            let position = image.layer_data.attributes.layer_position;
            let size = image.layer_data.size;
            if position != display.position || size != display.size {
                return Err(format!(
                    "EXR '{}' holds pixels ({}, {})–({}, {}) of a {}×{} frame at ({}, {}); \
                     only images whose data window is the whole display window are read",
                    path.display(),
                    position.x(),
                    position.y(),
                    position.x() + size.width() as i32 - 1,
                    position.y() + size.height() as i32 - 1,
                    display.size.width(),
                    display.size.height(),
                    display.position.x(),
                    display.position.y()
                ));
            }
            let img = image.layer_data.channel_data.pixels;
            if img.width == 0 || img.height == 0 {
                return Err(format!("EXR '{}' is empty", path.display()));
            }
            Ok(img)
        }
        Ok(Err(e)) => Err(format!("cannot read EXR '{}': {e}", path.display())),
        Err(_) => Err(format!(
            "cannot read EXR '{}': corrupt file",
            path.display()
        )),
    }
}

/// Writes a float RGB EXR atomically: to a temporary file in the same folder,
/// then renamed, so an interrupted run never leaves a truncated image.
///
/// The blocks are compressed on one thread, so they are written in line
/// order and the same pixels always make the same file. Compressed on
/// several threads (the crate's default), they were written in the order
/// the threads finished them: two renders with identical pixels gave files
/// that differed in their offset tables and block order, so a checksum
/// could not tell whether a render had been reproduced.
pub fn write_rgb(
    path: &Path,
    width: usize,
    height: usize,
    pixels: &[Spectrum],
) -> Result<(), String> {
    use exr::prelude::*;
    assert_eq!(pixels.len(), width * height);
    let tmp = crate::film::temp_path_for(path);
    let channels = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
        let p = pixels[y * width + x];
        (p.x, p.y, p.z)
    });
    let res = Image::from_channels((width, height), channels)
        .write()
        .non_parallel()
        .to_file(&tmp);
    match res {
        Ok(()) => crate::film::commit_temp(&tmp, path),
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(format!("cannot write EXR '{}': {e}", path.display()))
        }
    }
}

/// Reads an EXR as an [`Image`](super::image::Image).
pub fn read_image(path: &Path) -> Result<super::image::Image, String> {
    let img = read_rgb(path)?;
    Ok(super::image::Image {
        width: img.width,
        height: img.height,
        pixels: img.pixels,
    })
}

/// Reads an EXR that an error metric will compare: refused, naming the
/// file and its first bad pixel, if any pixel is NaN, Inf or negative.
pub fn read_valid_image(path: &Path) -> Result<super::image::Image, String> {
    let img = read_image(path)?;
    img.check_valid(&format!("'{}'", path.display()))?;
    Ok(img)
}
