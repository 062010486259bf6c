//! Bitmaps decoded from 8-bit sources, kept as one packed texel per pixel
//! (4 bytes instead of a 12-byte linear `Spectrum`). Bilinear lookups on
//! large textures are bound by memory traffic; a third of the bytes keeps
//! more of a scene's textures in cache. Channels go through a 256-entry
//! table built by the same decoding as the float path, and the filter does
//! the float path's arithmetic in the same order, so lookups are
//! bit-identical to [`super::RgbImage`]'s.
//!
//! Texels are stored in 4×4 tiles of one cache line each: a bilinear
//! footprint then lies in one line 9 times in 16 (row-major storage needs
//! two, one per row), and nearby lookups share lines in both directions.

use crate::huge::HugeSlice;
use crate::math::Spectrum;
use glam::Vec2;

#[derive(Clone, Debug)]
pub struct Bitmap8 {
    pub width: usize,
    pub height: usize,
    /// R | G << 8 | B << 16, in 4×4 tiles (see [`tile_index`]), row 0
    /// at the top.
    tiles: HugeSlice<Tile>,
    /// Tiles per row.
    tiles_x: usize,
    /// Linear value of each 8-bit code.
    lut: [f32; 256],
}

impl Bitmap8 {
    /// `decode` maps a normalised channel value to linear (sRGB decoding or
    /// the identity for `raw` textures).
    pub fn new(img: &image::RgbImage, decode: impl Fn(f32) -> f32) -> Self {
        // The float path's u8 → f32 conversion, applied to every code.
        let codes = image::DynamicImage::ImageRgb8(image::RgbImage::from_fn(256, 1, |x, _| {
            image::Rgb([x as u8; 3])
        }))
        .to_rgb32f();
        let mut lut = [0.0f32; 256];
        for (v, p) in lut.iter_mut().zip(codes.pixels()) {
            *v = decode(p.0[0]);
        }
        let (width, height) = (img.width() as usize, img.height() as usize);
        let tiles_x = width.div_ceil(4);
        let mut tiles = vec![Tile([0; 16]); tiles_x * height.div_ceil(4)];
        for (x, y, p) in img.enumerate_pixels() {
            let (tile, i) = tile_index(tiles_x, x as usize, y as usize);
            tiles[tile].0[i] = p.0[0] as u32 | (p.0[1] as u32) << 8 | (p.0[2] as u32) << 16;
        }
        Bitmap8 {
            width,
            height,
            tiles: HugeSlice::new(tiles),
            tiles_x,
            lut,
        }
    }

    #[inline(always)]
    fn unpack(&self, t: u32) -> Spectrum {
        let c = |shift: u32| self.lut[((t >> shift) & 0xff) as usize];
        Spectrum::new(c(0), c(8), c(16))
    }

    #[inline]
    pub fn get(&self, x: usize, y: usize) -> Spectrum {
        let (tile, i) = tile_index(self.tiles_x, x, y);
        self.unpack(self.tiles[tile].0[i])
    }

    /// Linear pixels in row-major order.
    pub fn pixels(&self) -> impl Iterator<Item = Spectrum> + '_ {
        (0..self.height).flat_map(move |y| (0..self.width).map(move |x| self.get(x, y)))
    }

    /// Prefetches the tiles of the bilinear footprint at `uv` (one to
    /// four cache lines) without waiting for them.
    #[inline]
    pub fn prefetch(&self, uv: Vec2) {
        let Some(([x0, x1, y0, y1], _, _)) = super::bilinear_footprint(self.width, self.height, uv)
        else {
            return;
        };
        for (x, y) in [(x0, y0), (x1, y0), (x0, y1), (x1, y1)] {
            let tile = tile_index(self.tiles_x, x, y).0;
            crate::huge::prefetch(&self.tiles[tile]);
        }
    }

    /// The lookup of [`super::bilinear_periodic`].
    #[inline]
    pub fn bilinear_periodic(&self, uv: Vec2) -> Spectrum {
        let Some(([x0, x1, y0, y1], tx, ty)) =
            super::bilinear_footprint(self.width, self.height, uv)
        else {
            return self.get(0, 0);
        };
        let top = self.get(x0, y0) * (1.0 - tx) + self.get(x1, y0) * tx;
        let bottom = self.get(x0, y1) * (1.0 - tx) + self.get(x1, y1) * tx;
        top * (1.0 - ty) + bottom * ty
    }
}

/// 4×4 texels, aligned to a cache line.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct Tile([u32; 16]);

/// (tile, index in the tile) of texel (x, y) with `tiles_x` tiles per row.
#[inline(always)]
fn tile_index(tiles_x: usize, x: usize, y: usize) -> (usize, usize) {
    ((y >> 2) * tiles_x + (x >> 2), (y & 3) * 4 + (x & 3))
}

#[cfg(test)]
mod tests {
    use super::super::{RgbImage, Texture, srgb_to_linear};
    use super::*;
    use std::sync::Arc;

    #[test]
    fn lookups_match_the_float_image_bit_for_bit() {
        let (w, h) = (7u32, 5u32);
        let src = image::RgbImage::from_fn(w, h, |x, y| {
            image::Rgb([
                (x * 37 + y * 11) as u8,
                (x * 5 + y * 91) as u8,
                (x * y * 29) as u8,
            ])
        });
        let float = image::DynamicImage::ImageRgb8(src.clone()).to_rgb32f();
        for raw in [false, true] {
            let decode = |c: f32| if raw { c } else { srgb_to_linear(c) };
            let reference = Texture::Bitmap(Arc::new(RgbImage {
                width: w as usize,
                height: h as usize,
                pixels: float
                    .pixels()
                    .map(|p| Spectrum::new(decode(p.0[0]), decode(p.0[1]), decode(p.0[2])))
                    .collect(),
            }));
            let packed = Texture::Bitmap8(Arc::new(Bitmap8::new(&src, decode)));
            let mut rng = crate::sampling::Rng::new(3, 0);
            for _ in 0..2000 {
                let uv = (rng.next_2d() - 0.3) * 3.0;
                assert_eq!(reference.eval(uv), packed.eval(uv), "uv {uv}");
            }
            assert_eq!(reference.max_value(), packed.max_value());
        }
    }
}
