//! f32x16 building blocks shared by the wide kernels, each the lane-wise
//! twin of a scalar function in [`super::polygon`] (same operations, same
//! order), so wide and scalar kernels agree bit for bit.
//!
//! The lane-crossing operations below have one route per lane layout:
//! `cfg(zmm_kernels)` (set by `build.rs`: AVX-512 without the `ymm-kernels`
//! feature, so avx512f is enabled wherever a SAFETY comment below says so)
//! uses single zmm instructions; AVX2, and AVX-512 builds with the feature,
//! use the two-halves versions of [`super::simd_avx2`]; other targets a
//! portable lane loop.

use super::lanes::f32x16;
use super::polygon::ATAN_COEFFS;

#[inline(always)]
pub fn splat(v: f32) -> f32x16 {
    f32x16::splat(v)
}

/// atan on [0, 1] (see [`super::polygon::atan_unit`]).
#[inline(always)]
pub fn atan_unit(t: f32x16) -> f32x16 {
    let u = t * t;
    let mut p = splat(ATAN_COEFFS[9]);
    for k in (0..9).rev() {
        p = p.mul_add(u, splat(ATAN_COEFFS[k]));
    }
    t * p
}

/// θ/s (see [`super::polygon::theta_over_s`]).
#[inline(always)]
pub fn theta_over_s(s: f32x16, d: f32x16) -> f32x16 {
    let s = s.fast_max(splat(1e-30));
    let a = d.abs();
    let swap = s.simd_gt(a);
    let num = swap.bitselect(a, s);
    let den = swap.bitselect(s, a);
    let r = splat(1.0) / (den * s).fast_max(splat(1e-37));
    let t = num * s * r;
    let at = atan_unit(t);
    let th = swap.bitselect(splat(std::f32::consts::FRAC_PI_2) - at, at);
    let theta = d
        .simd_lt(splat(0.0))
        .bitselect(splat(std::f32::consts::PI) - th, th);
    theta * (den * r)
}

/// sin, cos of 2π·v (see [`super::polygon::sincos_turns`]).
#[inline(always)]
pub fn sincos_turns(v: f32x16) -> (f32x16, f32x16) {
    let q = v * splat(4.0);
    let qi = q.floor();
    let x = (q - qi) * splat(std::f32::consts::FRAC_PI_2);
    let u = x * x;
    let mut s = splat(1.0 / 6_227_020_800.0);
    s = s.mul_add(u, splat(-1.0 / 39_916_800.0));
    s = s.mul_add(u, splat(1.0 / 362_880.0));
    s = s.mul_add(u, splat(-1.0 / 5040.0));
    s = s.mul_add(u, splat(1.0 / 120.0));
    s = s.mul_add(u, splat(-1.0 / 6.0));
    s = s.mul_add(u, splat(1.0));
    let s = x * s;
    let mut c = splat(-1.0 / 87_178_291_200.0);
    c = c.mul_add(u, splat(1.0 / 479_001_600.0));
    c = c.mul_add(u, splat(-1.0 / 3_628_800.0));
    c = c.mul_add(u, splat(1.0 / 40320.0));
    c = c.mul_add(u, splat(-1.0 / 720.0));
    c = c.mul_add(u, splat(1.0 / 24.0));
    c = c.mul_add(u, splat(-0.5));
    c = c.mul_add(u, splat(1.0));
    let quadrant = qi - (qi * splat(0.25)).floor() * splat(4.0);
    let q1 = quadrant.simd_eq(splat(1.0));
    let q2 = quadrant.simd_eq(splat(2.0));
    let q3 = quadrant.simd_eq(splat(3.0));
    let sin = q3.bitselect(-c, q2.bitselect(-s, q1.bitselect(c, s)));
    let cos = q3.bitselect(s, q2.bitselect(-c, q1.bitselect(-s, c)));
    (sin, cos)
}

#[inline(always)]
pub fn transform(rows: &[[f32; 3]; 3], x: f32x16, y: f32x16, z: f32x16) -> [f32x16; 3] {
    let r = |i: usize| {
        splat(rows[i][2]).mul_add(z, splat(rows[i][1]).mul_add(y, splat(rows[i][0]) * x))
    };
    [r(0), r(1), r(2)]
}

/// θ·(a×b)/|a×b| on 16 lanes.
#[inline(always)]
pub fn edge_vectors(a: [f32x16; 3], b: [f32x16; 3]) -> [f32x16; 3] {
    let cx = a[1] * b[2] - a[2] * b[1];
    let cy = a[2] * b[0] - a[0] * b[2];
    let cz = a[0] * b[1] - a[1] * b[0];
    let d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let s = (cx * cx + cy * cy + cz * cz).sqrt();
    let k = theta_over_s(s, d);
    [cx * k, cy * k, cz * k]
}

#[inline(always)]
pub fn load16(a: &[f32], i: usize) -> f32x16 {
    f32x16::from(<[f32; 16]>::try_from(&a[i..i + 16]).unwrap())
}

/// Gathers lanes of `v` by constant indices: one vpermps on AVX-512.
#[inline(always)]
pub fn permute(v: f32x16, idx: &[i32; 16]) -> f32x16 {
    #[cfg(zmm_kernels)]
    {
        use std::arch::x86_64::{__m512, __m512i, _mm512_permutexvar_ps};
        // SAFETY: f32x16 and __m512 are both 64 bytes holding 16 f32, and
        // [i32; 16] and __m512i both 64 bytes; avx512f is enabled at
        // compile time (the cfg above).
        unsafe {
            let vi: __m512i = std::mem::transmute(*idx);
            let vv: __m512 = std::mem::transmute(v);
            std::mem::transmute(_mm512_permutexvar_ps(vi, vv))
        }
    }
    #[cfg(all(target_feature = "avx2", not(zmm_kernels)))]
    {
        super::simd_avx2::permute(v, idx)
    }
    #[cfg(not(any(target_feature = "avx2", zmm_kernels)))]
    {
        let a = v.to_array();
        f32x16::from(std::array::from_fn::<f32, 16, _>(|l| a[idx[l] as usize]))
    }
}

/// The immediate of [`shuffle_blocks`] for a block order (block j of the
/// result is block `order[j]` of the source).
pub const fn block_order(order: [usize; 4]) -> i32 {
    (order[0] | order[1] << 2 | order[2] << 4 | order[3] << 6) as i32
}

/// The 128-bit block holding edge e of every child (lane k of it) in the
/// child kernels: blocks 0 + 2 and 1 + 3 are added first, so e0, e1 and
/// e2, e3 must sit in those pairs and the per-child sums
/// (e0 + e1) + (e2 + e3) are two block additions ([`block_sums`]).
pub const BLOCK_OF_EDGE: [usize; 4] = [0, 2, 1, 3];

/// The [`block_order`] taking each edge's start to its end in a polygon of
/// `edges` (3 or 4) edges laid out by [`BLOCK_OF_EDGE`]: block
/// `BLOCK_OF_EDGE[e]` of the ends is block `BLOCK_OF_EDGE[e + 1 mod edges]`
/// of the starts; an unused fourth block stays put.
pub const fn edge_end_blocks(edges: usize) -> i32 {
    let mut t = [3usize; 4];
    let mut e = 0;
    while e < edges {
        t[BLOCK_OF_EDGE[e]] = BLOCK_OF_EDGE[(e + 1) % edges];
        e += 1;
    }
    block_order(t)
}

/// The 128-bit blocks of `v` rearranged by `ORDER` (from [`block_order`]):
/// one vshuff32x4 on AVX-512.
#[inline(always)]
pub fn shuffle_blocks<const ORDER: i32>(v: f32x16) -> f32x16 {
    #[cfg(zmm_kernels)]
    {
        use std::arch::x86_64::{__m512, _mm512_shuffle_f32x4};
        // SAFETY: f32x16 and __m512 are both 64 bytes holding 16 f32;
        // avx512f is enabled at compile time (the cfg above).
        unsafe {
            let vv: __m512 = std::mem::transmute(v);
            std::mem::transmute(_mm512_shuffle_f32x4::<ORDER>(vv, vv))
        }
    }
    #[cfg(all(target_feature = "avx2", not(zmm_kernels)))]
    {
        super::simd_avx2::shuffle_blocks(v, ORDER)
    }
    #[cfg(not(any(target_feature = "avx2", zmm_kernels)))]
    {
        let a = v.to_array();
        f32x16::from(std::array::from_fn::<f32, 16, _>(|l| {
            a[4 * ((ORDER as usize >> (2 * (l / 4))) & 3) + l % 4]
        }))
    }
}

/// Heights ((u + i)·h)·2 − 1 and radii √((1 − z)(1 + z)) per lane, with
/// the operations of [`super::children::child_grid`] and the grid radii.
/// `u` (< 2^24, so exact in f32) is converted lane-wise: a scalar
/// `cvtusi2ss` merges into a stale register, and when that register was
/// last written by the previous call's polynomial, every call waits for the
/// one before (measured: 26 → 44 ns per plain-quad call).
#[inline(always)]
pub fn heights_and_radii(u: u32, h: f32, i: f32x16) -> (f32x16, f32x16) {
    debug_assert!(u < 1 << 24);
    let u = super::lanes::splat_converted(u as i32);
    let z = ((u + i) * splat(h)).mul_add(splat(2.0), splat(-1.0));
    // z is an exact dyadic in [−1, 1] for any cell, so 1 ∓ z are exact
    // and their product is ≥ 0: the scalar `max(0)` is a no-op here.
    let r = ((splat(1.0) - z) * (splat(1.0) + z)).sqrt();
    (z, r)
}

/// World directions mapped by `rows` and normalised: the operations of
/// [`super::quad::unit_cosine_vertex`].
#[inline(always)]
pub fn unit_vertices(rows: &[[f32; 3]; 3], x: f32x16, y: f32x16, z: f32x16) -> [f32x16; 3] {
    normalise(transform(rows, x, y, z))
}

/// t/|t| per lane, with the normalisation of
/// [`super::quad::unit_cosine_vertex`].
#[inline(always)]
pub fn normalise(t: [f32x16; 3]) -> [f32x16; 3] {
    use super::fast_math::{RSQRT_FLOOR, rsqrt_x16};
    let n2 = t[2].mul_add(t[2], t[1].mul_add(t[1], t[0] * t[0]));
    let inv = rsqrt_x16(n2.fast_max(splat(RSQRT_FLOOR)));
    [t[0] * inv, t[1] * inv, t[2] * inv]
}

/// (b0 + b2) + (b1 + b3) of the four 128-bit blocks b_j of `v`, lane by
/// lane: two extract-and-add steps (the halves, then the quarters).
#[inline(always)]
pub fn block_sums(v: f32x16) -> wide::f32x4 {
    use wide::{f32x4, f32x8};
    // SAFETY: f32x16 is 64 bytes of 16 f32 (repr C); [f32x8; 2] and
    // [f32x4; 2] are the same bytes split in halves, lanes in order.
    let [lo, hi]: [f32x8; 2] = unsafe { std::mem::transmute(v) };
    let [lo, hi]: [f32x4; 2] = unsafe { std::mem::transmute(lo + hi) };
    lo + hi
}

/// a×b and θ/sin θ of edges between unit vectors: the operations of
/// [`super::quad::unit_edge`].
#[inline(always)]
pub fn unit_edges(a: [f32x16; 3], b: [f32x16; 3]) -> ([f32x16; 3], f32x16) {
    let cx = a[1] * b[2] - a[2] * b[1];
    let cy = a[2] * b[0] - a[0] * b[2];
    let cz = a[0] * b[1] - a[1] * b[0];
    let d = a[2].mul_add(b[2], a[1].mul_add(b[1], a[0] * b[0]));
    let k = super::fast_math::theta_over_sin_x16(d, || cz.mul_add(cz, cy.mul_add(cy, cx * cx)));
    ([cx, cy, cz], k)
}

/// x, y of a×b with the operations of [`unit_edges`].
#[inline(always)]
pub fn cross_xy(a: &[f32x16; 3], b: &[f32x16; 3]) -> (f32x16, f32x16) {
    (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2])
}

/// (a×b)_z and θ/sin θ of [`unit_edges`], without forming (a×b)_x, y
/// unless some lane is obtuse: the plain-quad kernel needs only F_z when
/// no child straddles the horizon, and skipping 6 of its ~80 vector
/// operations shows in its throughput.
#[inline(always)]
pub fn unit_edges_z(a: &[f32x16; 3], b: &[f32x16; 3]) -> (f32x16, f32x16) {
    let cz = a[0] * b[1] - a[1] * b[0];
    let d = a[2].mul_add(b[2], a[1].mul_add(b[1], a[0] * b[0]));
    let k = super::fast_math::theta_over_sin_x16(d, || {
        let (cx, cy) = cross_xy(a, b);
        cz.mul_add(cz, cy.mul_add(cy, cx * cx))
    });
    (cz, k)
}

/// z terms of the parts above the horizon of 16 edges a → b that cross
/// it at p: a → p where a is up, p → b otherwise.
#[inline(always)]
pub fn above_part_z(a: [f32x16; 3], b: [f32x16; 3], p: [f32x16; 3], a_up: f32x16) -> f32x16 {
    let s = std::array::from_fn(|i| a_up.bitselect(a[i], p[i]));
    let t = std::array::from_fn(|i| a_up.bitselect(p[i], b[i]));
    let (c, k) = unit_edges(s, t);
    c[2] * k
}

/// [`super::coarse::horizon_point`] on 16 lanes.
#[inline(always)]
pub fn horizon_points(a: [f32x16; 3], b: [f32x16; 3]) -> [f32x16; 3] {
    use super::fast_math::{RSQRT_FLOOR, rsqrt_x16};
    let t = a[2] / (a[2] - b[2]);
    let x = (b[0] - a[0]).mul_add(t, a[0]);
    let y = (b[1] - a[1]).mul_add(t, a[1]);
    let inv = rsqrt_x16(y.mul_add(y, x * x).fast_max(splat(RSQRT_FLOOR)));
    [x * inv, y * inv, splat(0.0)]
}

/// Lanes of a 4-lane vector spread over 16 by constant indices (< 4): one
/// vpermps on AVX-512, the xmm read as the low quarter of a zmm. Per-node
/// quantities with only 3 distinct values (heights, radii) are cheaper to
/// compute 4 wide and spread than 16 wide, where a zmm √ costs about 8
/// issue slots (measured against vaddps on this machine).
#[inline(always)]
pub fn spread4(v: wide::f32x4, idx: &[i32; 16]) -> f32x16 {
    #[cfg(zmm_kernels)]
    {
        use std::arch::x86_64::{__m128, __m512i, _mm512_castps128_ps512, _mm512_permutexvar_ps};
        // SAFETY: f32x4 and __m128 are both 16 bytes holding 4 f32, [i32;
        // 16] and __m512i both 64 bytes; the indices only read the low 4
        // lanes (the cast leaves the upper ones undefined); avx512f is
        // enabled at compile time (the cfg above).
        unsafe {
            debug_assert!(idx.iter().all(|&i| (0..4).contains(&i)));
            let vi: __m512i = std::mem::transmute(*idx);
            let vv: __m128 = std::mem::transmute(v);
            std::mem::transmute(_mm512_permutexvar_ps(vi, _mm512_castps128_ps512(vv)))
        }
    }
    #[cfg(all(target_feature = "avx2", not(zmm_kernels)))]
    {
        super::simd_avx2::spread4(v, idx)
    }
    #[cfg(not(any(target_feature = "avx2", zmm_kernels)))]
    {
        let a = v.to_array();
        f32x16::from(std::array::from_fn::<f32, 16, _>(|l| a[idx[l] as usize]))
    }
}

/// Bit l set where lane l is not ≥ `c` (NaN included): one compare into a
/// mask register, where `!v.simd_ge(..)` costs a `knotw` more.
#[inline(always)]
pub fn not_ge_mask(v: f32x16, c: f32) -> u16 {
    #[cfg(zmm_kernels)]
    {
        use std::arch::x86_64::{__m512, _CMP_NGE_UQ, _mm512_cmp_ps_mask, _mm512_set1_ps};
        // SAFETY: f32x16 and __m512 are both 64 bytes holding 16 f32;
        // avx512f is enabled at compile time (the cfg above).
        unsafe {
            let vv: __m512 = std::mem::transmute(v);
            _mm512_cmp_ps_mask::<_CMP_NGE_UQ>(vv, _mm512_set1_ps(c))
        }
    }
    #[cfg(not(zmm_kernels))]
    {
        (!v.simd_ge(f32x16::splat(c))).to_bitmask() as u16
    }
}

/// The f32 at `$base` plus `$offset` bytes (a constant expression) in all
/// 16 lanes, by a broadcast load addressed with a constant displacement
/// (a load-port micro-op, no ALU slot), or `$fallback` splat without
/// AVX-512. Left to itself LLVM merges neighbouring fields of `GlossyLtc`
/// into 8-byte loads and splits them again with shifts and register
/// broadcasts (two ALU micro-ops each). The caller bounds the offset
/// within the array `$base` references.
macro_rules! broadcast_displaced {
    ($base:expr, $offset:expr, $fallback:expr) => {{
        #[cfg(zmm_kernels)]
        {
            let v: std::arch::x86_64::__m512;
            // SAFETY: `$base` is a valid reference and the caller's
            // assertion keeps the displacement inside its array; the
            // instruction reads 4 bytes; avx512f is enabled at compile time.
            unsafe {
                std::arch::asm!(
                    "vbroadcastss {v}, dword ptr [{p} + {off}]",
                    v = out(zmm_reg) v,
                    p = in(reg) $base,
                    off = const $offset,
                    options(pure, readonly, nostack, preserves_flags)
                );
                std::mem::transmute::<std::arch::x86_64::__m512, f32x16>(v)
            }
        }
        #[cfg(not(zmm_kernels))]
        {
            f32x16::splat($fallback)
        }
    }};
}

/// `rows[I][J]` in all 16 lanes: a broadcast load addressed as the row
/// array plus a constant displacement, so that the entries of one array
/// share one address register (LLVM otherwise forms each entry's address
/// with its own `lea`, an integer micro-op that may take a vector port).
#[inline(always)]
pub fn broadcast_entry<const I: usize, const J: usize>(rows: &[[f32; 3]; 3]) -> f32x16 {
    const { assert!(I < 3 && J < 3) };
    broadcast_displaced!(rows, 4 * (3 * I + J), rows[I][J])
}

/// `c[I]` in all 16 lanes, addressed as [`broadcast_entry`] addresses.
#[inline(always)]
pub fn broadcast_coeff<const I: usize>(c: &[f32; 4]) -> f32x16 {
    const { assert!(I < 4) };
    broadcast_displaced!(c, 4 * I, c[I])
}

/// `pair[J]` in all 16 lanes, by a broadcast load (a table entry read
/// where it lies, not loaded into a register and broadcast from there).
#[inline(always)]
pub fn broadcast_pair<const J: usize>(pair: &[f32; 2]) -> f32x16 {
    const { assert!(J < 2) };
    broadcast_displaced!(pair, 4 * J, pair[J])
}

/// Lanes 1..16 of `v` followed by lane 0 of `next`: each lane's successor
/// (one valignd on AVX-512).
#[inline(always)]
pub fn successor_lanes(v: f32x16, next: f32x16) -> f32x16 {
    #[cfg(zmm_kernels)]
    {
        use std::arch::x86_64::{__m512i, _mm512_alignr_epi32};
        // SAFETY: f32x16 and __m512i are both 64 bytes; the lanes are moved
        // as bits; avx512f is enabled at compile time (the cfg above).
        unsafe {
            let v: __m512i = std::mem::transmute(v);
            let n: __m512i = std::mem::transmute(next);
            std::mem::transmute(_mm512_alignr_epi32::<1>(n, v))
        }
    }
    #[cfg(all(target_feature = "avx2", not(zmm_kernels)))]
    {
        super::simd_avx2::successor_lanes(v, next)
    }
    #[cfg(not(any(target_feature = "avx2", zmm_kernels)))]
    {
        let (a, n) = (v.to_array(), next.to_array());
        f32x16::from(std::array::from_fn::<f32, 16, _>(|l| {
            if l < 15 { a[l + 1] } else { n[0] }
        }))
    }
}

/// A lane mask (all bits set where bit l of `bits` is) for `bitselect`.
#[inline(always)]
pub fn lane_mask(bits: u16) -> f32x16 {
    #[cfg(zmm_kernels)]
    {
        use std::arch::x86_64::{_mm512_maskz_mov_epi32, _mm512_set1_epi32};
        // SAFETY: the 16 i32 lanes are reinterpreted as f32 bit patterns
        // (all ones or zero); avx512f is enabled at compile time.
        unsafe { std::mem::transmute(_mm512_maskz_mov_epi32(bits, _mm512_set1_epi32(-1))) }
    }
    #[cfg(all(target_feature = "avx2", not(zmm_kernels)))]
    {
        super::simd_avx2::lane_mask(bits)
    }
    #[cfg(not(any(target_feature = "avx2", zmm_kernels)))]
    {
        f32x16::from(std::array::from_fn::<f32, 16, _>(|l| {
            f32::from_bits(if bits >> l & 1 == 1 { u32::MAX } else { 0 })
        }))
    }
}

/// The lane sums of 4 vectors v_k, each as ((w0 + w2) + (w1 + w3)) with
/// w_i = (v_i + v_(i+8)) + (v_(i+4) + v_(i+12)): on AVX-512 the four
/// reductions share their shuffles (14 operations instead of 4 × 7).
#[inline(always)]
pub fn lane_sums4(v: [f32x16; 4]) -> wide::f32x4 {
    #[cfg(zmm_kernels)]
    {
        use std::arch::x86_64::{
            __m512, _mm512_add_ps, _mm512_castps512_ps128, _mm512_permute_ps,
            _mm512_permutexvar_ps, _mm512_set_epi32, _mm512_shuffle_f32x4,
        };
        // SAFETY: f32x16 and __m512 are both 64 bytes holding 16 f32, f32x4
        // and __m128 both 16 bytes holding 4; avx512f is enabled at compile
        // time (the cfg above).
        unsafe {
            let [p0, p1, p2, p3]: [__m512; 4] = std::mem::transmute(v);
            // Blocks (p.b0 + p.b2, p.b1 + p.b3) of two vectors side by side.
            let halves = |a: __m512, b: __m512| {
                _mm512_add_ps(
                    _mm512_shuffle_f32x4::<0b01_00_01_00>(a, b),
                    _mm512_shuffle_f32x4::<0b11_10_11_10>(a, b),
                )
            };
            let (h01, h23) = (halves(p0, p1), halves(p2, p3));
            // Block k: w of vector k.
            let w = _mm512_add_ps(
                _mm512_shuffle_f32x4::<0b10_00_10_00>(h01, h23),
                _mm512_shuffle_f32x4::<0b11_01_11_01>(h01, h23),
            );
            let x = _mm512_add_ps(w, _mm512_permute_ps::<0b01_00_11_10>(w));
            let y = _mm512_add_ps(x, _mm512_permute_ps::<0b10_11_00_01>(x));
            let lanes = _mm512_set_epi32(0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 12, 8, 4, 0);
            std::mem::transmute(_mm512_castps512_ps128(_mm512_permutexvar_ps(lanes, y)))
        }
    }
    #[cfg(all(target_feature = "avx2", not(zmm_kernels)))]
    {
        super::simd_avx2::lane_sums4(v)
    }
    #[cfg(not(any(target_feature = "avx2", zmm_kernels)))]
    {
        wide::f32x4::from(v.map(|v| {
            let a = v.to_array();
            let w: [f32; 4] = std::array::from_fn(|i| (a[i] + a[i + 8]) + (a[i + 4] + a[i + 12]));
            (w[0] + w[2]) + (w[1] + w[3])
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The constant-displacement loads read the entry their indices name,
    /// in every lane (a wrong displacement would read a neighbour).
    #[test]
    fn broadcast_helpers_read_the_named_entry() {
        let rows = [[1.5f32, -2.0, 3.25], [4.0, 5.5, -6.0], [7.0, 8.125, 9.0]];
        let got = [
            broadcast_entry::<0, 0>(&rows),
            broadcast_entry::<0, 1>(&rows),
            broadcast_entry::<0, 2>(&rows),
            broadcast_entry::<1, 0>(&rows),
            broadcast_entry::<1, 1>(&rows),
            broadcast_entry::<1, 2>(&rows),
            broadcast_entry::<2, 0>(&rows),
            broadcast_entry::<2, 1>(&rows),
            broadcast_entry::<2, 2>(&rows),
        ];
        for (i, v) in got.iter().enumerate() {
            assert_eq!(v.to_array(), [rows[i / 3][i % 3]; 16], "entry {i}");
        }
        let c = [0.25f32, -1.0, 3.0, 1e-3];
        let got = [
            broadcast_coeff::<0>(&c),
            broadcast_coeff::<1>(&c),
            broadcast_coeff::<2>(&c),
            broadcast_coeff::<3>(&c),
        ];
        for (i, v) in got.iter().enumerate() {
            assert_eq!(v.to_array(), [c[i]; 16], "coefficient {i}");
        }
    }
}
