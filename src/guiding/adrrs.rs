//! Adjoint-driven Russian roulette (Vorba & Křivánek 2016), without
//! splitting.
//!
//! A path whose expected contribution, throughput × adjoint, is far below
//! the pixel value is not worth its cost. The weight window is centred on
//! C = pixel_estimate / adjoint_estimate, the throughput at which the path's
//! expected contribution equals the pixel value; its lower bound is
//! 2C/(1+s). Below it the path survives with q = throughput/lower and is
//! reweighted by 1/q, so survivors carry `lower`: E[weight] =
//! q · throughput/q = throughput (unbiased). q is rounded up to the grid of
//! the random numbers ([`crate::sampling::roulette`]), where survival has
//! exactly that probability; survivors then carry slightly less than
//! `lower`. Müller's reference code
//! computed the inverse ratio, which is ≥ 1 below the window and so never
//! killed anything.
//!
//! `throughput` is the scalar path throughput including the measurement
//! (pixel filter) weight, in the units the pixel estimate is in. Anything
//! unusable — zero, negative or non-finite estimates or throughput — means
//! no roulette (survival 1), and is counted.

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Adrrs {
    /// Ratio between the window's upper and lower bounds.
    pub s: f32,
}

/// Vorba & Křivánek's window ratio s, which DESIGN §5 prescribes.
pub const PAPER_WINDOW: f32 = 5.0;

/// ADRRS's window ratio s must be a finite number ≥ 1 (the upper bound is
/// s times the lower); otherwise every roulette would be skipped as invalid.
pub fn check_window(s: f32) -> Result<(), String> {
    if s >= 1.0 && s.is_finite() {
        Ok(())
    } else {
        Err(format!(
            "--adrrs-window must be a finite number of at least 1, got {s}"
        ))
    }
}

impl Default for Adrrs {
    fn default() -> Self {
        Adrrs { s: PAPER_WINDOW }
    }
}

/// Per-thread counters; merge them after a pass.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct AdrrsStats {
    /// Calls where the window was below the throughput: survival 1.
    pub above_window: u64,
    /// Calls where roulette was played (survival < 1).
    pub played: u64,
    /// Calls with unusable inputs, no roulette: NaN, Inf or negative
    /// estimates or throughput, a window bound that overflowed (and zero
    /// estimates passed to `survival_probability`, which the path loop
    /// skips as legitimate before, see [`usable_estimates`]).
    pub invalid_estimate: u64,
}

impl AdrrsStats {
    pub fn merge(&mut self, o: &AdrrsStats) {
        self.above_window += o.above_window;
        self.played += o.played;
        self.invalid_estimate += o.invalid_estimate;
    }
}

/// Whether the path loop plays ADRRS with these estimates: both positive
/// and finite. A zero estimate (a dark pixel, no light recorded near the
/// vertex yet) is legitimate and means no roulette; a NaN, Inf or negative
/// one is an error, counted in `invalid_estimate`.
#[inline]
pub fn usable_estimates(
    pixel_estimate: f32,
    adjoint_estimate: f32,
    stats: &mut AdrrsStats,
) -> bool {
    let valid = |x: f32| x.is_finite() && x >= 0.0;
    if !(valid(pixel_estimate) && valid(adjoint_estimate)) {
        stats.invalid_estimate += 1;
        return false;
    }
    pixel_estimate > 0.0 && adjoint_estimate > 0.0
}

impl Adrrs {
    /// Lower bound of the weight window, or `None` if the estimates are
    /// unusable.
    #[inline]
    pub fn lower_bound(&self, pixel_estimate: f32, adjoint_estimate: f32) -> Option<f32> {
        let ok = |x: f32| x.is_finite() && x > 0.0;
        if !(ok(pixel_estimate) && ok(adjoint_estimate) && self.s.is_finite() && self.s >= 1.0) {
            return None;
        }
        let centre = pixel_estimate / adjoint_estimate;
        let lower = 2.0 * centre / (1.0 + self.s);
        ok(lower).then_some(lower)
    }

    /// Probability that the path continues.
    #[inline]
    pub fn survival_probability(
        &self,
        throughput: f32,
        pixel_estimate: f32,
        adjoint_estimate: f32,
        stats: &mut AdrrsStats,
    ) -> f32 {
        let lower = match self.lower_bound(pixel_estimate, adjoint_estimate) {
            Some(l) if throughput.is_finite() && throughput > 0.0 => l,
            _ => {
                stats.invalid_estimate += 1;
                return 1.0;
            }
        };
        if throughput < lower {
            stats.played += 1;
            // > 0 because throughput > 0; < 1 by the branch.
            (throughput / lower).max(f32::MIN_POSITIVE)
        } else {
            stats.above_window += 1;
            1.0
        }
    }

    /// Plays the roulette with the uniform number `u`: `Some(factor)` to
    /// multiply the (RGB) throughput by when the path survives, `None` when
    /// it is terminated.
    #[inline]
    pub fn roulette(
        &self,
        throughput: f32,
        pixel_estimate: f32,
        adjoint_estimate: f32,
        u: f32,
        stats: &mut AdrrsStats,
    ) -> Option<f32> {
        let q = self.survival_probability(throughput, pixel_estimate, adjoint_estimate, stats);
        crate::sampling::roulette(q, u)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn survival_follows_the_window() {
        let rr = Adrrs::default();
        let mut st = AdrrsStats::default();
        // C = 2/0.5 = 4; lower = 8/6.
        let lower = 8.0 / 6.0;
        assert!((rr.lower_bound(2.0, 0.5).unwrap() - lower).abs() < 1e-6);
        let q = rr.survival_probability(0.1, 2.0, 0.5, &mut st);
        assert!((q - 0.1 / lower).abs() < 1e-6, "{q}");
        assert_eq!(rr.survival_probability(2.0, 2.0, 0.5, &mut st), 1.0);
        for (pix, adj) in [
            (0.0, 1.0),
            (1.0, 0.0),
            (f32::NAN, 1.0),
            (1.0, f32::INFINITY),
        ] {
            assert_eq!(rr.survival_probability(0.1, pix, adj, &mut st), 1.0);
        }
        assert_eq!(
            st,
            AdrrsStats {
                above_window: 1,
                played: 1,
                invalid_estimate: 4
            }
        );
    }

    /// A wider window lowers the bound, so it plays less often and with
    /// higher survival; every window keeps the expected weight equal to
    /// the throughput (exact average over a uniform grid of u).
    #[test]
    fn wider_windows_kill_less_and_stay_unbiased() {
        let mut st = AdrrsStats::default();
        let (pixel, adjoint) = (2.0, 0.5);
        let mut last_q = 0.0;
        for s in [1.0, PAPER_WINDOW, 20.0, 100.0] {
            let rr = Adrrs { s };
            let q = rr.survival_probability(0.05, pixel, adjoint, &mut st);
            assert!(q > last_q && q <= 1.0, "s = {s}: q = {q}");
            last_q = q;
            let n = 100_000;
            let mean: f64 = (0..n)
                .map(|i| {
                    let u = (i as f32 + 0.5) / n as f32;
                    rr.roulette(0.05, pixel, adjoint, u, &mut st)
                        .map_or(0.0, |f| 0.05 * f as f64)
                })
                .sum::<f64>()
                / n as f64;
            assert!((mean - 0.05).abs() < 1e-5, "s = {s}: E[weight] = {mean}");
        }
    }

    #[test]
    fn only_non_finite_or_negative_estimates_are_invalid() {
        let mut st = AdrrsStats::default();
        assert!(usable_estimates(2.0, 0.5, &mut st));
        assert!(!usable_estimates(0.0, 0.5, &mut st));
        assert!(!usable_estimates(2.0, 0.0, &mut st));
        assert_eq!(st.invalid_estimate, 0);
        for (pix, adj) in [
            (f32::NAN, 1.0),
            (1.0, f32::NAN),
            (1.0, f32::INFINITY),
            (-1.0, 1.0),
        ] {
            assert!(!usable_estimates(pix, adj, &mut st));
        }
        assert_eq!(st.invalid_estimate, 4);
    }

    /// Over every value `next_f32` can return, the survivors' weights
    /// average to exactly 1 for survival probabilities off the RNG's grid,
    /// down to ADRRS's floor: survival 1/q with P(u < q) rounded to the
    /// grid had E = 4/3 at q = 1.5·2⁻²⁴ and 5e30 at q = f32::MIN_POSITIVE.
    #[test]
    fn roulette_is_exactly_unbiased_over_the_rng_grid() {
        let rr = Adrrs::default();
        let mut st = AdrrsStats::default();
        let (pixel, adjoint) = (2.0, 0.5);
        let lower = rr.lower_bound(pixel, adjoint).unwrap();
        let grid = 1.0 / (1u32 << 24) as f32;
        for q in [1.5 * grid, 3e-9, 0.3, 1e-30, f32::MIN_POSITIVE, 1e-45] {
            let t = q * lower;
            let mut mean = 0.0f64;
            for j in 0..1u32 << 24 {
                let u = crate::sampling::grid_f32(j << 8);
                if let Some(f) = rr.roulette(t, pixel, adjoint, u, &mut st) {
                    mean += f as f64;
                }
            }
            mean /= (1u64 << 24) as f64;
            // To the f32 rounding of the survivors' factor 1/q'.
            assert!((mean - 1.0).abs() < 1.2e-7, "q = {q:e}: E[factor] = {mean}");
        }
    }
}
