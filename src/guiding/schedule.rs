//! The PPG training schedule (Müller et al. 2017 §5.1, with the 2019
//! production notes' refinements), as a pure state machine.
//!
//! Iteration k renders 2^k passes (1 pass = 1 spp over the image), so each
//! iteration has as many samples as all previous ones together and the
//! guide it learns from has twice the data. Before starting iteration k the
//! schedule stops training and renders the final image with everything left
//! when
//! - the remaining budget is less than twice iteration k's (Müller 2017):
//!   iteration k and a final of at least its length would not both fit;
//! - and, with [`TrainingStop::Variance`] only, when the extrapolated
//!   variance of the final image rose (2019): if training stopped after
//!   iteration j, the final image would have variance
//!   E_j = V_j · cost_j / remaining_j (variance falls as 1/budget), so once
//!   E_{k−1} > E_{k−2}, the last iteration's improvement did not pay for the
//!   budget it consumed.
//!
//! The variance rule is off by default. It judges from two early, noisy
//! iterations, and where learning sets in late it stops training before it
//! does: on veach-ajar and veach-mis the variance per sample of the 8- and
//! 16-spp iterations is flat, then falls 3× by 64 spp. It also decided by
//! the seconds of one short iteration, so a run's load flipped it: with the
//! same seed (hence the same variances), radiance guiding on veach-ajar at
//! 240 s trained to 64 spp and ended at MAE 0.23 when its 8-spp iteration
//! took 10.1 s, and stopped at 16 spp and ended at 0.32 when it took 8.8 s.
//! Without the rule, every iteration's image still counts (the
//! inverse-variance combination, `combine.rs`), so training longer costs
//! its recording, not its samples (docs/results-reading.md, session 32).
//!
//! With a time budget the next iteration's cost is extrapolated from the
//! last iteration's seconds per spp.

/// When training ends (`--training-stop`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum TrainingStop {
    /// Once the next iteration would leave less than its own length for
    /// the final one (Müller 2017).
    #[default]
    Budget,
    /// Also once the extrapolated variance of the final image rises
    /// (Müller 2019; DESIGN.md §5).
    Variance,
}

/// Why the schedule ended training.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum TrainingEnd {
    /// The next iteration and a final one of its length would not both fit.
    Budget,
    /// The extrapolated final variance rose ([`TrainingStop::Variance`]).
    VarianceRose,
}

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
    /// Mean over pixels of the variance of the iteration's pixel estimates
    /// (unclamped, so that it does not depend on the sample count; see
    /// `train.rs`).
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
    stop: TrainingStop,
}

impl Schedule {
    pub fn new(budget: Budget) -> Self {
        Schedule {
            budget,
            reports: Vec::new(),
            final_done: false,
            stop: TrainingStop::default(),
        }
    }

    /// A schedule that ends training by `stop`.
    pub fn with_stop(budget: Budget, stop: TrainingStop) -> Self {
        Schedule {
            stop,
            ..Schedule::new(budget)
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
        self.next_with_reason().0
    }

    /// [`next`](Self::next), and why training ends when it returns the
    /// final iteration (`None` otherwise).
    pub fn next_with_reason(&self) -> (Step, Option<TrainingEnd>) {
        let k = self.reports.len();
        let remaining = self.remaining_after(k);
        if self.final_done
            || remaining <= 0.0
            || (matches!(self.budget, Budget::Spp(_)) && remaining < 1.0)
        {
            return (Step::Done, None);
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
            return (finish, Some(TrainingEnd::Budget));
        }
        if self.stop == TrainingStop::Variance && k >= 2 {
            let (a, b) = (
                self.extrapolated_final_variance(k - 2),
                self.extrapolated_final_variance(k - 1),
            );
            if a.is_finite() && b.is_finite() && b > a {
                return (finish, Some(TrainingEnd::VarianceRose));
            }
        }
        (Step::Train { iteration, spp }, None)
    }

    /// Reports the iteration that [`Schedule::next`] asked for.
    pub fn report(&mut self, step: Step, r: IterationReport) {
        if let Step::Final { .. } = step {
            self.final_done = true;
        }
        self.reports.push(r);
    }
}
