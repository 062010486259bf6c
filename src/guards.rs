//! Every guard that keeps NaN, Inf or a negative value out of an image, a
//! tree or an optimizer, and the counts a render reports of them. A guard
//! that fires is never silent: its count reaches `--stats-json`, the
//! `guards:` line of `render` and `compare`'s summary.
//!
//! Most counts travel with the path loop's per-thread
//! [`crate::integrator::stats::RenderCounters`] or the guiding statistics.
//! Code that has no counters at hand (the LTC kernels, the quadtree
//! descent, the lobe decomposition, the emitters) records a
//! [`GuardEvent`] in a thread-local count instead. A render runs on a pool
//! whose threads it starts, so draining its workers' counts when it ends
//! ([`drain_pool`]) reports exactly its own events, even when other renders
//! or tests run in the same process.

use serde::Serialize;
use std::cell::Cell;

/// A guard fired in code without per-thread counters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GuardEvent {
    /// A non-finite LTC input or intermediate value was zeroed or replaced.
    LtcNonfinite,
    /// Below the root, a descent's child weights (or their total) were NaN
    /// or Inf; that level took the radiance weights instead.
    DescentWeightsNonfinite,
    /// A lobe weight of the product's lobe decomposition was NaN, Inf or
    /// negative, and was zeroed.
    LobeWeightInvalid,
    /// A finite BSDF value, pdf or sample weight was negative: zeroed, or
    /// the sample rejected.
    BsdfNegative,
    /// A light sample whose shadow-ray origin coincided with the sampled
    /// point (or was not finite) left no direction, and was dropped.
    LightSampleDegenerate,
    /// A quadtree sum or a built cell's radiance passed f32::MAX and was
    /// held there: the tree stays finite, but that cell lost flux.
    TreeSumSaturated,
}

const EVENT_COUNT: usize = 6;

thread_local! {
    static THREAD_COUNTS: [Cell<u64>; EVENT_COUNT] = const { [const { Cell::new(0) }; EVENT_COUNT] };
}

/// Adds `n` to this thread's count of `event`. Kept out of line: guards sit
/// on hot paths and fire rarely.
#[cold]
#[inline(never)]
pub fn record(event: GuardEvent, n: u64) {
    THREAD_COUNTS.with(|c| {
        let slot = &c[event as usize];
        slot.set(slot.get().saturating_add(n));
    });
}

/// This thread's count of `event` so far (for tests that call the guarded
/// code directly on their own thread).
pub fn thread_count(event: GuardEvent) -> u64 {
    THREAD_COUNTS.with(|c| c[event as usize].get())
}

/// This thread's counts, reset to zero.
fn take_thread_counts() -> [u64; EVENT_COUNT] {
    THREAD_COUNTS.with(|c| std::array::from_fn(|i| c[i].take()))
}

/// Every event count of a pool's workers, summed and reset to zero.
pub fn drain_pool(pool: &rayon::ThreadPool) -> EventCounts {
    let mut sum = [0u64; EVENT_COUNT];
    for counts in pool.broadcast(|_| take_thread_counts()) {
        for (s, c) in sum.iter_mut().zip(counts) {
            *s = s.saturating_add(c);
        }
    }
    EventCounts(sum)
}

/// Summed counts of each [`GuardEvent`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EventCounts([u64; EVENT_COUNT]);

impl EventCounts {
    pub fn get(&self, event: GuardEvent) -> u64 {
        self.0[event as usize]
    }
}

#[derive(Clone, Copy, Debug, Default, Serialize, PartialEq, Eq)]
pub struct Guards {
    /// Path contributions that were NaN/Inf/negative (replaced by zero).
    pub image_nonfinite_samples: u64,
    /// BSDF or guide samples with unusable pdf or weight (path ended).
    pub invalid_scattering: u64,
    /// NaN/Inf BSDF values, pdfs or sampled directions (zeroed or rejected).
    pub bsdf_nonfinite: u64,
    /// Negative BSDF values, pdfs or sample weights (zeroed or rejected).
    pub bsdf_negative: u64,
    /// NaN/Inf/negative weights of the product's lobe decomposition (zeroed).
    pub lobe_weights_invalid: u64,
    /// Guide vertices dropped for NaN/Inf weights at the root.
    pub guide_root_nonfinite: u64,
    /// Descent levels below the root whose weights were NaN/Inf (radiance
    /// weights used at that level).
    pub descent_weights_nonfinite: u64,
    /// Learning records rejected before they could reach the SD-tree.
    pub tree_records_non_finite: u64,
    pub tree_records_negative: u64,
    pub tree_records_zero_pdf: u64,
    /// Adam steps rejected (non-finite gradient, vanishing mixture pdf).
    pub optimizer_rejected: u64,
    /// ADRRS decisions whose estimates were NaN, Inf or negative (no
    /// roulette played).
    pub adrrs_invalid_estimate: u64,
    /// Non-finite LTC inputs or outputs zeroed.
    pub ltc_nonfinite: u64,
    /// Light samples dropped: no direction from the shadow-ray origin.
    pub light_samples_degenerate: u64,
    /// Guided iterations left out of the image: their variance was not finite.
    pub iterations_dropped_nonfinite_variance: u64,
    /// Quadtree sums or built radiances held at f32::MAX (flux lost there).
    pub tree_sums_saturated: u64,
}

impl Guards {
    /// Every counter with its name as --stats-json spells it (the one list
    /// `total` and `describe` read, so neither can miss a counter).
    pub fn entries(&self) -> [(&'static str, u64); 16] {
        [
            ("image_nonfinite_samples", self.image_nonfinite_samples),
            ("invalid_scattering", self.invalid_scattering),
            ("bsdf_nonfinite", self.bsdf_nonfinite),
            ("bsdf_negative", self.bsdf_negative),
            ("lobe_weights_invalid", self.lobe_weights_invalid),
            ("guide_root_nonfinite", self.guide_root_nonfinite),
            ("descent_weights_nonfinite", self.descent_weights_nonfinite),
            ("tree_records_non_finite", self.tree_records_non_finite),
            ("tree_records_negative", self.tree_records_negative),
            ("tree_records_zero_pdf", self.tree_records_zero_pdf),
            ("optimizer_rejected", self.optimizer_rejected),
            ("adrrs_invalid_estimate", self.adrrs_invalid_estimate),
            ("ltc_nonfinite", self.ltc_nonfinite),
            ("light_samples_degenerate", self.light_samples_degenerate),
            (
                "iterations_dropped_nonfinite_variance",
                self.iterations_dropped_nonfinite_variance,
            ),
            ("tree_sums_saturated", self.tree_sums_saturated),
        ]
    }

    /// Fills the counters that come from [`GuardEvent`]s.
    pub fn with_events(self, events: &EventCounts) -> Guards {
        Guards {
            bsdf_negative: events.get(GuardEvent::BsdfNegative),
            lobe_weights_invalid: events.get(GuardEvent::LobeWeightInvalid),
            descent_weights_nonfinite: events.get(GuardEvent::DescentWeightsNonfinite),
            ltc_nonfinite: events.get(GuardEvent::LtcNonfinite),
            light_samples_degenerate: events.get(GuardEvent::LightSampleDegenerate),
            tree_sums_saturated: events.get(GuardEvent::TreeSumSaturated),
            ..self
        }
    }

    pub fn total(&self) -> u64 {
        self.entries().iter().map(|e| e.1).sum()
    }

    /// The counters that fired, by name: `name N, name N`; empty if none.
    pub fn describe(&self) -> String {
        let fired: Vec<String> = self
            .entries()
            .iter()
            .filter(|e| e.1 > 0)
            .map(|(name, n)| format!("{name} {n}"))
            .collect();
        fired.join(", ")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `entries` lists every serialised counter once, in order, so that
    /// `total` and `describe` see every guard a new field adds.
    #[test]
    fn guards_entries_cover_every_counter() {
        let json = serde_json::to_value(Guards::default()).unwrap();
        let keys: Vec<&str> = json
            .as_object()
            .unwrap()
            .keys()
            .map(|k| k.as_str())
            .collect();
        let mut names: Vec<&str> = Guards::default().entries().iter().map(|e| e.0).collect();
        names.sort_unstable();
        let mut sorted = keys.clone();
        sorted.sort_unstable();
        assert_eq!(names, sorted);
        let g = Guards {
            bsdf_nonfinite: 2,
            iterations_dropped_nonfinite_variance: 1,
            ..Guards::default()
        };
        assert_eq!(g.total(), 3);
        assert_eq!(
            g.describe(),
            "bsdf_nonfinite 2, iterations_dropped_nonfinite_variance 1"
        );
        assert_eq!(Guards::default().describe(), "");
    }

    /// Each event lands in its own counter, and a pool's counts are its
    /// workers' alone: the test thread's own count is neither drained nor
    /// reported by the pool.
    #[test]
    fn events_reach_their_counters_and_pools_report_only_their_workers() {
        let events = [
            GuardEvent::LtcNonfinite,
            GuardEvent::DescentWeightsNonfinite,
            GuardEvent::LobeWeightInvalid,
            GuardEvent::BsdfNegative,
            GuardEvent::LightSampleDegenerate,
            GuardEvent::TreeSumSaturated,
        ];
        let own_before = thread_count(GuardEvent::BsdfNegative);
        record(GuardEvent::BsdfNegative, 7);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        assert_eq!(drain_pool(&pool), EventCounts::default());
        pool.broadcast(|ctx| {
            for (i, &e) in events.iter().enumerate() {
                record(e, (i as u64 + 1) * (ctx.index() as u64 + 1));
            }
        });
        let drained = drain_pool(&pool);
        let guards = Guards::default().with_events(&drained);
        // Workers 0 and 1 recorded (i + 1)·1 and (i + 1)·2.
        for (i, &e) in events.iter().enumerate() {
            assert_eq!(drained.get(e), 3 * (i as u64 + 1), "{e:?}");
        }
        assert_eq!(guards.total(), 3 * (1 + 2 + 3 + 4 + 5 + 6));
        assert_eq!(guards.tree_sums_saturated, 18);
        assert_eq!(guards.ltc_nonfinite, 3);
        assert_eq!(guards.light_samples_degenerate, 15);
        assert_eq!(drain_pool(&pool), EventCounts::default());
        assert_eq!(thread_count(GuardEvent::BsdfNegative), own_before + 7);
    }
}
