//! Does a 512-bit floating-point instruction slow down the code after it on
//! this host? Answers whether a build with the `ymm-kernels` feature (see
//! `src/ltc/lanes.rs`) should pay here.
//!
//! `cargo run --release --example zmm_clock_probe`
//!
//! A dependent chain of integer multiply-adds (bound by the clock alone;
//! LLVM strides it; a slice of 20 000 steps took 1.3 µs on a 4 GHz Xeon)
//! is timed slice by slice. Before every slice the probe runs a short
//! burst of one kind of instruction, a few of them:
//! - nothing;
//! - 256-bit FMAs;
//! - 512-bit FMAs;
//! - 512-bit adds;
//! - 512-bit loads and stores.
//!
//! On an Intel core that lowers its clock for 512-bit arithmetic, the chain
//! after the 512-bit arithmetic bursts runs ~8 % slower, and nothing else
//! moves. The kinds are interleaved round by round so that a drifting host
//! meets them alike; the median round is reported.

#[cfg(target_arch = "x86_64")]
mod probe {
    use std::arch::x86_64::*;
    use std::hint::black_box;
    use std::time::Instant;

    const SLICE: u32 = 20_000;
    const SLICES: u32 = 2_000;
    const BURST: u32 = 4;

    fn chain(mut x: u64, n: u32) -> u64 {
        for _ in 0..n {
            x = x
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
        }
        x
    }

    #[target_feature(enable = "avx2,fma")]
    fn ymm_fma(seed: f32) -> f32 {
        let (b, c) = (_mm256_set1_ps(1.000_000_1), _mm256_set1_ps(1e-7));
        let mut a = _mm256_set1_ps(seed);
        for _ in 0..BURST {
            a = _mm256_fmadd_ps(black_box(a), b, c);
        }
        _mm256_cvtss_f32(a)
    }

    #[target_feature(enable = "avx512f")]
    fn zmm_fma(seed: f32) -> f32 {
        let (b, c) = (_mm512_set1_ps(1.000_000_1), _mm512_set1_ps(1e-7));
        let mut a = _mm512_set1_ps(seed);
        for _ in 0..BURST {
            a = _mm512_fmadd_ps(black_box(a), b, c);
        }
        _mm512_cvtss_f32(a)
    }

    #[target_feature(enable = "avx512f")]
    fn zmm_add(seed: f32) -> f32 {
        let b = _mm512_set1_ps(1e-7);
        let mut a = _mm512_set1_ps(seed);
        for _ in 0..BURST {
            a = _mm512_add_ps(black_box(a), b);
        }
        _mm512_cvtss_f32(a)
    }

    #[target_feature(enable = "avx512f")]
    fn zmm_move(buffer: &mut [f32; 64]) -> f32 {
        for i in 0..BURST as usize {
            // SAFETY: lanes 16·(i % 3) .. +16 and 16·(i % 3 + 1) .. +16
            // lie inside the 64-float buffer.
            unsafe {
                let v = _mm512_loadu_ps(buffer.as_ptr().add(16 * (i % 3)));
                _mm512_storeu_ps(buffer.as_mut_ptr().add(16 * (i % 3 + 1)), black_box(v));
            }
        }
        buffer[5]
    }

    /// Microseconds per slice of the chain after bursts of `kind`.
    fn run(kind: usize, avx512: bool, buffer: &mut [f32; 64]) -> f64 {
        let (mut x, mut f, mut chained) = (1u64, 0.0f32, 0.0f64);
        for _ in 0..SLICES {
            // SAFETY: each function's features were detected at run time.
            f += unsafe {
                match kind {
                    1 => ymm_fma(f),
                    2 if avx512 => zmm_fma(f),
                    3 if avx512 => zmm_add(f),
                    4 if avx512 => zmm_move(buffer),
                    _ => 0.0,
                }
            };
            let start = Instant::now();
            x = chain(black_box(x), SLICE);
            chained += start.elapsed().as_secs_f64();
        }
        black_box((x, f));
        chained / SLICES as f64 * 1e6
    }

    pub fn main() {
        let avx512 = is_x86_feature_detected!("avx512f");
        if !is_x86_feature_detected!("avx2") || !is_x86_feature_detected!("fma") {
            println!("this host has no AVX2 and FMA: nothing to probe");
            return;
        }
        let names = [
            "nothing",
            "256-bit FMA",
            "512-bit FMA",
            "512-bit add",
            "512-bit load/store",
        ];
        let kinds = if avx512 { 5 } else { 2 };
        let mut buffer = [1.0f32; 64];
        let mut times: Vec<Vec<f64>> = vec![Vec::new(); kinds];
        for _round in 0..7 {
            for (kind, t) in times.iter_mut().enumerate() {
                t.push(run(kind, avx512, &mut buffer));
            }
        }
        let median = |t: &mut Vec<f64>| {
            t.sort_by(f64::total_cmp);
            t[t.len() / 2]
        };
        let base = median(&mut times[0]);
        println!(
            "integer chain, µs per slice after a burst of {BURST} instructions before each slice (median of 7 rounds):"
        );
        for (kind, t) in times.iter_mut().enumerate() {
            let m = median(t);
            println!(
                "  {:20} {:.3} µs  ({:.3}× nothing)",
                names[kind],
                m,
                m / base
            );
        }
        if !avx512 {
            println!("no AVX-512 here: the kernels are 256-bit in any build");
            return;
        }
        let slowdown = median(&mut times[2]) / base;
        if slowdown > 1.03 {
            println!(
                "512-bit arithmetic slows what follows it by {:.1} %: a `--features ymm-kernels` build should render the product faster here",
                (slowdown - 1.0) * 100.0
            );
        } else {
            println!(
                "512-bit arithmetic does not slow what follows it (within 3 %): keep the default zmm kernels"
            );
        }
    }
}

fn main() {
    #[cfg(target_arch = "x86_64")]
    probe::main();
    #[cfg(not(target_arch = "x86_64"))]
    println!("the probe is for x86-64 hosts");
}
