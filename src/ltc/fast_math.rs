//! The arithmetic shared by the scalar and 16-wide quad kernels, in pairs
//! that perform the same IEEE operations in the same order, so that both
//! kernels agree bit for bit (deep cells cancel catastrophically, so any
//! rounding difference would show up as a different result):
//! - [`rsqrt`]: 1/√x from the hardware estimate (`vrsqrt14`, the same
//!   table for the scalar and packed forms) and one Newton step, instead of
//!   a √ and a division that occupy the divider for ~30 cycles per vector;
//! - [`theta_over_sin`]: θ/sin θ of an edge between unit vectors from
//!   d = cos θ, our own polynomial (no atan2, no division);
//! - [`dyadic_sincos`]: sin and cos of 2π·n/2^depth from two 2048-entry
//!   tables, for the corner grids of the quadtree (every corner azimuth is
//!   dyadic), instead of a range-reduced series per call.
// `!(x > 0.0)` is deliberate: it is also true for NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::lanes::f32x16;
use std::sync::LazyLock;
use wide::f32x4;

/// θ/sin θ = acos(x)/√(1 − x²) ≈ Σ c_k·x^k on x ∈ [0, 1]: the minimax
/// polynomial of degree 7 for the relative error (Remez, then rounded to
/// f32), 4.7e-7. The function is analytic on [0, 1] (its branch point at
/// x = −1 costs a factor ~5.8 per degree); degree 7 rather than 9 saves
/// three of the deep kernel's ~80 vector operations and one step of its
/// dependency chain. The error is a smooth function of x, nearly the same
/// for all the edges of a small cell, so it scales the cell's integral
/// rather than being amplified by the cancellation between its edges.
#[allow(clippy::excessive_precision)] // printed from the f64 fit
pub const THETA_OVER_SIN: [f32; 8] = [
    1.5707956553e+00,
    -9.9990975857e-01,
    7.8339272738e-01,
    -6.4917790890e-01,
    5.1058888435e-01,
    -3.2613664865e-01,
    1.3752788305e-01,
    -2.7081303298e-02,
];

/// Smallest cosine of an edge that [`THETA_OVER_SIN_SHORT`] covers (edges
/// up to 36.9°): every edge of a plain-quad node past level ~6 of a sharp
/// lobe, and all of them deeper.
pub const SHORT_EDGE_MIN_COS: f32 = 0.8;

/// θ/sin θ ≈ Σ c_k·d^k on d = cos θ ∈ [0.8, 1]: Chebyshev interpolant of
/// degree 3 rounded to f32, relative error 4.8e-7 in f32 Horner (the
/// degree-7 [`THETA_OVER_SIN`]'s is 4.7e-7). The function is analytic far
/// beyond the interval (its branch point is at d = −1), so 3 fused
/// operations suffice where the full range needs 9: the plain-quad kernels
/// take it when every edge of a node is this short.
#[allow(clippy::excessive_precision)] // printed from the fit
pub const THETA_OVER_SIN_SHORT: [f32; 4] = [
    1.5339473486e+00,
    -8.0322659016e-01,
    3.3800449967e-01,
    -6.8725638092e-02,
];

/// θ/sin θ for d ∈ [[`SHORT_EDGE_MIN_COS`], 1], in Horner's form: the
/// plain-quad kernels are bound by throughput, where Estrin's form costs
/// one operation more for two steps of latency fewer.
#[inline(always)]
pub fn theta_over_sin_short<T: PolyLane>(d: T) -> T {
    short_polynomial(&THETA_OVER_SIN_SHORT, d)
}

/// Σ c_k·d^k in Horner's form: [`theta_over_sin_short`] with coefficients
/// that may carry a factor (the plain-quad kernels fold the lobe's 1/2π
/// and orientation into them, one multiplication fewer per node).
#[inline(always)]
pub fn short_polynomial<T: PolyLane>(coeffs: &[f32; 4], d: T) -> T {
    let c = coeffs.map(T::splat);
    c[3].fma(d, c[2]).fma(d, c[1]).fma(d, c[0])
}

/// Floor of the arguments of [`rsqrt`]: keeps a zero vertex or a zero
/// cross product finite (its products with 0 then stay exactly 0).
pub const RSQRT_FLOOR: f32 = 1e-30;

/// 1/√x for x ≥ [`RSQRT_FLOOR`]: the hardware estimate and one Newton step:
/// ~1 ulp from AVX-512's (relative error < 2⁻¹⁴); from AVX2's (< 1.5·2⁻¹²)
/// a relative error below 3·10⁻⁷; elsewhere an exact 1/√x, refined.
#[inline(always)]
pub fn rsqrt(x: f32) -> f32 {
    #[cfg(all(target_arch = "x86_64", target_feature = "avx512f"))]
    let y = {
        use std::arch::x86_64::{_mm_cvtss_f32, _mm_rsqrt14_ss, _mm_set_ss};
        // SAFETY: avx512f is enabled at compile time (the cfg above).
        unsafe {
            let v = _mm_set_ss(x);
            _mm_cvtss_f32(_mm_rsqrt14_ss(v, v))
        }
    };
    #[cfg(all(target_feature = "avx2", not(target_feature = "avx512f")))]
    let y = {
        use std::arch::x86_64::{_mm_cvtss_f32, _mm_rsqrt_ss, _mm_set_ss};
        // SAFETY: avx2 (so sse) is enabled at compile time (the cfg above).
        unsafe { _mm_cvtss_f32(_mm_rsqrt_ss(_mm_set_ss(x))) }
    };
    #[cfg(not(any(target_feature = "avx2", target_feature = "avx512f")))]
    let y = 1.0 / x.sqrt();
    newton_rsqrt_step(x, y)
}

/// One Newton step y·(1.5 − ½x·y²) from an estimate y of 1/√x, the same
/// operations on every lane width, so the wide rsqrts are the scalar one
/// lane by lane (−½·x is −(½·x) exactly).
#[inline(always)]
fn newton_rsqrt_step<T: PolyLane>(x: T, y: T) -> T {
    let minus_half_x = T::splat(-0.5) * x;
    y * minus_half_x.fma(y * y, T::splat(1.5))
}

/// The hardware estimate of 1/√x on 16 lanes, the one [`rsqrt`] refines
/// (lane for lane the scalar estimate: vrsqrt14ps on AVX-512, on one zmm
/// register or, with the `ymm-kernels` feature, on two ymm halves; vrsqrtps
/// on AVX2).
#[inline(always)]
pub fn rsqrt_estimate_x16(x: f32x16) -> f32x16 {
    #[cfg(all(target_arch = "x86_64", zmm_kernels))]
    {
        use std::arch::x86_64::{__m512, _mm512_rsqrt14_ps};
        // SAFETY: f32x16 and __m512 are both 64 bytes holding 16 f32;
        // avx512f is enabled at compile time (the cfg above).
        unsafe {
            let v: __m512 = std::mem::transmute(x);
            std::mem::transmute(_mm512_rsqrt14_ps(v))
        }
    }
    #[cfg(all(target_feature = "avx2", not(zmm_kernels)))]
    {
        super::simd_avx2::rsqrt_estimate(x)
    }
    #[cfg(not(any(target_feature = "avx2", zmm_kernels)))]
    {
        f32x16::splat(1.0) / x.sqrt()
    }
}

/// [`rsqrt`] on 4 lanes: the same hardware estimate as the scalar one
/// (`rsqrt14` under AVX-512, `rsqrt` under AVX2), refined the same way.
#[inline(always)]
pub fn rsqrt_x4(x: f32x4) -> f32x4 {
    #[cfg(all(target_arch = "x86_64", target_feature = "avx512vl"))]
    let y: f32x4 = {
        use std::arch::x86_64::{__m128, _mm_rsqrt14_ps};
        // SAFETY: f32x4 and __m128 are both 16 bytes holding 4 f32;
        // avx512vl is enabled at compile time (the cfg above).
        unsafe {
            let v: __m128 = std::mem::transmute(x);
            std::mem::transmute(_mm_rsqrt14_ps(v))
        }
    };
    #[cfg(all(target_feature = "avx2", not(target_feature = "avx512vl")))]
    let y: f32x4 = {
        use std::arch::x86_64::{__m128, _mm_rsqrt_ps};
        // SAFETY: as above; avx2 (so sse) is enabled at compile time.
        unsafe {
            let v: __m128 = std::mem::transmute(x);
            std::mem::transmute(_mm_rsqrt_ps(v))
        }
    };
    #[cfg(not(any(target_feature = "avx2", target_feature = "avx512vl")))]
    let y = f32x4::splat(1.0) / x.sqrt();
    newton_rsqrt_step(x, y)
}

/// [`rsqrt`] on 16 lanes.
#[inline(always)]
pub fn rsqrt_x16(x: f32x16) -> f32x16 {
    newton_rsqrt_step(x, rsqrt_estimate_x16(x))
}

/// f32 and f32x16 alike: the polynomial below is written once for both,
/// so the scalar and wide kernels run the same operations in the same order.
pub trait PolyLane: Copy + std::ops::Mul<Output = Self> {
    fn splat(c: f32) -> Self;
    /// self·a + b, fused.
    fn fma(self, a: Self, b: Self) -> Self;
}

impl PolyLane for f32 {
    #[inline(always)]
    fn splat(c: f32) -> Self {
        c
    }
    #[inline(always)]
    fn fma(self, a: Self, b: Self) -> Self {
        self.mul_add(a, b)
    }
}

macro_rules! poly_lane_for_vectors {
    ($($lanes:ty),*) => {$(
        impl PolyLane for $lanes {
            #[inline(always)]
            fn splat(c: f32) -> Self {
                <$lanes>::splat(c)
            }
            #[inline(always)]
            fn fma(self, a: Self, b: Self) -> Self {
                self.mul_add(a, b)
            }
        }
    )*};
}
poly_lane_for_vectors!(f32x4, f32x16);

/// θ/sin θ on [0, 1] (the polynomial alone), in Estrin's form: 9
/// operations instead of Horner's 7, but a dependency chain of 3 instead
/// of 7, which matters because a descent waits for each level's result.
#[inline(always)]
pub fn theta_over_sin_poly<T: PolyLane>(x: T) -> T {
    let c = THETA_OVER_SIN.map(T::splat);
    let (x2, pair) = (x * x, |i: usize| c[i + 1].fma(x, c[i]));
    let lo = pair(2).fma(x2, pair(0));
    let hi = pair(6).fma(x2, pair(4));
    hi.fma(x2 * x2, lo)
}

/// θ/sin θ of an edge between unit vectors with dot product `d` and cross
/// product of squared length `q`. Past 90° (d < 0) θ = π − θ(|d|), so
/// θ/sin θ = π/sin θ − θ(|d|)/sin θ; sin θ = √q is taken from the cross
/// product, which stays accurate near d = −1 where √(1 − d²) would not.
#[inline(always)]
pub fn theta_over_sin(d: f32, q: impl FnOnce() -> f32) -> f32 {
    let p = theta_over_sin_poly(d.abs());
    if d < 0.0 {
        theta_over_sin_obtuse(p, q())
    } else {
        p
    }
}

/// The obtuse branch of [`theta_over_sin`]: π/sin θ − p, with
/// p = `theta_over_sin_poly(|d|)` and sin θ = √q.
#[inline(always)]
pub fn theta_over_sin_obtuse(p: f32, q: f32) -> f32 {
    std::f32::consts::PI.mul_add(rsqrt(q.max(RSQRT_FLOOR)), -p)
}

/// [`theta_over_sin`] on 16 lanes; the obtuse branch is only evaluated
/// when some lane needs it.
#[inline(always)]
pub fn theta_over_sin_x16(d: f32x16, q: impl FnOnce() -> f32x16) -> f32x16 {
    let p = theta_over_sin_poly(d.abs());
    let obtuse = d.simd_lt(f32x16::splat(0.0));
    if obtuse.any() {
        let rs = rsqrt_x16(q().fast_max(f32x16::splat(RSQRT_FLOOR)));
        let far = f32x16::splat(std::f32::consts::PI).mul_add(rs, -p);
        obtuse.bitselect(far, p)
    } else {
        p
    }
}

const TABLE_BITS: u32 = 11;
/// Angles resolved by the two tables: 2π·n/2^22 for n < 2^22.
pub const DYADIC_BITS: u32 = 2 * TABLE_BITS;

struct SinCosTables {
    /// sin, cos of 2π·i/2^11.
    hi: [[f32; 2]; 1 << TABLE_BITS],
    /// sin, cos of 2π·i/2^22.
    lo: [[f32; 2]; 1 << TABLE_BITS],
    /// [`dyadic_sincos`]`(1, d)` for d ≤ 22, as computed by it.
    step: [(f32, f32); DYADIC_BITS as usize + 1],
}

// Held in the static itself, not boxed: a box would put one more
// dependent load before every table read on the kernels' critical path.
static TABLES: LazyLock<SinCosTables> = LazyLock::new(|| {
    let entry = |turns: f64| {
        let (s, c) = (2.0 * std::f64::consts::PI * turns).sin_cos();
        [s as f32, c as f32]
    };
    let n = 1usize << TABLE_BITS;
    let mut t = SinCosTables {
        hi: std::array::from_fn(|i| entry(i as f64 / n as f64)),
        lo: std::array::from_fn(|i| entry(i as f64 / (n * n) as f64)),
        step: [(0.0, 0.0); DYADIC_BITS as usize + 1],
    };
    for d in 0..=DYADIC_BITS {
        t.step[d as usize] = table_sincos(&t, 1, d);
    }
    t
});

/// Forces the tables (otherwise built on first use).
pub fn precompute() {
    LazyLock::force(&TABLES);
}

/// sin and cos of 2π·n/2^depth (n < 2^depth ≤ 2^22) by one angle addition
/// of two table entries: within ~2 ulps, no range reduction.
#[inline(always)]
pub fn dyadic_sincos(n: u64, depth: u32) -> (f32, f32) {
    if depth > DYADIC_BITS {
        return deeper_sincos(n, depth);
    }
    table_sincos(&TABLES, n, depth)
}

/// The two table entries behind [`dyadic_sincos`]`(n, depth)` (depth ≤
/// [`DYADIC_BITS`]): [sin, cos] of its high and of its low part.
#[inline(always)]
pub fn dyadic_entries(n: u64, depth: u32) -> ([f32; 2], [f32; 2]) {
    debug_assert!(depth <= DYADIC_BITS);
    table_entries(&TABLES, n, depth)
}

/// Whether the low entry of [`dyadic_entries`]`(n, depth)` is exactly
/// (sin, cos) = (0, 1) for every n: the angles of depths up to the high
/// table's resolution are multiples of its step, so their low part is 0.
/// A rotation by that entry, c·1 − 0·s and 0·c + 1·s fused, returns its
/// operand bit for bit (no operand of the kernels is a signed zero), which
/// lets the wide plain-quad kernel skip it at those depths.
#[inline(always)]
pub const fn dyadic_low_is_identity(depth: u32) -> bool {
    depth <= TABLE_BITS
}

/// [`dyadic_entries`] by reference into the tables, for kernels that
/// broadcast the entries to their lanes straight from memory.
#[inline(always)]
pub fn dyadic_entry_refs(n: u64, depth: u32) -> (&'static [f32; 2], &'static [f32; 2]) {
    debug_assert!(depth <= DYADIC_BITS);
    table_entry_refs(&TABLES, n, depth)
}

#[inline(always)]
fn table_entry_refs(tab: &SinCosTables, n: u64, depth: u32) -> (&[f32; 2], &[f32; 2]) {
    let t = ((n << (DYADIC_BITS - depth)) & ((1 << DYADIC_BITS) - 1)) as usize;
    (
        &tab.hi[t >> TABLE_BITS],
        &tab.lo[t & ((1 << TABLE_BITS) - 1)],
    )
}

#[inline(always)]
fn table_entries(tab: &SinCosTables, n: u64, depth: u32) -> ([f32; 2], [f32; 2]) {
    let (hi, lo) = table_entry_refs(tab, n, depth);
    (*hi, *lo)
}

#[inline(always)]
fn table_sincos(tab: &SinCosTables, n: u64, depth: u32) -> (f32, f32) {
    let ([sh, ch], [sl, cl]) = table_entries(tab, n, depth);
    (sh.mul_add(cl, ch * sl), ch.mul_add(cl, -(sh * sl)))
}

/// sin and cos of a cell's width at `depth`, 2π/2^depth: exactly
/// [`dyadic_sincos`]`(1, depth)`, read from a per-depth table (every grid
/// needs it, and the angle addition sits on the kernels' critical path).
#[inline(always)]
pub fn step_sincos(depth: u32) -> (f32, f32) {
    if depth > DYADIC_BITS {
        return deeper_sincos(1, depth);
    }
    TABLES.step[depth as usize]
}

#[cold]
fn deeper_sincos(n: u64, depth: u32) -> (f32, f32) {
    super::polygon::sincos_turns((n as f64 / (1u64 << depth.min(63)) as f64) as f32)
}

/// 4π/4^depth in f32, exactly the f64 solid angle of a cell rounded.
#[inline]
pub fn cell_solid_angle(depth: u32) -> f32 {
    let scale = f32::from_bits((127u32.saturating_sub(2 * depth.min(63))) << 23);
    (4.0 * std::f32::consts::PI) * scale
}

/// ⌈log₂ x⌉ from the bits (a libm log2 was a twentieth of a shading
/// point's set-up); 64 for anything not finite and positive, which keeps
/// the deep switch off.
pub fn ceil_log2(x: f64) -> i64 {
    if !(x.is_finite() && x > 0.0) {
        return 64;
    }
    let (m, e) = {
        // Scale subnormals into the normal range first.
        let (y, bias) = if x < f64::MIN_POSITIVE {
            (x * 2f64.powi(64), 64)
        } else {
            (x, 0)
        };
        let b = y.to_bits();
        (
            b & ((1u64 << 52) - 1),
            ((b >> 52) & 0x7ff) as i64 - 1023 - bias,
        )
    };
    if m == 0 { e } else { e + 1 }
}

/// atan2(y, x) for y > 0 on four lanes, with
/// [`crate::directional::fast_atan2`]'s reduction and polynomial (so
/// within its 4e-7 rad): one division for four angles. Three calls of the
/// scalar function instead took the diffuse lobe's level 1 through the
/// API from 12.1 to 22.8 ns (session 60).
#[inline(always)]
pub fn atan2_upper_x4(y: f32x4, x: f32x4) -> f32x4 {
    use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};
    let s4 = f32x4::splat;
    let ax = x.abs();
    let (lo, hi) = (ax.fast_min(y), ax.fast_max(y));
    let upper = lo.simd_gt(s4(0.414_213_57) * hi);
    let t = upper.bitselect(lo - hi, lo) / upper.bitselect(lo + hi, hi);
    let z = t * t;
    let p = (((s4(8.053_744_5e-2) * z - s4(1.387_768_6e-1)) * z + s4(1.997_771_1e-1)) * z
        - s4(3.333_295e-1))
        * z
        * t
        + t;
    let r = upper.bitselect(s4(FRAC_PI_4) + p, p);
    let r = y.simd_gt(ax).bitselect(s4(FRAC_PI_2) - r, r);
    x.simd_lt(s4(0.0)).bitselect(s4(PI) - r, r)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ceil_log2_matches_libm() {
        for x in [
            1e-300, 1e-310, 0.3, 0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 1e10, 7.999,
        ] {
            assert_eq!(ceil_log2(x), x.log2().ceil() as i64, "{x}");
        }
        for x in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert_eq!(ceil_log2(x), 64);
        }
    }

    #[test]
    fn short_theta_over_sin_matches_acos() {
        let mut worst = 0.0f64;
        for i in 0..=20000 {
            let d =
                SHORT_EDGE_MIN_COS as f64 + (1.0 - SHORT_EDGE_MIN_COS as f64) * i as f64 / 20000.0;
            let d = d as f32 as f64;
            let want = if d < 1.0 {
                d.acos() / (1.0 - d * d).sqrt()
            } else {
                1.0
            };
            let got = theta_over_sin_short(d as f32) as f64;
            worst = worst.max((got - want).abs() / want);
        }
        assert!(worst < 6e-7, "{worst}");
    }

    #[test]
    fn theta_over_sin_matches_acos() {
        let mut worst = 0.0f64;
        for i in 0..=20000 {
            let d = -0.999 + 1.999 * i as f64 / 20000.0;
            let theta = d.acos();
            let want = theta / theta.sin();
            let q = (1.0 - d * d) as f32;
            let got = theta_over_sin(d as f32, || q) as f64;
            worst = worst.max((got - want).abs() / want);
        }
        assert!(worst < 1e-6, "{worst}");
        assert!((rsqrt(2.0) as f64 - 0.5f64.sqrt()).abs() < 2e-7);
    }

    /// The low entries that [`dyadic_low_is_identity`] calls the identity
    /// are (0, 1) exactly, and the first depth past it has others.
    #[test]
    fn low_entries_are_the_identity_up_to_the_high_tables_resolution() {
        for depth in 0..=DYADIC_BITS {
            let nodes = 1u64 << depth;
            let exact = (0..nodes.min(4096)).all(|n| dyadic_entries(n, depth).1 == [0.0, 1.0]);
            assert_eq!(exact, dyadic_low_is_identity(depth), "depth {depth}");
        }
    }

    #[test]
    fn dyadic_sincos_is_accurate() {
        for depth in [0u32, 1, 3, 7, 12, 20, 22] {
            let n = 1u64 << depth;
            for i in [0, 1, n / 3, n / 2, n - 1] {
                let (s, c) = dyadic_sincos(i, depth);
                let phi = 2.0 * std::f64::consts::PI * i as f64 / n as f64;
                assert!((s as f64 - phi.sin()).abs() < 3e-7, "{depth} {i}");
                assert!((c as f64 - phi.cos()).abs() < 3e-7, "{depth} {i}");
            }
        }
        for d in 0..30 {
            assert_eq!(step_sincos(d), dyadic_sincos(1, d));
            let want = 4.0 * std::f64::consts::PI / (1u64 << (2 * d)) as f64;
            assert_eq!(cell_solid_angle(d), want as f32);
        }
    }

    #[test]
    fn rsqrt_is_accurate_and_the_wide_estimate_is_the_scalar_one() {
        let mut worst = 0.0f64;
        for i in 0..=60_000 {
            // 1e-30 ..= 1e30, geometrically, plus the mantissa in between.
            let x = (1e-30f64 * 10f64.powf(60.0 * i as f64 / 60_000.0)) as f32;
            let x = x.max(RSQRT_FLOOR);
            let exact = 1.0 / (x as f64).sqrt();
            worst = worst.max((rsqrt(x) as f64 / exact - 1.0).abs());
            let lanes = f32x16::from(std::array::from_fn::<f32, 16, _>(|l| {
                x * (1.0 + l as f32 / 16.0)
            }));
            let wide = rsqrt_x16(lanes).to_array();
            for (l, &v) in lanes.to_array().iter().enumerate() {
                assert_eq!(wide[l].to_bits(), rsqrt(v).to_bits(), "x = {v}");
            }
            let quad: [f32; 4] = std::array::from_fn(|l| lanes.to_array()[4 * l + 1]);
            let narrow = rsqrt_x4(f32x4::from(quad)).to_array();
            for (l, &v) in quad.iter().enumerate() {
                assert_eq!(narrow[l].to_bits(), rsqrt(v).to_bits(), "x = {v}");
            }
        }
        assert!(worst < 3e-7, "worst relative error {worst:e}");
    }
}
