//! Random numbers and the standard warps from the unit square.

use crate::math::{INV_PI, PI};
use glam::{Vec2, Vec3};

/// PCG32 (O'Neill 2014): small, fast and reproducible across platforms, so a
/// seed and a thread count determine an image exactly.
#[derive(Clone, Debug)]
pub struct Rng {
    state: u64,
    inc: u64,
}

impl Rng {
    /// A stream selected by `stream`, started by `seed`. Distinct streams are
    /// statistically independent, which lets every pixel/pass own one.
    pub fn new(seed: u64, stream: u64) -> Self {
        let mut rng = Rng {
            state: 0,
            inc: (stream << 1) | 1,
        };
        rng.next_u32();
        rng.state = rng.state.wrapping_add(seed);
        rng.next_u32();
        rng
    }

    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(6364136223846793005).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// Uniform in [0, 1), never exactly 1.
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        grid_f32(self.next_u32())
    }

    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        Vec2::new(self.next_f32(), self.next_f32())
    }

    /// Uniform in [0, 1) with 53 bits, for f64 reference integrators.
    #[inline]
    pub fn next_f64(&mut self) -> f64 {
        let hi = (self.next_u32() >> 5) as u64;
        let lo = (self.next_u32() >> 6) as u64;
        ((hi << 26) | lo) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

/// The float [`Rng::next_f32`] makes of 32 random bits: its top 24 bits
/// times 2⁻²⁴, a multiple of [`F32_GRID`] in [0, 1).
#[inline]
pub fn grid_f32(bits: u32) -> f32 {
    (bits >> 8) as f32 * F32_GRID
}

/// The spacing of the values [`Rng::next_f32`] returns.
pub const F32_GRID: f32 = 1.0 / (1u32 << 24) as f32;

/// A survival probability `q` rounded up to [`F32_GRID`], within [2⁻²⁴, 1]
/// (1 for NaN or q ≥ 1). Exactly q'·2²⁴ of the 2²⁴ values of
/// [`Rng::next_f32`] lie below q', so `u < q'` survives with probability
/// exactly q', and a survivor weighted 1/q' keeps the estimate unbiased.
/// Compared with q itself, P(u < q) is q rounded up to the grid: weighted
/// 1/q, the survivors' expectation is off by up to 2⁻²⁴/q relative (×1.33
/// at q = 1.5·2⁻²⁴), and a q far below 2⁻²⁴ gave huge weights.
#[inline]
pub fn survival_on_grid(q: f32) -> f32 {
    if !(q < 1.0) {
        return 1.0;
    }
    // Scaling by a power of two and ceil are exact; so is k·2⁻²⁴ for k ≤ 2²⁴.
    (q * (1u32 << 24) as f32).ceil().max(1.0) * F32_GRID
}

/// Russian roulette with survival probability `q` and `u` from
/// [`Rng::next_f32`]: the factor to weight a survivor by, `None` when the
/// path ends. Survival and weight use [`survival_on_grid`]'s q', so
/// E[factor] = 1 up to the rounding of 1/q'.
#[inline]
pub fn roulette(q: f32, u: f32) -> Option<f32> {
    let q = survival_on_grid(q);
    (u < q).then(|| 1.0 / q)
}

/// Concentric map of Shirley and Chiu: preserves stratification better than
/// the polar map.
#[inline]
pub fn square_to_disk_concentric(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    // Both branches as selects around one division: the branch on a
    // uniformly random u would mispredict half the time.
    // θ = q or π/2 − q with |q| ≤ π/4, so sin θ and cos θ are the
    // quarter-range sine and cosine of q, possibly swapped.
    let near_y = o.x.abs() <= o.y.abs();
    let (num, r) = if near_y { (o.x, o.y) } else { (o.y, o.x) };
    let q = (PI / 4.0) * (num / r);
    let (sq, cq) = crate::math::sin_cos_quarter(q);
    let (s, c) = if near_y { (cq, sq) } else { (sq, cq) };
    Vec2::new(r * c, r * s)
}

#[inline]
pub fn square_to_cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = square_to_disk_concentric(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

#[inline]
pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    if cos_theta > 0.0 {
        cos_theta * INV_PI
    } else {
        0.0
    }
}

#[inline]
pub fn square_to_uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (s, c) = (2.0 * PI * u.y).sin_cos();
    Vec3::new(r * c, r * s, z)
}

/// Uniform barycentrics on a triangle (Heitz's low-distortion map is not needed
/// here; the square-root map is exact in measure).
#[inline]
pub fn square_to_triangle(u: Vec2) -> Vec2 {
    let su = u.x.sqrt();
    Vec2::new(1.0 - su, u.y * su)
}

/// The power heuristic with beta = 2, in the ratio of the smaller pdf to
/// the larger: a² + b² overflowed from pdfs of ~1.8e19 on (and underflowed
/// below ~1e-19), and both strategies then took weight 1. A pdf that is
/// zero or NaN gets weight 0 and leaves its partner 1; two infinite pdfs
/// share 1/2 each.
#[inline]
pub fn power_heuristic(pdf_a: f32, pdf_b: f32) -> f32 {
    if !(pdf_a > 0.0) {
        return 0.0;
    }
    if !(pdf_b > 0.0) {
        return 1.0;
    }
    if pdf_a == pdf_b {
        return 0.5;
    }
    // r ≤ 1, so r² cannot overflow; it underflows only where the weight
    // rounds to 0 or 1 anyway. An infinite pdf makes r = 0.
    if pdf_a > pdf_b {
        let r = pdf_b / pdf_a;
        1.0 / (1.0 + r * r)
    } else {
        let r2 = (pdf_a / pdf_b).powi(2);
        r2 / (1.0 + r2)
    }
}

/// A piecewise-constant 1D distribution with its CDF, for emitter and
/// environment-map selection.
#[derive(Clone, Debug)]
pub struct Distribution1D {
    pub func: Vec<f32>,
    cdf: Vec<f64>,
    pub integral: f64,
}

impl Distribution1D {
    /// Non-finite or negative entries are treated as zero; an all-zero input
    /// becomes uniform so sampling is always defined.
    pub fn new(values: &[f32]) -> Self {
        let func: Vec<f32> = values
            .iter()
            .map(|&v| if v.is_finite() && v > 0.0 { v } else { 0.0 })
            .collect();
        let n = func.len().max(1);
        let mut cdf = Vec::with_capacity(n + 1);
        cdf.push(0.0f64);
        for &f in &func {
            let last = *cdf.last().unwrap();
            cdf.push(last + f as f64 / n as f64);
        }
        let integral = *cdf.last().unwrap();
        if integral > 0.0 {
            for c in cdf.iter_mut() {
                *c /= integral;
            }
        } else {
            for (i, c) in cdf.iter_mut().enumerate() {
                *c = i as f64 / n as f64;
            }
        }
        Distribution1D {
            func,
            cdf,
            integral,
        }
    }

    pub fn len(&self) -> usize {
        self.func.len()
    }

    pub fn is_empty(&self) -> bool {
        self.func.is_empty()
    }

    /// Returns (index, pdf of the index, the sample rescaled to [0,1) inside the bin).
    pub fn sample_discrete(&self, u: f32) -> (usize, f32, f32) {
        let u = u as f64;
        let n = self.func.len();
        // The first bin with cdf[i+1] > u (the last bin if none): the last
        // i < n with cdf[i] <= u, as cdf is non-decreasing with cdf[0] = 0.
        // A branch-free search: u is random, so a branching one mispredicts
        // half its steps (emitter triangles are sampled per shadow ray).
        let mut i = 0usize;
        let mut len = n.max(1);
        while len > 1 {
            let half = len / 2;
            i = if self.cdf[i + half] <= u { i + half } else { i };
            len -= half;
        }
        let width = self.cdf[i + 1] - self.cdf[i];
        let remapped = if width > 0.0 {
            ((u - self.cdf[i]) / width).clamp(0.0, 1.0 - f64::EPSILON)
        } else {
            0.5
        };
        (i, self.discrete_pdf(i), remapped as f32)
    }

    pub fn discrete_pdf(&self, i: usize) -> f32 {
        (self.cdf[i + 1] - self.cdf[i]) as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distribution_samples_proportionally() {
        let d = Distribution1D::new(&[1.0, 0.0, 3.0, f32::NAN]);
        assert_eq!(d.discrete_pdf(1), 0.0);
        assert_eq!(d.discrete_pdf(3), 0.0);
        assert!((d.discrete_pdf(2) - 0.75).abs() < 1e-6);
        let mut rng = Rng::new(1, 2);
        let mut counts = [0u32; 4];
        for _ in 0..40000 {
            counts[d.sample_discrete(rng.next_f32()).0] += 1;
        }
        assert_eq!(counts[1] + counts[3], 0);
        assert!((counts[2] as f32 / 40000.0 - 0.75).abs() < 0.01);
    }

    #[test]
    fn discrete_search_finds_the_first_bin_above_u() {
        for weights in [
            vec![1.0],
            vec![1.0, 1.0],
            vec![0.0, 2.0, 0.0, 0.0, 1.0, 3.0, 0.0],
            vec![5.0, 0.0, 0.0],
        ] {
            let d = Distribution1D::new(&weights);
            let n = weights.len();
            for k in 0..=1000 {
                let u = (k as f32 / 1000.0).min(1.0 - f32::EPSILON);
                let expected = (0..n).find(|&i| d.cdf[i + 1] > u as f64).unwrap_or(n - 1);
                assert_eq!(d.sample_discrete(u).0, expected, "{weights:?} u={u}");
            }
            assert_eq!(d.sample_discrete(f32::NAN).0, 0);
        }
    }

    /// Every grid value of `next_f32` enumerated: survival is exactly q',
    /// q' is q rounded up (by less than one grid step), and the factor
    /// averages to 1 (to the f32 rounding of 1/q').
    #[test]
    fn roulette_on_the_grid_survives_with_its_probability() {
        for q in [
            1.5 * F32_GRID,
            3e-9,
            F32_GRID,
            0.3,
            0.95,
            1e-30,
            f32::MIN_POSITIVE,
            0.0,
        ] {
            let qg = survival_on_grid(q);
            let up = qg as f64 - q as f64;
            let least = qg == F32_GRID || up < F32_GRID as f64;
            assert!(qg >= q && qg >= F32_GRID && least, "{q:e}: {qg:e}");
            let (mut survived, mut mean) = (0u64, 0.0f64);
            for j in 0..1u32 << 24 {
                if let Some(f) = roulette(q, grid_f32(j << 8)) {
                    survived += 1;
                    mean += f as f64;
                }
            }
            let n = (1u64 << 24) as f64;
            assert_eq!(survived as f64 / n, qg as f64, "q = {q:e}");
            assert!((mean / n - 1.0).abs() < 1.2e-7, "q = {q:e}: {}", mean / n);
        }
        assert_eq!(survival_on_grid(1.0), 1.0);
        assert_eq!(survival_on_grid(f32::NAN), 1.0);
        assert_eq!(roulette(2.0, 0.999_999_9), Some(1.0));
    }

    /// The two strategies' weights sum to 1 however far apart their pdfs
    /// are: with a² + b² overflowing, both got weight 1.
    #[test]
    fn power_heuristic_weights_sum_to_one_for_huge_pdfs() {
        for (a, b) in [
            (1e30, 1.0),
            (1e20, 1e20),
            (1e19, 3e19),
            (2.0, 1.0),
            (1e-30, 1e-25),
        ] {
            let (wa, wb) = (power_heuristic(a, b), power_heuristic(b, a));
            assert!((wa + wb - 1.0).abs() < 1e-6, "({a:e}, {b:e}): {wa} + {wb}");
        }
        assert_eq!(power_heuristic(1e30, 1.0), 1.0);
        assert!(power_heuristic(1.0, 1e30) < 1e-30);
        assert_eq!(power_heuristic(1e20, 1e20), 0.5);
        assert_eq!(power_heuristic(f32::INFINITY, 1.0), 1.0);
        assert_eq!(power_heuristic(1.0, f32::INFINITY), 0.0);
        assert_eq!(power_heuristic(f32::INFINITY, f32::INFINITY), 0.5);
        assert_eq!(power_heuristic(0.0, 0.0), 0.0);
        assert_eq!(power_heuristic(1.0, 0.0), 1.0);
        assert_eq!(power_heuristic(0.0, 1.0), 0.0);
        assert_eq!(power_heuristic(f32::NAN, 1.0), 0.0);
        assert_eq!(power_heuristic(1.0, f32::NAN), 1.0);
    }

    #[test]
    fn rng_streams_differ_and_repeat() {
        let a: Vec<u32> = (0..4)
            .map(|_| 0)
            .scan(Rng::new(7, 1), |r, _| Some(r.next_u32()))
            .collect();
        let b: Vec<u32> = (0..4)
            .map(|_| 0)
            .scan(Rng::new(7, 1), |r, _| Some(r.next_u32()))
            .collect();
        let c: Vec<u32> = (0..4)
            .map(|_| 0)
            .scan(Rng::new(7, 2), |r, _| Some(r.next_u32()))
            .collect();
        assert_eq!(a, b);
        assert_ne!(a, c);
    }
}
