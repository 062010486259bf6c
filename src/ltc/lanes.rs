//! The 16-lane vector type of the wide kernels.
//!
//! By default it is `wide::f32x16`, one zmm register on an AVX-512 build.
//! With the cargo feature `ymm-kernels` it is [`F32x16Pair`], the same 16
//! lanes as two 256-bit halves, while the rest of the program keeps its
//! AVX-512 code generation (EVEX encodings, 32 vector registers).
//!
//! Why a build would want that: on Intel cores any 512-bit floating-point
//! instruction (a multiply, an add, a conversion) lowers the core's clock
//! for every instruction that follows it, for a while after the last one. A product render runs the
//! kernels at every vertex, so the whole render, ray traversal included,
//! runs at the lower clock. `docs/results-reading.md` (session 63) measures
//! it. AMD's Zen 4 and Zen 5 have no such penalty, so the default keeps
//! the zmm kernels.
//!
//! The kernels only use the operations below, in the same order in both
//! types, so the two builds agree bit for bit; the 1/√x estimate is
//! vrsqrt14ps on each half as on the whole register
//! ([`super::fast_math::rsqrt_estimate_x16`]).

#[cfg(not(feature = "ymm-kernels"))]
pub use wide::f32x16;

#[cfg(feature = "ymm-kernels")]
#[allow(non_camel_case_types)]
pub type f32x16 = F32x16Pair;

/// How this build holds the wide kernels' 16 lanes, as `render
/// --stats-json` and `compare`'s pages name it: `zmm` (one 512-bit
/// register, the default on AVX-512), `ymm-kernels` (two 256-bit halves on
/// an AVX-512 build, the cargo feature), `avx2` (a build without AVX-512:
/// `wide` splits the lanes itself) or `portable`.
pub const LAYOUT: &str = if cfg!(zmm_kernels) {
    "zmm"
} else if cfg!(feature = "ymm-kernels") && cfg!(target_feature = "avx512f") {
    "ymm-kernels"
} else if cfg!(target_feature = "avx2") {
    "avx2"
} else {
    "portable"
};

/// Whether this process runs on an Intel core with AVX-512, where a
/// 512-bit floating-point instruction lowers the clock of what follows it
/// (session 63 measured 8 % on a Xeon; AMD's Zen 4 and Zen 5 do not).
pub fn host_slows_under_512_bit_arithmetic() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        // CPUID leaf 0 (the vendor string) exists on every x86-64 processor.
        let id = std::arch::x86_64::__cpuid(0);
        let vendor: Vec<u8> = [id.ebx, id.edx, id.ecx]
            .iter()
            .flat_map(|r| r.to_le_bytes())
            .collect();
        vendor == b"GenuineIntel" && std::arch::is_x86_feature_detected!("avx512f")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// A note for a run whose product descents use the wide kernels, when
/// this build's zmm kernels will lower the clock of the host's whole
/// render: the build to use instead.
pub fn layout_note(uses_wide_kernels: bool) -> Option<String> {
    (uses_wide_kernels && LAYOUT == "zmm" && host_slows_under_512_bit_arithmetic()).then(|| {
        "note: this Intel AVX-512 core lowers its clock under the zmm LTC kernels, for the \
         whole render; a `cargo build --release --features ymm-kernels` binary computes the same \
         image faster here (staircase's product: 4-5 % more samples per CPU second, \
         docs/results-reading.md, session 63)"
            .to_string()
    })
}

use std::ops::{Add, AddAssign, BitAnd, BitXor, Div, Mul, Neg, Not, Sub};
use wide::f32x8;

/// `v` in every lane, converted to f32 lane-wise (vcvtdq2ps on a
/// broadcast): a scalar conversion would merge into a stale register and
/// wait for whatever last wrote it.
#[inline(always)]
pub fn splat_converted(v: i32) -> f32x16 {
    #[cfg(not(feature = "ymm-kernels"))]
    {
        wide::i32x16::splat(v).round_float()
    }
    #[cfg(feature = "ymm-kernels")]
    {
        let h = wide::i32x8::splat(v).round_float();
        F32x16Pair { lo: h, hi: h }
    }
}

/// 16 f32 lanes held as two `wide::f32x8` halves, lanes 0–7 in `lo`. The
/// layout is that of `[__m256; 2]`, which the AVX2 helpers of
/// [`super::simd_avx2`] rely on.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, align(64))]
pub struct F32x16Pair {
    lo: f32x8,
    hi: f32x8,
}

macro_rules! lanewise {
    ($($name:ident),*) => {$(
        #[inline(always)]
        #[must_use]
        pub fn $name(self) -> Self {
            Self { lo: self.lo.$name(), hi: self.hi.$name() }
        }
    )*};
}

macro_rules! lanewise2 {
    ($($name:ident),*) => {$(
        #[inline(always)]
        #[must_use]
        pub fn $name(self, rhs: Self) -> Self {
            Self { lo: self.lo.$name(rhs.lo), hi: self.hi.$name(rhs.hi) }
        }
    )*};
}

macro_rules! lanewise3 {
    ($($name:ident),*) => {$(
        #[inline(always)]
        #[must_use]
        pub fn $name(self, a: Self, b: Self) -> Self {
            Self { lo: self.lo.$name(a.lo, b.lo), hi: self.hi.$name(a.hi, b.hi) }
        }
    )*};
}

impl F32x16Pair {
    #[inline(always)]
    #[must_use]
    pub fn splat(v: f32) -> Self {
        let h = f32x8::splat(v);
        Self { lo: h, hi: h }
    }

    #[inline(always)]
    #[must_use]
    pub fn to_array(self) -> [f32; 16] {
        // SAFETY: two f32x8 are 16 consecutive f32 (repr(C), no padding).
        unsafe { std::mem::transmute(self) }
    }

    #[inline(always)]
    #[must_use]
    pub fn as_array(&self) -> &[f32; 16] {
        // SAFETY: as in `to_array`; the reference keeps self's lifetime.
        unsafe { &*(self as *const Self as *const [f32; 16]) }
    }

    lanewise!(abs, sqrt, floor);
    lanewise2!(fast_max, simd_eq, simd_lt, simd_gt, simd_le, simd_ge);
    lanewise3!(mul_add);

    /// Lanes of `if_one` where the mask's bits are set, else `if_zero`.
    #[inline(always)]
    #[must_use]
    pub fn bitselect(self, if_one: Self, if_zero: Self) -> Self {
        Self {
            lo: self.lo.bitselect(if_one.lo, if_zero.lo),
            hi: self.hi.bitselect(if_one.hi, if_zero.hi),
        }
    }

    /// Bit l is set where lane l's sign bit is (lane l of a mask is true).
    #[inline(always)]
    #[must_use]
    pub fn to_bitmask(self) -> u32 {
        self.lo.to_bitmask() | (self.hi.to_bitmask() << 8)
    }

    #[inline(always)]
    #[must_use]
    pub fn any(self) -> bool {
        self.lo.any() || self.hi.any()
    }
}

impl From<[f32; 16]> for F32x16Pair {
    #[inline(always)]
    fn from(a: [f32; 16]) -> Self {
        // SAFETY: the same layout as `to_array`'s.
        unsafe { std::mem::transmute(a) }
    }
}

macro_rules! binary_op {
    ($($trait:ident $method:ident),*) => {$(
        impl $trait for F32x16Pair {
            type Output = Self;
            #[inline(always)]
            fn $method(self, rhs: Self) -> Self {
                Self { lo: self.lo.$method(rhs.lo), hi: self.hi.$method(rhs.hi) }
            }
        }
    )*};
}
binary_op!(Add add, Sub sub, Mul mul, Div div, BitAnd bitand, BitXor bitxor);

macro_rules! assign_op {
    ($($trait:ident $method:ident $op:ident),*) => {$(
        impl $trait for F32x16Pair {
            #[inline(always)]
            fn $method(&mut self, rhs: Self) {
                *self = (*self).$op(rhs);
            }
        }
    )*};
}
assign_op!(AddAssign add_assign add);

impl Neg for F32x16Pair {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        Self {
            lo: -self.lo,
            hi: -self.hi,
        }
    }
}

impl Not for F32x16Pair {
    type Output = Self;
    #[inline(always)]
    fn not(self) -> Self {
        Self {
            lo: !self.lo,
            hi: !self.hi,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::F32x16Pair;
    use wide::f32x16 as Zmm;

    /// Inputs with the awkward values in every lane position: signed zeros,
    /// infinities, NaN, denormals, and ordinary values of both signs.
    fn inputs() -> Vec<[f32; 16]> {
        let special = [
            0.0,
            -0.0,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            1e-40,
            -1e-40,
            1.0,
            -1.0,
            0.5,
            2.5,
            -2.5,
            3.0e38,
            -7.25,
            1e-7,
            42.0,
        ];
        let mut state = 0x9e37_79b9_u32;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            (state as f32 / u32::MAX as f32) * 8.0 - 4.0
        };
        let mut out: Vec<[f32; 16]> = (0..16)
            .map(|r| std::array::from_fn(|l| special[(l + r) % 16]))
            .collect();
        out.extend((0..64).map(|_| std::array::from_fn(|_| next())));
        out
    }

    fn bits(a: [f32; 16]) -> [u32; 16] {
        a.map(f32::to_bits)
    }

    /// Every operation the kernels use gives the zmm type's bits lane for
    /// lane, so a `ymm-kernels` build computes what the default build does.
    #[test]
    fn pair_matches_the_zmm_type_bit_for_bit() {
        let xs = inputs();
        let mut checked = 0;
        for (i, &a) in xs.iter().enumerate() {
            let b = xs[(i * 7 + 3) % xs.len()];
            let c = xs[(i * 13 + 5) % xs.len()];
            let (pa, pb, pc) = (
                F32x16Pair::from(a),
                F32x16Pair::from(b),
                F32x16Pair::from(c),
            );
            let (za, zb, zc) = (Zmm::from(a), Zmm::from(b), Zmm::from(c));
            let pairs: Vec<(&str, F32x16Pair, Zmm)> = vec![
                ("add", pa + pb, za + zb),
                ("sub", pa - pb, za - zb),
                ("mul", pa * pb, za * zb),
                ("div", pa / pb, za / zb),
                ("neg", -pa, -za),
                ("and", pa & pb, za & zb),
                ("xor", pa ^ pb, za ^ zb),
                ("not", !pa, !za),
                ("abs", pa.abs(), za.abs()),
                ("sqrt", pa.sqrt(), za.sqrt()),
                ("floor", pa.floor(), za.floor()),
                ("fast_max", pa.fast_max(pb), za.fast_max(zb)),
                ("eq", pa.simd_eq(pb), za.simd_eq(zb)),
                ("lt", pa.simd_lt(pb), za.simd_lt(zb)),
                ("gt", pa.simd_gt(pb), za.simd_gt(zb)),
                ("le", pa.simd_le(pb), za.simd_le(zb)),
                ("ge", pa.simd_ge(pb), za.simd_ge(zb)),
                ("mul_add", pa.mul_add(pb, pc), za.mul_add(zb, zc)),
                (
                    "bitselect",
                    pa.simd_lt(pb).bitselect(pb, pc),
                    za.simd_lt(zb).bitselect(zb, zc),
                ),
            ];
            for (name, p, z) in pairs {
                // NaN payloads may differ between instruction forms; any
                // NaN agrees with any NaN, every other lane bit for bit.
                for (l, (x, y)) in p.to_array().iter().zip(z.to_array()).enumerate() {
                    assert!(
                        x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()),
                        "{name} lane {l}: {x:e} against {y:e} (inputs {}, {}, {})",
                        a[l],
                        b[l],
                        c[l]
                    );
                }
                checked += 1;
            }
            let mask = pa.simd_lt(pb);
            assert_eq!(mask.to_bitmask(), za.simd_lt(zb).to_bitmask());
            assert_eq!(mask.any(), za.simd_lt(zb).any());
            assert_eq!(bits(pa.to_array()), bits(a));
            assert_eq!(bits(*pa.as_array()), bits(a));
        }
        assert_eq!(checked, 19 * xs.len());
        let s = F32x16Pair::splat(-3.5);
        assert_eq!(bits(s.to_array()), bits(Zmm::splat(-3.5).to_array()));
        assert_eq!(
            bits(super::splat_converted(16_777_215).to_array()),
            bits(wide::i32x16::splat(16_777_215).round_float().to_array())
        );
    }
}
