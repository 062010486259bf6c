//! The plan's measured choice of strategy: once per guided run, the calls
//! of one iteration alternate between the candidates, each into a film of
//! its own with its own render time, and the most efficient one renders the
//! rest of the run. The candidates are
//! - the model's child weights (product or radiance);
//! - its cheaper weights, when it has some (product → radiance weights);
//! - path tracing with NEE and classic roulette, without a guide: what a
//!   fallback renders, measured as it would run (no recording), so the run
//!   drops guiding exactly when guiding loses to what replaces it.
//!
//! Each call renders its passes pixel-major, as the rest of the run does,
//! so each side is timed with the reuse it will have (product guiding's
//! first lobe, `guiding::pixel_reuse`).
//!
//! Every trial pass is an unbiased estimate of the same pixels, so all of
//! them also join the iteration's film: when guiding is kept, a trial costs
//! no samples. When path tracing wins, the image keeps only its passes
//! (`super::train`). (The unguided passes record nothing, so a training
//! iteration that holds the trial trains the guide on 6 of its 8 passes.)
//!
//! Where path tracing leads every guided side by [`EARLY_FALLBACK_LEAD`]
//! after one call each, the trial ends there.
//!
//! Efficiency is 1 / (variance of the film's mean × render seconds); the
//! variance is measured about the pooled mean of every film so far, which
//! stays meaningful at a few spp. The guided sides of a training iteration
//! pay the path loop's recording, not the tree's update (as in the final
//! iteration they will render), so the comparison leans towards guiding.

use super::combine::{efficiency, pooled_mean};
use crate::film::image::Film;

/// What renders a trial call (and, once decided, the rest of the run).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Strategy {
    /// The guide with the model's child weights.
    Model,
    /// The guide with the model's cheaper child weights.
    Cheaper,
    /// Path tracing with NEE, no guide: the fallback.
    Unguided,
}

/// Passes of a whole trial: the check iteration's length.
pub const TRIAL_PASSES: u32 = 8;
/// The unguided side's share of them; the guided sides split the rest.
pub const UNGUIDED_PASSES: u32 = 2;
/// Calls per side, interleaved round robin, so that a drift of the host's
/// speed during the trial reaches every side alike.
const CALLS_PER_SIDE: u32 = 2;
/// Path tracing's lead in efficiency over every guided side that ends the
/// trial after its first round of calls. Where path tracing wins on the
/// pack, it leads by 5.7–8.5× after the whole trial (cornell-box,
/// veach-ajar, staircase) or 2.0–4.1× (veach-mis); where guiding wins
/// (living-room), it is behind. A lead this large does not come from
/// noise: at 1 spp a guided side's variance misses its rare fireflies, which
/// overrates guiding, not path tracing. Stopping early turns the rest of the
/// trial's guided passes, which a fallback leaves out of the image, into
/// path tracing's, which it keeps.
pub const EARLY_FALLBACK_LEAD: f64 = 4.0;

/// How a fallback's plan line ends: its image holds only path tracing's
/// passes, so its spp is not the number of samples the run traced
/// (`experiment::cost` looks for these words).
pub const FALLBACK_IMAGE: &str = "the image holds path tracing's passes alone";

/// How a plan line says that the model's weights lost the trial to the
/// cheaper ones (`experiment::ablation` and `scripts/ratios.py` look for
/// these words).
pub const CHEAPER_WEIGHTS: &str = "weights do not pay here: the rest of the run uses the cheaper";

struct Side {
    strategy: Strategy,
    film: Film,
    seconds: f64,
    calls: u32,
    /// The side's share of the trial, split over its calls.
    passes: u32,
}

/// The outcome of a finished trial.
#[derive(Clone, Debug, PartialEq)]
pub struct Decision {
    /// The strategy for the rest of the run.
    pub strategy: Strategy,
    /// The model's weights against the cheaper ones (empty without them).
    pub weights_note: String,
    /// Non-empty when path tracing won: why guiding was dropped.
    pub fallback_note: String,
}

pub struct StrategyTrial {
    sides: Vec<Side>,
    /// Index of the next call, over all sides round robin.
    next: usize,
}

impl StrategyTrial {
    /// A trial of the model's weights, the cheaper ones when `has_cheaper`,
    /// and path tracing, on `width` × `height` films.
    pub fn new(width: usize, height: usize, has_cheaper: bool) -> Self {
        let mut strategies = vec![Strategy::Model];
        if has_cheaper {
            strategies.push(Strategy::Cheaper);
        }
        let guided_passes = (TRIAL_PASSES - UNGUIDED_PASSES) / strategies.len() as u32;
        strategies.push(Strategy::Unguided);
        let sides = strategies
            .into_iter()
            .map(|strategy| {
                let passes = match strategy {
                    Strategy::Unguided => UNGUIDED_PASSES,
                    _ => guided_passes,
                };
                Side {
                    strategy,
                    film: Film::new(width, height),
                    seconds: 0.0,
                    calls: 0,
                    passes,
                }
            })
            .collect();
        StrategyTrial { sides, next: 0 }
    }

    fn side(&self) -> &Side {
        &self.sides[self.next % self.sides.len()]
    }

    /// The strategy and pass count of the next call.
    pub fn next_call(&self) -> (Strategy, u32) {
        let s = self.side();
        // As even a split as whole passes allow (3 passes: 1, then 2).
        let share = |c: u32| s.passes * c / CALLS_PER_SIDE;
        let n = share(s.calls + 1) - share(s.calls);
        (s.strategy, n.max(1))
    }

    /// Adds the next call's film and render time to its side.
    pub fn record(&mut self, film: &Film, seconds: f64) {
        let i = self.next % self.sides.len();
        let s = &mut self.sides[i];
        s.film.merge(film);
        s.seconds += seconds;
        s.calls += 1;
        self.next += 1;
    }

    pub fn finished(&self) -> bool {
        self.sides.iter().all(|s| s.calls >= CALLS_PER_SIDE)
    }

    /// Each side's efficiency, its variance measured about the pooled mean
    /// of `done` and every side's film (0 when not measurable).
    fn efficiencies(&self, done: &[Film]) -> impl Fn(Strategy) -> f64 + '_ {
        let mut all: Vec<&Film> = done.iter().collect();
        all.extend(self.sides.iter().map(|s| &s.film));
        let mu = pooled_mean(&all);
        move |strategy| {
            let s = self.side_of(strategy).expect("every trial has this side");
            let e = efficiency(&s.film, s.seconds, &mu);
            if e.is_finite() { e } else { 0.0 }
        }
    }

    /// The unguided side's passes so far: after a fallback, the start of
    /// the image (`super::train`).
    pub fn unguided_film(&self) -> &Film {
        &self
            .side_of(Strategy::Unguided)
            .expect("every trial has this side")
            .film
    }

    fn side_of(&self, strategy: Strategy) -> Option<&Side> {
        self.sides.iter().find(|s| s.strategy == strategy)
    }

    /// The most efficient strategy, with the reports, once the trial can
    /// tell: after every call, or after the first round when path tracing
    /// leads every guided side by [`EARLY_FALLBACK_LEAD`]; `None` until
    /// then. `done` are the films of the finished iterations, `model` and
    /// `cheaper` the weights' names.
    pub fn decision(&self, done: &[Film], model: &str, cheaper: Option<&str>) -> Option<Decision> {
        let finished = self.finished();
        if !finished && self.next != self.sides.len() {
            return None;
        }
        let eff = self.efficiencies(done);
        if !finished {
            let unguided = eff(Strategy::Unguided);
            let best_guided = [Strategy::Model, Strategy::Cheaper]
                .into_iter()
                .filter(|&s| self.side_of(s).is_some())
                .map(&eff)
                .fold(0.0, f64::max);
            // Unmeasurable (0) everywhere is no lead.
            if !(unguided > 0.0 && unguided >= EARLY_FALLBACK_LEAD * best_guided) {
                return None;
            }
        }
        let side = |st| self.side_of(st).expect("every trial has this side");
        let model_side = side(Strategy::Model);
        let mut guided = (Strategy::Model, eff(Strategy::Model), model);
        let mut weights_note = String::new();
        if let (Some(c), Some(name)) = (self.side_of(Strategy::Cheaper), cheaper) {
            let (em, ec) = (guided.1, eff(Strategy::Cheaper));
            let cheaper_wins = ec > em;
            weights_note = format!(
                "{model} {} (efficiency {em:.3e}, {name} weights {ec:.3e}, measured on {} + {} spp)",
                if cheaper_wins {
                    CHEAPER_WEIGHTS
                } else {
                    "weights pay here; kept over the cheaper"
                },
                model_side.film.spp,
                c.film.spp,
            );
            if cheaper_wins {
                guided = (Strategy::Cheaper, ec, name);
            }
        }
        let unguided = side(Strategy::Unguided);
        let eu = eff(Strategy::Unguided);
        let pt_wins = eu > guided.1;
        let fallback_note = if pt_wins {
            let early = if finished {
                String::new()
            } else {
                format!(
                    ", after the first round: a lead of {EARLY_FALLBACK_LEAD}× or more ends the trial"
                )
            };
            format!(
                "guiding does not pay here (path tracing with NEE measured efficiency {eu:.3e} on {} spp, guiding with {} weights {:.3e} on {} spp{early}): the rest of the budget is rendered by path tracing with NEE, and {FALLBACK_IMAGE}",
                unguided.film.spp,
                guided.2,
                guided.1,
                side(guided.0).film.spp,
            )
        } else {
            String::new()
        };
        Some(Decision {
            strategy: if pt_wins {
                Strategy::Unguided
            } else {
                guided.0
            },
            weights_note,
            fallback_note,
        })
    }

    /// The report of a trial the budget ended before it finished.
    pub fn unfinished_note(&self, model: &str, cheaper: Option<&str>) -> String {
        let spp: Vec<String> = self
            .sides
            .iter()
            .map(|s| {
                let name = match s.strategy {
                    Strategy::Model => model,
                    Strategy::Cheaper => cheaper.unwrap_or("cheaper"),
                    Strategy::Unguided => "path tracing",
                };
                format!("{} spp {name}", s.film.spp)
            })
            .collect();
        format!(
            "strategy check unfinished: the budget ended after {}",
            spp.join(", ")
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Spectrum;
    use crate::sampling::Rng;

    /// A film of `spp` passes of mean 1 with per-sample standard deviation
    /// `sigma`.
    fn film(spp: u32, sigma: f32, seed: u64) -> Film {
        let (w, h) = (64, 64);
        let mut f = Film::new(w, h);
        let mut rng = Rng::new(seed, 0);
        for _ in 0..spp {
            let pass: Vec<Spectrum> = (0..w * h)
                .map(|_| {
                    let s = if rng.next_f32() < 0.5 { -1.0 } else { 1.0 };
                    Spectrum::splat(1.0 + s * sigma)
                })
                .collect();
            f.add_pass(&pass);
        }
        f
    }

    /// Runs a trial whose sides render with (σ, seconds per pass).
    fn run(has_cheaper: bool, side: impl Fn(Strategy) -> (f32, f64)) -> (StrategyTrial, Decision) {
        let mut t = StrategyTrial::new(64, 64, has_cheaper);
        let mut seed = 1;
        loop {
            if let Some(d) = t.decision(&[], "product", has_cheaper.then_some("radiance")) {
                return (t, d);
            }
            let (strategy, passes) = t.next_call();
            let (sigma, seconds) = side(strategy);
            t.record(&film(passes, sigma, seed), seconds * passes as f64);
            seed += 1;
        }
    }

    #[test]
    fn sides_alternate_and_split_the_trial_passes() {
        let mut t = StrategyTrial::new(8, 8, true);
        let mut order = Vec::new();
        let mut calls = Vec::new();
        while !t.finished() {
            let (s, n) = t.next_call();
            order.push(s);
            calls.push(n);
            t.record(&Film::new(8, 8), 0.0);
        }
        use Strategy::*;
        assert_eq!(order, [Model, Cheaper, Unguided, Model, Cheaper, Unguided]);
        // 8 passes: 2 of path tracing, 3 per guided side as 1 + 2.
        assert_eq!(calls, [1, 1, 1, 2, 2, 1]);
        assert_eq!(calls.iter().sum::<u32>(), TRIAL_PASSES);
        let t = StrategyTrial::new(8, 8, false);
        assert_eq!(t.next_call(), (Model, (TRIAL_PASSES - UNGUIDED_PASSES) / 2));
    }

    #[test]
    fn the_most_efficient_side_wins() {
        // Efficiency ∝ 1/(σ² × seconds): guiding halves the variance at
        // 1.5× the time (efficiency 1.33× path tracing's) and keeps going.
        let (_, d) = run(false, |s| match s {
            Strategy::Unguided => (1.0, 1.0),
            _ => (0.5f32.sqrt(), 1.5),
        });
        assert_eq!(d.strategy, Strategy::Model);
        assert!(d.fallback_note.is_empty() && d.weights_note.is_empty());
        // The same variance at 2.5× the time: path tracing wins.
        let (_, d) = run(false, |s| match s {
            Strategy::Unguided => (1.0, 1.0),
            _ => (0.5f32.sqrt(), 2.5),
        });
        assert_eq!(d.strategy, Strategy::Unguided);
        assert!(
            d.fallback_note.starts_with("guiding does not pay here"),
            "{}",
            d.fallback_note
        );
        // Cheaper weights 10 % more efficient than the model's, both ahead
        // of path tracing: the cheaper weights render the rest.
        let (_, d) = run(true, |s| match s {
            Strategy::Model => (0.9, 1.0),
            Strategy::Cheaper => (0.9, 0.9),
            Strategy::Unguided => (1.0, 1.0),
        });
        assert_eq!(d.strategy, Strategy::Cheaper);
        assert!(d.weights_note.contains("do not pay"), "{}", d.weights_note);
        assert!(d.weights_note.contains("measured on 3 + 3 spp"));
        assert!(d.fallback_note.is_empty());
        // Both weights lose to path tracing: the report names the better.
        let (_, d) = run(true, |s| match s {
            Strategy::Model => (1.0, 1.3),
            Strategy::Cheaper => (1.0, 1.2),
            Strategy::Unguided => (1.0, 1.0),
        });
        assert_eq!(d.strategy, Strategy::Unguided);
        assert!(d.fallback_note.contains("radiance weights"));
        assert!(!d.fallback_note.contains("first round"));
    }

    /// Path tracing 10× as efficient as either guided side: the trial
    /// decides after one call per side. At 3× it makes every call.
    #[test]
    fn a_decisive_lead_ends_the_trial_after_the_first_round() {
        let (t, d) = run(true, |s| match s {
            Strategy::Unguided => (1.0, 1.0),
            _ => (1.0, 10.0),
        });
        assert!(t.sides.iter().all(|s| s.calls == 1), "one round");
        assert!(!t.finished());
        assert_eq!(d.strategy, Strategy::Unguided);
        assert!(d.fallback_note.contains("on 1 spp"), "{}", d.fallback_note);
        assert!(d.fallback_note.contains("after the first round"));
        let (t, d) = run(false, |s| match s {
            Strategy::Unguided => (1.0, 1.0),
            _ => (1.0, 3.0),
        });
        assert!(t.finished() && t.sides.iter().all(|s| s.calls == CALLS_PER_SIDE));
        assert_eq!(d.strategy, Strategy::Unguided);
        assert!(!d.fallback_note.contains("first round"));
    }
}
