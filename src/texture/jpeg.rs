//! JPEG decoding through libjpeg-turbo's decoder with the library's
//! defaults, which is how Mitsuba 3 reads JPEG textures (`Bitmap::read_jpeg`:
//! islow IDCT, "fancy" triangle chroma upsampling, fixed-point YCbCr → RGB).
//!
//! The library is the libjpeg-turbo-derived C code vendored in the
//! `mozjpeg-sys` crate (its decoder is libjpeg-turbo's; mozjpeg changes the
//! encoder), compiled by that crate's build script without SIMD and linked
//! statically: building needs a C compiler, no system libjpeg. On the
//! staircase and other scene textures it decodes byte for byte as the system
//! libjpeg-turbo 2.1.5 does. A small C shim (`jpeg_shim.c`, compiled by
//! `build.rs` against mozjpeg-sys's headers) drives it and turns libjpeg's
//! fatal errors into error returns with `longjmp`, so no error unwinds
//! through Rust frames.
//!
//! The `image` crate's decoder (zune-jpeg) rounds its 4:2:0 chroma
//! upsampling twice, half up each time, which raises Cb and Cr by about a
//! quarter of a code on average: decoded textures come out redder and bluer
//! and less green than libjpeg's (up to +0.7 % in blue on a texture's linear
//! mean), enough to bias renders against Mitsuba references by a few
//! tenths of a percent per channel.

// Only the shim calls into libjpeg; this keeps mozjpeg-sys (and with it the
// static library that defines the `jpeg_*` symbols) in the link.
use mozjpeg_sys as _;

use std::ffi::{c_char, c_int, c_uint};

unsafe extern "C" {
    fn ltc_jpeg_decode(
        data: *const u8,
        len: usize,
        out: *mut *mut u8,
        width: *mut c_uint,
        height: *mut c_uint,
        components: *mut c_int,
        msg: *mut c_char,
        msg_len: usize,
    ) -> c_int;
    fn ltc_jpeg_free(p: *mut u8);
}

/// Whether `bytes` starts with a JPEG SOI marker.
pub fn is_jpeg(bytes: &[u8]) -> bool {
    bytes.starts_with(&[0xFF, 0xD8, 0xFF])
}

/// Decodes a JPEG into an 8-bit grey or RGB image.
pub fn decode(bytes: &[u8]) -> Result<image::DynamicImage, String> {
    let mut out: *mut u8 = std::ptr::null_mut();
    let (mut w, mut h, mut comps): (c_uint, c_uint, c_int) = (0, 0, 0);
    let mut msg = [0 as c_char; 256];
    // SAFETY: the shim reads `len` bytes from `data`, writes the out
    // parameters, and on success hands over a malloc'ed buffer of
    // w·h·components bytes, freed below by `ltc_jpeg_free`.
    let rc = unsafe {
        ltc_jpeg_decode(
            bytes.as_ptr(),
            bytes.len(),
            &mut out,
            &mut w,
            &mut h,
            &mut comps,
            msg.as_mut_ptr(),
            msg.len(),
        )
    };
    if rc != 0 {
        // SAFETY: the shim leaves a NUL-terminated message (or zeros).
        let text = unsafe { std::ffi::CStr::from_ptr(msg.as_ptr()) };
        return Err(format!("libjpeg: {}", text.to_string_lossy()));
    }
    let len = w as usize * h as usize * comps as usize;
    // SAFETY: on success `out` holds `len` initialised bytes.
    let data = unsafe { std::slice::from_raw_parts(out, len) }.to_vec();
    // SAFETY: `out` came from the shim's malloc and is freed once.
    unsafe { ltc_jpeg_free(out) };
    let img = match comps {
        1 => image::GrayImage::from_raw(w, h, data).map(image::DynamicImage::ImageLuma8),
        _ => image::RgbImage::from_raw(w, h, data).map(image::DynamicImage::ImageRgb8),
    };
    img.ok_or_else(|| "libjpeg: buffer size mismatch".to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 48×32 RGB noise written by libjpeg-turbo 2.1.5 (`jpeg_set_defaults`,
    /// quality 90: 4:2:0 chroma). The sums below are the system
    /// libjpeg-turbo 2.1.5's decode, which the vendored decoder matches.
    const NOISE_420: &[u8] = include_bytes!("../../tests/fixtures/noise_420.jpg");

    fn channel_sums(img: &image::RgbImage) -> [u64; 3] {
        let mut s = [0u64; 3];
        for p in img.pixels() {
            for (sum, v) in s.iter_mut().zip(p.0) {
                *sum += v as u64;
            }
        }
        s
    }

    #[test]
    fn decodes_4_2_0_as_libjpeg_does() {
        let img = decode(NOISE_420).unwrap().to_rgb8();
        assert_eq!(img.dimensions(), (48, 32));
        // libjpeg-turbo's djpeg defaults. The `image` crate's decoder gives
        // [198345, 195859, 198796] here: chroma rounded up by about a
        // quarter of a code.
        assert_eq!(channel_sums(&img), [197865, 196214, 198156]);
    }

    #[test]
    fn bitmaps_load_jpegs_through_libjpeg() {
        let path = std::env::temp_dir().join(format!("ltcguide-jpeg-{}.jpg", std::process::id()));
        std::fs::write(&path, NOISE_420).unwrap();
        let loaded = crate::texture::load_image(&path, true);
        std::fs::remove_file(&path).unwrap();
        let loaded = loaded.unwrap();
        let direct = decode(NOISE_420).unwrap().to_rgb32f();
        assert_eq!((loaded.width, loaded.height), (48, 32));
        for (a, b) in loaded.pixels.iter().zip(direct.pixels()) {
            assert_eq!([a.x, a.y, a.z], b.0);
        }
    }

    #[test]
    fn errors_are_reported_not_fatal() {
        assert!(is_jpeg(NOISE_420));
        let err = decode(&NOISE_420[..20]).unwrap_err();
        assert!(err.starts_with("libjpeg:"), "{err}");
        assert!(decode(b"\xff\xd8\xff garbage").is_err());
    }
}
