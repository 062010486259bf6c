//! The lane-crossing f32x16 operations of [`super::simd`], and the 1/√x
//! estimate of [`super::fast_math`], where the 16 lanes are two 256-bit
//! halves: on AVX2 hosts (no AVX-512), where `wide` keeps an f32x16 so, and
//! in AVX-512 builds with the `ymm-kernels` feature ([`super::lanes`]).
//!
//! Without these, the portable fallbacks move all 16 lanes through memory
//! one by one, and LLVM left some of them as out-of-line closure calls: on
//! a Zen 3 host the coarse kernels ran 4–9× slower than their AVX-512
//! timings, against about 3.5× for the lane-wise arithmetic around them.
//! The lane operations move lanes only (or add them in the portable
//! fallback's order), so their results are bit for bit the fallback's.
//! The 1/√x estimate is lane for lane the scalar one that
//! [`super::fast_math::rsqrt`] starts from: vrsqrtps's, or vrsqrt14ps's on
//! AVX-512.

use super::lanes::f32x16;
#[cfg(not(target_feature = "avx512vl"))]
use std::arch::x86_64::_mm256_rsqrt_ps;
use std::arch::x86_64::{
    __m128, __m256, __m256i, _mm_add_ps, _mm_movehl_ps, _mm_movelh_ps, _mm_unpackhi_ps,
    _mm_unpacklo_ps, _mm256_add_ps, _mm256_and_si256, _mm256_blend_ps, _mm256_blendv_ps,
    _mm256_castps128_ps256, _mm256_castps256_ps128, _mm256_castsi256_ps, _mm256_cmpeq_epi32,
    _mm256_extractf128_ps, _mm256_permute2f128_ps, _mm256_permutevar8x32_ps, _mm256_set1_epi32,
    _mm256_setr_epi32, _mm256_slli_epi32,
};
use wide::f32x4;

// `wide` lays an f32x16 out as two f32x8 (low lanes first) without
// AVX-512, and an f32x8 as one __m256 with AVX: 64 bytes either way.
const _: () = assert!(size_of::<f32x16>() == size_of::<[__m256; 2]>());

#[inline(always)]
fn halves(v: f32x16) -> [__m256; 2] {
    // SAFETY: same size (checked above); both are plain f32 bit patterns.
    unsafe { std::mem::transmute(v) }
}

#[inline(always)]
fn join(h: [__m256; 2]) -> f32x16 {
    // SAFETY: as in `halves`.
    unsafe { std::mem::transmute(h) }
}

/// The hardware estimate of 1/√x per lane (vrsqrtps, relative error
/// < 1.5·2⁻¹²; vrsqrt14ps, < 2⁻¹⁴, on AVX-512, as the scalar's), the one
/// [`super::fast_math::rsqrt_x16`] refines.
#[inline(always)]
pub fn rsqrt_estimate(x: f32x16) -> f32x16 {
    let [lo, hi] = halves(x);
    #[cfg(target_feature = "avx512vl")]
    // SAFETY: avx512vl is enabled at compile time (the cfg above).
    unsafe {
        use std::arch::x86_64::_mm256_rsqrt14_ps;
        join([_mm256_rsqrt14_ps(lo), _mm256_rsqrt14_ps(hi)])
    }
    #[cfg(not(target_feature = "avx512vl"))]
    // SAFETY: avx2 is enabled at compile time (the caller's cfg).
    unsafe {
        join([_mm256_rsqrt_ps(lo), _mm256_rsqrt_ps(hi)])
    }
}

/// Lanes idx[l] (< 16) of `v`: each half picks from both source halves by
/// the index's low 3 bits and blends by its bit 3.
#[inline(always)]
pub fn permute(v: f32x16, idx: &[i32; 16]) -> f32x16 {
    let [lo, hi] = halves(v);
    // SAFETY: [i32; 16] and [__m256i; 2] are both 64 bytes of i32 lanes;
    // avx2 is enabled at compile time (the caller's cfg).
    unsafe {
        let index: [__m256i; 2] = std::mem::transmute(*idx);
        let pick = |i: __m256i| {
            let from_hi = _mm256_castsi256_ps(_mm256_slli_epi32::<28>(i));
            _mm256_blendv_ps(
                _mm256_permutevar8x32_ps(lo, i),
                _mm256_permutevar8x32_ps(hi, i),
                from_hi,
            )
        };
        join([pick(index[0]), pick(index[1])])
    }
}

/// Lanes 1..16 of `v` followed by lane 0 of `next`: each half rotated down
/// by one lane, its top lane from the rotated half above it.
#[inline(always)]
pub fn successor_lanes(v: f32x16, next: f32x16) -> f32x16 {
    let [lo, hi] = halves(v);
    let [next_lo, _] = halves(next);
    // SAFETY: avx2 is enabled at compile time (the caller's cfg).
    unsafe {
        let rotate = _mm256_setr_epi32(1, 2, 3, 4, 5, 6, 7, 0);
        let (lo, hi, next_lo) = (
            _mm256_permutevar8x32_ps(lo, rotate),
            _mm256_permutevar8x32_ps(hi, rotate),
            _mm256_permutevar8x32_ps(next_lo, rotate),
        );
        join([
            _mm256_blend_ps::<0b1000_0000>(lo, hi),
            _mm256_blend_ps::<0b1000_0000>(hi, next_lo),
        ])
    }
}

/// Two 128-bit blocks (`sel` = first | second << 4, each 0..4) of the
/// 4 blocks held by `lo` and `hi`: one vperm2f128. `sel` is a constant after
/// inlining, so the match folds to its one arm.
#[inline(always)]
fn block_pair(lo: __m256, hi: __m256, sel: i32) -> __m256 {
    macro_rules! arms {
        ($($s:literal)*) => {
            // SAFETY: avx2 is enabled at compile time (the caller's cfg).
            unsafe {
                match sel {
                    $($s => _mm256_permute2f128_ps::<$s>(lo, hi),)*
                    _ => unreachable!("block selector {sel:#x} out of range"),
                }
            }
        };
    }
    arms!(0x00 0x01 0x02 0x03 0x10 0x11 0x12 0x13 0x20 0x21 0x22 0x23 0x30 0x31 0x32 0x33)
}

/// The 128-bit blocks of `v` rearranged by `order` (from
/// [`super::simd::block_order`]): block j of the result is block
/// (order >> 2j) & 3 of `v`.
#[inline(always)]
pub fn shuffle_blocks(v: f32x16, order: i32) -> f32x16 {
    let [lo, hi] = halves(v);
    let block = |j: i32| (order >> (2 * j)) & 3;
    join([
        block_pair(lo, hi, block(0) | block(1) << 4),
        block_pair(lo, hi, block(2) | block(3) << 4),
    ])
}

/// Lanes of a 4-lane vector spread over 16 by indices < 4.
#[inline(always)]
pub fn spread4(v: f32x4, idx: &[i32; 16]) -> f32x16 {
    // SAFETY: f32x4 and __m128 are both 16 bytes of f32, [i32; 16] and
    // [__m256i; 2] both 64 bytes; the indices (< 4) read only the low
    // lanes that the cast defines; avx2 is enabled (the caller's cfg).
    unsafe {
        let v = _mm256_castps128_ps256(std::mem::transmute::<f32x4, __m128>(v));
        let index: [__m256i; 2] = std::mem::transmute(*idx);
        join([
            _mm256_permutevar8x32_ps(v, index[0]),
            _mm256_permutevar8x32_ps(v, index[1]),
        ])
    }
}

/// A lane mask (all bits set where bit l of `bits` is).
#[inline(always)]
pub fn lane_mask(bits: u16) -> f32x16 {
    // SAFETY: integer lanes reinterpreted as f32 bit patterns (all ones or
    // zero); avx2 is enabled at compile time (the caller's cfg).
    unsafe {
        let b = _mm256_set1_epi32(bits as i32);
        let mask = |lane_bits: __m256i| {
            _mm256_castsi256_ps(_mm256_cmpeq_epi32(
                _mm256_and_si256(b, lane_bits),
                lane_bits,
            ))
        };
        join([
            mask(_mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128)),
            mask(_mm256_setr_epi32(
                1 << 8,
                1 << 9,
                1 << 10,
                1 << 11,
                1 << 12,
                1 << 13,
                1 << 14,
                1 << 15,
            )),
        ])
    }
}

/// The lane sums of 4 vectors in the portable order: ((w0 + w2) + (w1 +
/// w3)) with w_i = (v_i + v_(i+8)) + (v_(i+4) + v_(i+12)).
#[inline(always)]
pub fn lane_sums4(v: [f32x16; 4]) -> f32x4 {
    // SAFETY: avx2 is enabled at compile time (the caller's cfg); f32x4 and
    // __m128 are both 16 bytes of f32.
    unsafe {
        let w = v.map(|v| {
            let [lo, hi] = halves(v);
            let s = _mm256_add_ps(lo, hi);
            _mm_add_ps(_mm256_castps256_ps128(s), _mm256_extractf128_ps::<1>(s))
        });
        // Transposed: column i holds w_i of the 4 vectors.
        let (t0, t1) = (_mm_unpacklo_ps(w[0], w[1]), _mm_unpacklo_ps(w[2], w[3]));
        let (t2, t3) = (_mm_unpackhi_ps(w[0], w[1]), _mm_unpackhi_ps(w[2], w[3]));
        let (c0, c1) = (_mm_movelh_ps(t0, t1), _mm_movehl_ps(t1, t0));
        let (c2, c3) = (_mm_movelh_ps(t2, t3), _mm_movehl_ps(t3, t2));
        std::mem::transmute(_mm_add_ps(_mm_add_ps(c0, c2), _mm_add_ps(c1, c3)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lanes(seed: u32) -> f32x16 {
        f32x16::from(std::array::from_fn::<f32, 16, _>(|l| {
            (seed as f32 + 1.0) * 0.37 + l as f32 * 1.618 - 7.0
        }))
    }

    #[test]
    fn lane_moves_match_their_definitions() {
        let (v, n) = (lanes(1), lanes(2));
        let (a, b) = (v.to_array(), n.to_array());
        let idx: [i32; 16] = std::array::from_fn(|l| ((l * 7 + 3) % 16) as i32);
        let p = permute(v, &idx).to_array();
        assert!((0..16).all(|l| p[l] == a[idx[l] as usize]));
        let s = successor_lanes(v, n).to_array();
        assert!((0..15).all(|l| s[l] == a[l + 1]) && s[15] == b[0]);
        for order in 0..256 {
            let r = shuffle_blocks(v, order).to_array();
            let want = |l: usize| a[4 * ((order as usize >> (2 * (l / 4))) & 3) + l % 4];
            assert!((0..16).all(|l| r[l] == want(l)), "order {order:#x}");
        }
        let four = f32x4::from([1.5, -2.0, 3.25, 9.0]);
        let spread: [i32; 16] = std::array::from_fn(|l| ((l * 5) % 4) as i32);
        let r = spread4(four, &spread).to_array();
        assert!((0..16).all(|l| r[l] == four.to_array()[spread[l] as usize]));
        for bits in [0u16, 1, 0x8000, 0xA5C3, 0xFFFF] {
            let m = lane_mask(bits).to_array();
            assert!(
                (0..16).all(|l| (m[l].to_bits() == u32::MAX) == (bits >> l & 1 == 1)
                    && (m[l].to_bits() == 0) == (bits >> l & 1 == 0))
            );
        }
    }

    #[test]
    fn lane_sums_add_in_the_portable_order() {
        let v = [
            lanes(3),
            lanes(4) * f32x16::splat(1e-3),
            lanes(5),
            lanes(6) * lanes(6),
        ];
        let sums = lane_sums4(v).to_array();
        for k in 0..4 {
            let a = v[k].to_array();
            let w: [f32; 4] = std::array::from_fn(|i| (a[i] + a[i + 8]) + (a[i + 4] + a[i + 12]));
            assert_eq!(sums[k].to_bits(), ((w[0] + w[2]) + (w[1] + w[3])).to_bits());
        }
    }
}
