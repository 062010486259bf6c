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
//! Path tracing replaces guiding only when it is the more efficient and
//! the run's projected final efficiency is higher with a fallback, which
//! discards the guided passes already rendered ([`Projection`]).
//!
//! Efficiency is 1 / (variance of the film's mean × render seconds), the
//! variance measured about the pooled mean of every film so far, which
//! stays meaningful at a few spp (`super::projection::Mean`). The guided
//! sides of a training iteration pay the path loop's recording, not the
//! tree's update (as in the final iteration they will render), so the
//! comparison leans towards guiding.

use super::projection::{Mean, Measured, Projection};
pub use super::projection::{Rest, RunSoFar};
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

/// How a plan line says that path tracing led the trial but a fallback
/// would have discarded more guided work than the rest of the run recovers.
pub const GUIDING_KEPT: &str = "a fallback would discard more guided work than it saves";

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
    /// Non-empty when path tracing was the more efficient but a fallback
    /// would have ended the run worse ([`GUIDING_KEPT`]).
    pub declined_note: String,
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

    /// The unguided side's passes so far: after a fallback, the start of
    /// the image (`super::train`).
    pub fn unguided_film(&self) -> &Film {
        &self
            .side_of(Strategy::Unguided)
            .expect("every trial has this side")
            .film
    }

    fn side_of(&self, strategy: Strategy) -> Option<&Side> {
        self.index_of(strategy).map(|i| &self.sides[i])
    }

    fn index_of(&self, strategy: Strategy) -> Option<usize> {
        self.sides.iter().position(|s| s.strategy == strategy)
    }

    /// The strategy for the rest of the run, with the reports, once the
    /// trial can tell: after every call, or after the first round when path
    /// tracing leads every guided side by [`EARLY_FALLBACK_LEAD`] and the
    /// fallback's [`Projection`] is the higher; `None` until then. `model`
    /// and `cheaper` are the weights' names.
    ///
    /// The better guided side is the most efficient one. Path tracing
    /// replaces it when it is more efficient still and the run's projected
    /// final efficiency is higher with a fallback than without.
    pub fn decision(&self, run: &RunSoFar, model: &str, cheaper: Option<&str>) -> Option<Decision> {
        let finished = self.finished();
        if !finished && self.next != self.sides.len() {
            return None;
        }
        let mut films: Vec<&Film> = run.films.iter().collect();
        films.extend(self.sides.iter().map(|s| &s.film));
        let mean = Mean::of(&films);
        // Each side's spp, and its noise and cost, measured once.
        let sides: Vec<(u32, Measured)> = self
            .sides
            .iter()
            .map(|s| (s.film.spp, Measured::of(&s.film, s.seconds, &mean)))
            .collect();
        let of = |strategy| sides[self.index_of(strategy).expect("every trial has this side")];
        let eff = |strategy| of(strategy).1.efficiency();
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
        let eu = eff(Strategy::Unguided);
        let projection = Projection::of(run, &mean, &sides, of(guided.0).1, of(Strategy::Unguided));
        let falls_back = eu > guided.1 && !projection.keeps_guiding();
        if !finished {
            // Unmeasurable (0) everywhere is no lead.
            let decisive = eu > 0.0 && eu >= EARLY_FALLBACK_LEAD * guided.1;
            if !(decisive && falls_back) {
                return None;
            }
        }
        let unguided_spp = self.unguided_film().spp;
        let guided_spp = side(guided.0).film.spp;
        let measured = format!(
            "path tracing with NEE measured efficiency {eu:.3e} on {unguided_spp} spp, guiding with {} weights {:.3e} on {guided_spp} spp",
            guided.2, guided.1,
        );
        let projected = format!(
            "the run's projected final efficiency is {:.3e} with a fallback, {:.3e} guided",
            projection.fallback, projection.keep,
        );
        let mut fallback_note = String::new();
        let mut declined_note = String::new();
        if falls_back {
            let early = if finished {
                String::new()
            } else {
                format!(
                    ", after the first round: a lead of {EARLY_FALLBACK_LEAD}× or more ends the trial"
                )
            };
            fallback_note = format!(
                "guiding does not pay here ({measured}{early}; {projected}): the rest of the budget is rendered by path tracing with NEE, and {FALLBACK_IMAGE}"
            );
        } else if eu > guided.1 {
            let discarded: u32 = run.films.iter().map(|f| f.spp).sum::<u32>()
                + self
                    .sides
                    .iter()
                    .filter(|s| s.strategy != Strategy::Unguided)
                    .map(|s| s.film.spp)
                    .sum::<u32>();
            declined_note = format!(
                "guiding kept although path tracing led by {:.2}× ({measured}): {GUIDING_KEPT} ({discarded} guided spp; {projected})",
                eu / guided.1,
            );
        }
        Some(Decision {
            strategy: if falls_back {
                Strategy::Unguided
            } else {
                guided.0
            },
            weights_note,
            fallback_note,
            declined_note,
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
        film_of(spp, seed, |_| (1.0, sigma))
    }

    /// A film of `spp` passes whose pixel i has mean and per-sample
    /// standard deviation `pixel(i)`.
    fn film_of(spp: u32, seed: u64, pixel: impl Fn(usize) -> (f32, f32)) -> Film {
        let (w, h) = (64, 64);
        let mut f = Film::new(w, h);
        let mut rng = Rng::new(seed, 0);
        for _ in 0..spp {
            let pass: Vec<Spectrum> = (0..w * h)
                .map(|i| {
                    let s = if rng.next_f32() < 0.5 { -1.0 } else { 1.0 };
                    let (mean, sigma) = pixel(i);
                    Spectrum::splat(mean + s * sigma)
                })
                .collect();
            f.add_pass(&pass);
        }
        f
    }

    /// Runs a trial whose sides render with (σ, seconds per pass), with
    /// nothing rendered before it and a budget that dwarfs it: a decision
    /// by efficiency alone.
    fn run(has_cheaper: bool, side: impl Fn(Strategy) -> (f32, f64)) -> (StrategyTrial, Decision) {
        run_after(&[], 0.0, Rest::Seconds(1e9), has_cheaper, side)
    }

    /// [`run`] after the finished iterations `done`, which took
    /// `done_seconds`, with `rest` of the budget left after the trial.
    fn run_after(
        done: &[Film],
        done_seconds: f64,
        rest: Rest,
        has_cheaper: bool,
        side: impl Fn(Strategy) -> (f32, f64),
    ) -> (StrategyTrial, Decision) {
        let mut t = StrategyTrial::new(64, 64, has_cheaper);
        let mut seed = 1;
        loop {
            let run = RunSoFar {
                films: done,
                seconds: done_seconds + t.sides.iter().map(|s| s.seconds).sum::<f64>(),
                rest,
            };
            if let Some(d) = t.decision(&run, "product", has_cheaper.then_some("radiance")) {
                return (t, d);
            }
            let (strategy, passes) = t.next_call();
            let (sigma, seconds) = side(strategy);
            t.record(&film(passes, sigma, seed), seconds * passes as f64);
            seed += 1;
        }
    }

    /// Training iterations of 1, 2 and 4 passes with per-sample standard
    /// deviation `sigma`.
    fn training(sigma: f32) -> Vec<Film> {
        [1, 2, 4]
            .into_iter()
            .enumerate()
            .map(|(k, spp)| film(spp, sigma, 1000 + k as u64))
            .collect()
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

    /// Path tracing 1.15× as efficient as guiding (σ 1 at 1 s per pass
    /// against σ 1 at 1.15 s). After 7 guided spp of training and the
    /// trial's 6, a fallback keeps 2 spp of the 15 it has. A short rest
    /// cannot recover the 13 it discards, so guiding is kept and the
    /// report says why; a long one can, so path tracing takes over. The
    /// same under a sample budget.
    #[test]
    fn a_fallback_must_recover_the_guided_work_it_discards() {
        let done = training(1.0);
        let sides = |s| match s {
            Strategy::Unguided => (1.0, 1.0),
            _ => (1.0, 1.15),
        };
        let done_seconds = 7.0 * 1.15;
        for rest in [Rest::Seconds(10.0), Rest::Passes(10)] {
            let (t, d) = run_after(&done, done_seconds, rest, false, sides);
            assert!(t.finished());
            assert_eq!(d.strategy, Strategy::Model, "{rest:?}: {}", d.fallback_note);
            assert!(d.fallback_note.is_empty());
            assert!(
                d.declined_note
                    .starts_with("guiding kept although path tracing led by")
                    && d.declined_note.contains(GUIDING_KEPT)
                    && d.declined_note.contains("(13 guided spp;"),
                "{}",
                d.declined_note
            );
        }
        for rest in [Rest::Seconds(1000.0), Rest::Passes(10_000)] {
            let (_, d) = run_after(&done, done_seconds, rest, false, sides);
            assert_eq!(
                d.strategy,
                Strategy::Unguided,
                "{rest:?}: {}",
                d.declined_note
            );
            assert!(d.declined_note.is_empty());
            assert!(
                d.fallback_note.contains("projected final efficiency"),
                "{}",
                d.fallback_note
            );
        }
        // Guiding more efficient: nothing to decline.
        let (_, d) = run_after(
            &done,
            done_seconds,
            Rest::Seconds(10.0),
            false,
            |s| match s {
                Strategy::Unguided => (1.0, 1.15),
                _ => (1.0, 1.0),
            },
        );
        assert_eq!(d.strategy, Strategy::Model);
        assert!(d.declined_note.is_empty() && d.fallback_note.is_empty());
    }

    /// Training films that measure 100× quieter than the trial's guide are
    /// worth no more per sample than it (the combination's floor): with a
    /// long rest the run still falls back. Unfloored, their 7 spp would
    /// count as 70 000 and keep guiding.
    #[test]
    fn quiet_early_iterations_are_worth_no_more_than_the_trial_guide() {
        let (_, d) = run_after(
            &training(0.01),
            8.0,
            Rest::Seconds(1000.0),
            false,
            |s| match s {
                Strategy::Unguided => (1.0, 1.0),
                _ => (1.0, 1.15),
            },
        );
        assert_eq!(d.strategy, Strategy::Unguided, "{}", d.declined_note);
    }

    /// A 10× lead after the first round ends the trial only when the
    /// fallback also pays for what it discards: with 70 s of guided work
    /// behind it and 5 s left, the trial runs to its end and keeps guiding.
    #[test]
    fn a_decisive_lead_waits_when_the_rest_is_too_short() {
        let (t, d) = run_after(
            &training(1.0),
            70.0,
            Rest::Seconds(5.0),
            false,
            |s| match s {
                Strategy::Unguided => (1.0, 1.0),
                _ => (1.0, 10.0),
            },
        );
        assert!(t.finished());
        assert_eq!(d.strategy, Strategy::Model);
        assert!(
            d.declined_note.contains(GUIDING_KEPT),
            "{}",
            d.declined_note
        );
    }
}
