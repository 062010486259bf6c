//! The PPG training schedule (Müller et al. 2017 §5.1, with the 2019
//! production notes' refinements), as a pure state machine.
//!
//! Iteration k renders 2^k passes (1 pass = 1 spp over the image), so each
//! iteration has as many samples as all previous ones together and the
//! guide it learns from has twice the data. Before starting iteration k the
//! schedule stops training and renders the final image with everything left
//! when either
//! - the remaining budget is less than twice iteration k's (Müller 2017):
//!   iteration k and a final of at least its length would not both fit, or
//! - the extrapolated variance of the final image rose (2019): if training
//!   stopped after iteration j, the final image would have variance
//!   E_j = V_j · cost_j / remaining_j (variance falls as 1/budget), so once
//!   E_{k−1} > E_{k−2}, the last iteration's improvement did not pay for the
//!   budget it consumed, and neither will the next.
//!
//! With a time budget the next iteration's cost is extrapolated from the
//! last iteration's seconds per spp.

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Budget {
    Spp(u64),
    Seconds(f64),
}

/// What an iteration cost and how noisy its image was.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IterationReport {
    pub spp: u64,
    /// Wall-clock seconds, guide refinement included.
    pub seconds: f64,
    /// Mean over pixels of the (clamped) variance of the iteration's pixel
    /// estimates, see [`mean_clamped_variance`].
    pub mean_variance: f64,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Step {
    /// Render `spp` passes, record, then refine the guide.
    Train { iteration: u32, spp: u64 },
    /// Render with the current guide until `remaining` is used up; no
    /// further learning is needed.
    Final { iteration: u32, remaining: Budget },
    /// The budget is spent.
    Done,
}

#[derive(Clone, Debug)]
pub struct Schedule {
    budget: Budget,
    reports: Vec<IterationReport>,
    final_done: bool,
    /// Apply the 2019 extrapolated-variance rule (on by default).
    pub variance_rule: bool,
}

impl Schedule {
    pub fn new(budget: Budget) -> Self {
        Schedule {
            budget,
            reports: Vec::new(),
            final_done: false,
            variance_rule: true,
        }
    }

    pub fn reports(&self) -> &[IterationReport] {
        &self.reports
    }

    fn cost(&self, r: &IterationReport) -> f64 {
        match self.budget {
            Budget::Spp(_) => r.spp as f64,
            Budget::Seconds(_) => r.seconds,
        }
    }

    fn total(&self) -> f64 {
        match self.budget {
            Budget::Spp(n) => n as f64,
            Budget::Seconds(s) => s,
        }
    }

    /// Budget left after the first `n` iterations.
    fn remaining_after(&self, n: usize) -> f64 {
        self.total() - self.reports[..n].iter().map(|r| self.cost(r)).sum::<f64>()
    }

    /// E_j: variance of a final image rendered with the rest of the budget
    /// after iteration j.
    pub fn extrapolated_final_variance(&self, j: usize) -> f64 {
        let r = &self.reports[j];
        let rem = self.remaining_after(j + 1);
        if rem > 0.0 {
            r.mean_variance * self.cost(r) / rem
        } else {
            f64::INFINITY
        }
    }

    fn remaining_budget(&self, rem: f64) -> Budget {
        match self.budget {
            Budget::Spp(_) => Budget::Spp(rem.max(0.0) as u64),
            Budget::Seconds(_) => Budget::Seconds(rem.max(0.0)),
        }
    }

    /// What to do next.
    pub fn next(&self) -> Step {
        let k = self.reports.len();
        let remaining = self.remaining_after(k);
        if self.final_done
            || remaining <= 0.0
            || (matches!(self.budget, Budget::Spp(_)) && remaining < 1.0)
        {
            return Step::Done;
        }
        let iteration = k as u32;
        let spp = 1u64 << k.min(62);
        let next_cost = match (self.budget, self.reports.last()) {
            (Budget::Spp(_), _) => spp as f64,
            (Budget::Seconds(_), Some(last)) if last.spp > 0 => {
                last.seconds / last.spp as f64 * spp as f64
            }
            // Nothing to extrapolate from yet: the first iteration is 1 spp.
            (Budget::Seconds(_), _) => 0.0,
        };
        let finish = Step::Final {
            iteration,
            remaining: self.remaining_budget(remaining),
        };
        if remaining < 2.0 * next_cost {
            return finish;
        }
        if self.variance_rule && k >= 2 {
            let (a, b) = (
                self.extrapolated_final_variance(k - 2),
                self.extrapolated_final_variance(k - 1),
            );
            if a.is_finite() && b.is_finite() && b > a {
                return finish;
            }
        }
        Step::Train { iteration, spp }
    }

    /// Reports the iteration that [`Schedule::next`] asked for.
    pub fn report(&mut self, step: Step, r: IterationReport) {
        if let Step::Final { .. } = step {
            self.final_done = true;
        }
        self.reports.push(r);
    }
}

/// Mean of per-pixel variances, each clamped to `clamp` so a few fireflies do
/// not decide an image's weight; non-finite entries count as `clamp`.
pub fn mean_clamped_variance(pixel_variances: &[f32], clamp: f32) -> f64 {
    if pixel_variances.is_empty() {
        return 0.0;
    }
    let c = clamp as f64;
    let sum: f64 = pixel_variances
        .iter()
        .map(|&v| {
            let v = v as f64;
            if v.is_finite() { v.clamp(0.0, c) } else { c }
        })
        .sum();
    sum / pixel_variances.len() as f64
}

/// Combines images by inverse variance: I = Σ_i I_i/v_i / Σ_i 1/v_i per pixel
/// and channel. Images with non-finite or negative variance are left out; a
/// zero variance is treated as the smallest positive one (that image then
/// dominates, as it should). Non-finite pixel values are left out of that
/// pixel's sum. Returns `None` if the images differ in size or none is
/// usable.
pub fn combine_inverse_variance(images: &[(&[[f32; 3]], f64)]) -> Option<Vec<[f32; 3]>> {
    let len = images.first()?.0.len();
    if images.iter().any(|(img, _)| img.len() != len) {
        return None;
    }
    let weighted: Vec<(&[[f32; 3]], f64)> = images
        .iter()
        .filter(|(_, v)| v.is_finite() && *v >= 0.0)
        .map(|&(img, v)| (img, 1.0 / v.max(f64::MIN_POSITIVE)))
        .collect();
    if weighted.is_empty() {
        return None;
    }
    // Rescale so the largest weight is 1 and 1/MIN_POSITIVE cannot overflow
    // a sum.
    let wmax = weighted.iter().map(|w| w.1).fold(0.0, f64::max);
    let out = (0..len)
        .map(|p| {
            let mut px = [0f32; 3];
            for (c, out) in px.iter_mut().enumerate() {
                let (mut num, mut den) = (0.0f64, 0.0f64);
                for &(img, w) in &weighted {
                    let x = img[p][c] as f64;
                    if x.is_finite() {
                        let w = w / wmax;
                        num += w * x;
                        den += w;
                    }
                }
                *out = if den > 0.0 { (num / den) as f32 } else { 0.0 };
            }
            px
        })
        .collect();
    Some(out)
}
