//! The learned BSDF fraction, adjoint-driven Russian roulette and the
//! training schedule.

use ltcguide::film::image::Film;
use ltcguide::guiding::adam::{AdamConfig, AdamStats, BsdfFraction, NonFiniteGradient};
use ltcguide::guiding::adrrs::{Adrrs, AdrrsStats};
use ltcguide::guiding::combine::combine;
use ltcguide::guiding::schedule::{
    Budget, IterationReport, Schedule, Step, TrainingEnd, TrainingStop,
};
use ltcguide::math::Spectrum;
use ltcguide::sampling::Rng;

/// 1D problem on [0,1]: p_bsdf = 2x, p_guide = 2(1−x), integrand
/// F = a·p_bsdf + (1−a)·p_guide. The mixture equals F exactly at α = a, so
/// KL is minimised there. Returns α averaged over the last quarter.
fn learn_alpha(
    a: f32,
    cfg: &AdamConfig,
    steps: usize,
    seed: u64,
) -> (f32, BsdfFraction, AdamStats) {
    learn_alpha_scaled(a, 1.0, cfg, steps, seed)
}

/// As [`learn_alpha`] with the integrand in other units (F·scale).
fn learn_alpha_scaled(
    a: f32,
    scale: f32,
    cfg: &AdamConfig,
    steps: usize,
    seed: u64,
) -> (f32, BsdfFraction, AdamStats) {
    let mut frac = BsdfFraction::default();
    let mut stats = AdamStats::default();
    let mut rng = Rng::new(seed, 0);
    let mut acc = 0.0f64;
    for i in 0..steps {
        let alpha = frac.alpha(cfg);
        let u = rng.next_f32();
        let x = if rng.next_f32() < alpha {
            u.sqrt()
        } else {
            1.0 - u.sqrt()
        };
        let (pb, pg) = (2.0 * x, 2.0 * (1.0 - x));
        let p_mix = alpha * pb + (1.0 - alpha) * pg;
        let f = scale * (a * pb + (1.0 - a) * pg);
        let _ = frac.step_sample(cfg, f / p_mix, pb, pg, alpha, &mut stats);
        if i >= steps * 3 / 4 {
            acc += alpha as f64;
        }
    }
    ((acc / (steps / 4) as f64) as f32, frac, stats)
}

#[test]
fn adam_converges_to_the_known_optimal_fraction() {
    let no_reg = AdamConfig {
        l2: 0.0,
        ..Default::default()
    };
    for (a, seed) in [(0.3f32, 1u64), (0.8, 2)] {
        let (alpha, _, stats) = learn_alpha(a, &no_reg, 60_000, seed);
        assert!((alpha - a).abs() < 0.03, "a = {a}: learnt {alpha}");
        assert_eq!(stats.rejected_non_finite, 0);
        // The default L2 term (pulling θ to 0, α to ½) shifts the optimum a
        // little towards ½, but not far.
        let (alpha, _, _) = learn_alpha(a, &AdamConfig::default(), 60_000, seed);
        assert!(
            (alpha - a).abs() < 0.06 && (alpha - a) * (0.5 - a) >= -0.01,
            "a = {a}: learnt {alpha} with L2"
        );
    }
    // Optimum at α = 0: θ heads down, the α used stays at α_min for
    // coverage. KL is flat at α = 0 (its α-derivative vanishes there), so
    // with the L2 pull θ settles around −2 (α ≈ 0.1) instead of diving.
    let (alpha, frac, _) = learn_alpha(0.0, &no_reg, 60_000, 3);
    assert!(frac.theta() < -3.5, "θ = {}", frac.theta());
    assert_eq!(alpha, no_reg.alpha_min);
    let (alpha, _, _) = learn_alpha(0.0, &AdamConfig::default(), 60_000, 3);
    assert!(alpha < 0.15, "{alpha}");
}

#[test]
fn normalised_gradient_makes_learning_independent_of_radiance_units() {
    let cfg = AdamConfig::default();
    let raw = AdamConfig {
        normalize_gradient: false,
        ..cfg
    };
    for scale in [1e-3f32, 1.0, 1e3] {
        let (alpha, _, _) = learn_alpha_scaled(0.15, scale, &cfg, 60_000, 4);
        assert!((alpha - 0.15).abs() < 0.06, "scale {scale}: {alpha}");
    }
    // Without it, a dim integrand lets the L2 term pin α near ½.
    let (alpha, _, _) = learn_alpha_scaled(0.15, 1e-3, &raw, 60_000, 4);
    assert!(alpha > 0.4, "raw gradient at scale 1e-3: {alpha}");
}

#[test]
fn adam_rejects_and_counts_degenerate_gradients() {
    let cfg = AdamConfig::default();
    let mut frac = BsdfFraction::default();
    let mut stats = AdamStats::default();
    // p_mix = 0: the one-sample gradient is 0/0.
    assert_eq!(
        frac.step_sample(&cfg, 1.0, 0.0, 0.0, 0.5, &mut stats),
        Err(NonFiniteGradient)
    );
    // α = 0 with p_guide = 0: p_mix = 0 although p_bsdf > 0.
    assert_eq!(
        frac.step_sample(&cfg, 1.0, 3.0, 0.0, 0.0, &mut stats),
        Err(NonFiniteGradient)
    );
    assert_eq!(
        frac.step_sample(&cfg, f32::NAN, 1.0, 1.0, 0.5, &mut stats),
        Err(NonFiniteGradient)
    );
    assert_eq!(
        frac.step_sample(&cfg, 1.0, f32::INFINITY, 1.0, 0.5, &mut stats),
        Err(NonFiniteGradient)
    );
    assert_eq!(stats.rejected_non_finite, 4);
    assert_eq!(stats.steps, 0);
    assert_eq!(frac, BsdfFraction::default());
    // p_mix → 0 but positive, with the largest finite product: huge yet
    // finite gradient; θ moves by at most ~lr and stays finite.
    for _ in 0..100 {
        frac.step_sample(&cfg, f32::MAX, 1e-38, 1e-45, 0.5, &mut stats)
            .unwrap();
    }
    assert_eq!(stats.steps, 100);
    assert!(
        frac.theta().is_finite() && frac.theta() > 0.0 && frac.theta() <= 1.01,
        "{}",
        frac.theta()
    );
}

#[test]
fn adrrs_survival_formula() {
    let rr = Adrrs::default();
    let mut st = AdrrsStats::default();
    // C = I/adjoint = 0.2/0.05 = 4, lower = 2C/(1+s) = 8/6.
    let lower = 8.0f32 / 6.0;
    for t in [0.01f32, 0.5, 1.0, 1.3] {
        let q = rr.survival_probability(t, 0.2, 0.05, &mut st);
        assert!((q - t / lower).abs() < 1e-6, "t = {t}: q = {q}");
        assert!(q < 1.0, "below the window the path must be at risk");
    }
    assert_eq!(rr.survival_probability(1.4, 0.2, 0.05, &mut st), 1.0);
    assert_eq!(rr.survival_probability(100.0, 0.2, 0.05, &mut st), 1.0);
    // A brighter adjoint means more expected contribution per unit
    // throughput: C drops, and the same path survives more often.
    let q_dim = rr.survival_probability(0.1, 0.2, 0.05, &mut st);
    let q_bright = rr.survival_probability(0.1, 0.2, 0.5, &mut st);
    assert!(q_bright > q_dim);
    assert_eq!(st.invalid_estimate, 0);
}

#[test]
fn adrrs_is_unbiased_including_degenerate_estimates() {
    let rr = Adrrs::default();
    let mut rng = Rng::new(17, 0);
    let cases = [
        (0.05f32, 0.2f32, 0.05f32),
        (0.5, 1.0, 0.1),
        (0.001, 3.0, 2.0),
        (2.0, 0.2, 0.05),
        (0.05, 0.0, 0.05),
        (0.05, 0.2, 0.0),
        (0.05, f32::NAN, 0.05),
        (0.05, 0.2, f32::INFINITY),
    ];
    let n = 400_000;
    for &(t, pix, adj) in &cases {
        let mut st = AdrrsStats::default();
        let q = rr.survival_probability(t, pix, adj, &mut AdrrsStats::default()) as f64;
        let (mut sum, mut survivors) = (0.0f64, 0usize);
        for _ in 0..n {
            if let Some(f) = rr.roulette(t, pix, adj, rng.next_f32(), &mut st) {
                sum += (t * f) as f64;
                survivors += 1;
            }
        }
        let mean = sum / n as f64;
        // Var of the reweighted estimate: t²(1/q − 1).
        let sigma = (t as f64) * ((1.0 / q - 1.0).max(0.0) / n as f64).sqrt();
        assert!(
            (mean - t as f64).abs() <= 5.0 * sigma + 1e-6 * t as f64,
            "case {t} {pix} {adj}: {mean} vs {t}, σ {sigma}"
        );
        assert!(((survivors as f64 / n as f64) - q).abs() < 0.01);
        if !(pix > 0.0 && adj > 0.0 && pix.is_finite() && adj.is_finite()) {
            assert_eq!(q, 1.0);
            assert_eq!(st.invalid_estimate, n as u64);
        }
    }
}

fn report(spp: u64, variance_per_spp: f64) -> IterationReport {
    IterationReport {
        spp,
        seconds: spp as f64 * 0.5,
        mean_variance: variance_per_spp / spp as f64,
    }
}

/// Runs the schedule with a model of how the per-sample variance evolves
/// with the iteration index; returns every step taken.
fn run(mut s: Schedule, variance: impl Fn(u32) -> f64) -> Vec<Step> {
    let mut steps = vec![];
    loop {
        let step = s.next();
        steps.push(step);
        let (it, spp) = match step {
            Step::Train { iteration, spp } => (iteration, spp),
            Step::Final {
                iteration,
                remaining: Budget::Spp(n),
            } => (iteration, n),
            Step::Final {
                iteration,
                remaining: Budget::Seconds(t),
            } => (iteration, (t / 0.5).round() as u64),
            Step::Done => return steps,
        };
        s.report(step, report(spp, variance(it)));
    }
}

#[test]
fn schedule_doubles_and_stops_when_the_rest_is_less_than_twice_the_next() {
    // Variance improving fast enough that only the budget rule applies.
    let learning = |k: u32| 0.5f64.powi(k as i32);
    let steps = run(Schedule::new(Budget::Spp(64)), learning);
    let train: Vec<u64> = steps
        .iter()
        .filter_map(|s| match s {
            Step::Train { spp, .. } => Some(*spp),
            _ => None,
        })
        .collect();
    assert_eq!(train, vec![1, 2, 4, 8, 16]);
    // 31 spp used; 33 left < 2·32 → final with all 33.
    assert_eq!(
        steps[5],
        Step::Final {
            iteration: 5,
            remaining: Budget::Spp(33)
        }
    );
    assert_eq!(steps[6], Step::Done);
    assert_eq!(steps.len(), 7);
    // The same in seconds (0.5 s per spp): 32 s.
    let steps = run(Schedule::new(Budget::Seconds(32.0)), learning);
    assert_eq!(steps.len(), 7);
    assert_eq!(
        steps[5],
        Step::Final {
            iteration: 5,
            remaining: Budget::Seconds(16.5)
        }
    );
}

#[test]
fn schedule_stops_when_extrapolated_variance_rises() {
    let variance_rule = |budget| Schedule::with_stop(budget, TrainingStop::Variance);
    // No learning gain at all: per-sample variance is constant, so after
    // iteration j the final image would have variance V/remaining_j, which
    // grows as the budget is spent: stop as soon as two points exist.
    let steps = run(variance_rule(Budget::Spp(1024)), |_| 1.0);
    assert_eq!(
        steps[0],
        Step::Train {
            iteration: 0,
            spp: 1
        }
    );
    assert_eq!(
        steps[1],
        Step::Train {
            iteration: 1,
            spp: 2
        }
    );
    assert_eq!(
        steps[2],
        Step::Final {
            iteration: 2,
            remaining: Budget::Spp(1021)
        }
    );
    // Strong learning over 3 iterations, then none: training stops after
    // the first iteration that brought nothing.
    let v = |k: u32| if k <= 3 { 0.1f64.powi(k as i32) } else { 1e-3 };
    let steps = run(variance_rule(Budget::Spp(4096)), v);
    let last_train = steps
        .iter()
        .filter_map(|s| match s {
            Step::Train { iteration, .. } => Some(*iteration),
            _ => None,
        })
        .max();
    assert_eq!(last_train, Some(4));
    // With the rule off, the default, the budget rule alone decides.
    let steps = run(Schedule::new(Budget::Spp(1024)), |_| 1.0);
    assert_eq!(steps.len(), 11); // 9 training iterations (511 spp), final 513, done
    let steps = run(
        Schedule::with_stop(Budget::Spp(1024), TrainingStop::Budget),
        |_| 1.0,
    );
    assert_eq!(steps.len(), 11);
}

/// Learning that sets in late, as on veach-ajar and veach-mis: the
/// per-sample variance stays flat over iterations 2–4, then falls 3× per
/// iteration. The variance rule reads the plateau as the end of learning
/// and stops after the 8-spp iteration; the default trains until the
/// budget rule, and says which rule ended training.
#[test]
fn a_late_learner_trains_to_the_budget_rule_by_default() {
    // Below 4 spp the renderer reports no variance (the rule waits).
    let late = |k: u32| match k {
        0 | 1 => f64::INFINITY,
        2..=4 => 500.0,
        _ => 500.0 / 3f64.powi(k as i32 - 4),
    };
    let last_trained = |steps: &[Step]| {
        steps
            .iter()
            .filter_map(|s| match s {
                Step::Train { iteration, .. } => Some(*iteration),
                _ => None,
            })
            .max()
    };
    let with_variance = run(
        Schedule::with_stop(Budget::Spp(256), TrainingStop::Variance),
        late,
    );
    // E_3 = 500/241 > E_2 = 500/249: stop after the 8-spp iteration, as
    // radiance guiding did on veach-ajar at 120 s (seed 2).
    assert_eq!(last_trained(&with_variance), Some(3), "{with_variance:?}");
    // By default: iterations 0–6 (127 spp), then 129 left < 2·128 → final.
    let default = run(Schedule::new(Budget::Spp(256)), late);
    assert_eq!(last_trained(&default), Some(6), "{default:?}");
    // The reason comes with the final step, and only with it.
    let mut s = Schedule::new(Budget::Spp(256));
    let mut reasons = vec![];
    loop {
        let (step, why) = s.next_with_reason();
        let spp = match step {
            Step::Train { spp, .. } => spp,
            Step::Final {
                remaining: Budget::Spp(n),
                ..
            } => n,
            Step::Final { .. } => unreachable!("a sample budget"),
            Step::Done => break,
        };
        reasons.push(why);
        s.report(step, report(spp, late(reasons.len() as u32 - 1)));
    }
    assert_eq!(reasons.len(), 8);
    assert!(reasons[..7].iter().all(Option::is_none), "{reasons:?}");
    assert_eq!(reasons[7], Some(TrainingEnd::Budget));
    let mut s = Schedule::with_stop(Budget::Spp(256), TrainingStop::Variance);
    for k in 0..4u32 {
        let step = s.next();
        assert!(matches!(step, Step::Train { .. }), "{step:?}");
        s.report(step, report(1 << k, late(k)));
    }
    assert_eq!(s.next_with_reason().1, Some(TrainingEnd::VarianceRose));
}

/// The renderer's combination (`combine::combine`) on two-pixel films whose
/// pixels hold the same samples (so both checkerboard colours measure the
/// same weights): A = {2, 4}, B = {1, 7, 3, 7}. Pooled mean 4; spreads
/// about it: A gives (2² + 0²)/2 = 2, B gives (3² + 3² + 1² + 3²)/4 = 7.
/// B has the most samples, so A's per-sample variance is floored at 7:
/// variances of the means 7/2 and 7/4, weights normalised 1/3 and 2/3.
/// Image (1/3)·3 + (2/3)·4.5 = 4 (without the floor, A's 2 would give
/// weights 7/11 and 4/11 and 3.55); variance, from the measured spreads,
/// (1/3)²·2/2 + (2/3)²·7/4 = 8/9.
#[test]
fn inverse_variance_combination_matches_hand_computation() {
    let film = |samples: &[f32]| {
        let mut f = Film::new(2, 1);
        for &x in samples {
            f.add_pass(&[Spectrum::splat(x); 2]);
        }
        f
    };
    let (a, b, empty) = (
        film(&[2.0, 4.0]),
        film(&[1.0, 7.0, 3.0, 7.0]),
        Film::new(2, 1),
    );
    let (image, variance, weights) = combine(&[&a, &b, &empty]).unwrap();
    let close = |x: f64, y: f64| (x - y).abs() < 1e-5 * y.abs().max(1.0);
    for p in 0..2 {
        for c in 0..3 {
            assert!(close(image.pixels[p][c] as f64, 4.0), "{:?}", image.pixels);
        }
        assert!(close(variance[p], 8.0 / 9.0), "{variance:?}");
    }
    // The film without samples takes no part.
    assert_eq!(weights.len(), 2);
    assert!(
        close(weights[0], 1.0 / 3.0) && close(weights[1], 2.0 / 3.0),
        "{weights:?}"
    );
    assert!(combine(&[&empty]).is_none());
}

/// The own glossy-gap scene and radiance guiding at 16 spp without NEE:
/// the setting of the tests of the fraction's options.
fn gap_radiance_at_16_spp() -> (ltcguide::scene::Scene, ltcguide::render::RenderOptions) {
    use ltcguide::integrator::path::{PathSettings, RouletteMode};
    use ltcguide::render::{Budget, Method, RenderOptions};
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/glossy-gap/scene.xml");
    let opts = RenderOptions {
        method: Method::Radiance,
        budget: Budget::Spp(16),
        seed: 7,
        threads: 2,
        path: PathSettings {
            nee: false,
            max_depth: Some(6),
            roulette: RouletteMode::Adrrs,
            adrrs_window: ltcguide::guiding::adrrs::PAPER_WINDOW,
            defer_guide_pdf: true,
        },
        use_plan: false,
        ..Default::default()
    };
    (ltcguide::scene::load_scene(&path).unwrap(), opts)
}

/// `RenderOptions::bsdf_fraction_learning` reaches the leaves: with the
/// grid every trained leaf's α is a grid fraction, not all the one it
/// started from, and the stats name the learning; a fixed fraction refuses
/// it, since nothing would be learned.
#[test]
fn the_grid_learning_reaches_every_leaf_and_the_stats() {
    use ltcguide::guiding::adam::{FRACTION_GRID, FractionLearning};
    use ltcguide::render::{RenderOptions, render};
    let (scene, opts) = gap_radiance_at_16_spp();
    let opts = RenderOptions {
        bsdf_fraction_learning: FractionLearning::VarianceGrid,
        ..opts
    };
    let r = render(&scene, &opts).unwrap();
    let stats = r.stats.guiding.as_ref().unwrap();
    assert_eq!(stats.bsdf_fraction_learning, FractionLearning::VarianceGrid);
    let tree = r.tree.unwrap();
    let chosen: Vec<f32> = (0..tree.leaves().len() as u32)
        .filter(|&i| tree.leaf(i).fraction.steps() >= 64)
        .map(|i| tree.bsdf_fraction(i))
        .collect();
    assert!(chosen.len() >= 4, "{} trained leaves", chosen.len());
    assert!(
        chosen.iter().all(|a| FRACTION_GRID.contains(a)),
        "{chosen:?}"
    );
    assert!(chosen.iter().any(|&a| a != 0.5), "{chosen:?}");
    let fixed = RenderOptions {
        bsdf_fraction: Some(0.3),
        ..opts
    };
    let err = render(&scene, &fixed)
        .err()
        .expect("a fixed fraction refuses the grid");
    assert!(err.contains("--bsdf-fraction-learning"), "{err}");
}

/// `RenderOptions::bsdf_fraction_l2` reaches the leaves' Adam states: a
/// huge λ holds every trained leaf's α at ½, while without the pull the
/// same render's leaves move away from it. The stats report the λ used.
#[test]
fn the_l2_option_reaches_every_leaf_and_the_stats() {
    use ltcguide::render::{RenderOptions, render};
    let (scene, opts) = gap_radiance_at_16_spp();
    let run = |l2: f64| {
        let opts = RenderOptions {
            bsdf_fraction_l2: Some(l2),
            ..opts.clone()
        };
        let r = render(&scene, &opts).unwrap();
        assert_eq!(r.stats.guiding.as_ref().unwrap().adam_l2, l2);
        let tree = r.tree.unwrap();
        let trained: Vec<f32> = (0..tree.leaves().len() as u32)
            .filter(|&i| tree.leaf(i).fraction.steps() > 100)
            .map(|i| tree.bsdf_fraction(i))
            .collect();
        assert!(trained.len() >= 4, "{} trained leaves", trained.len());
        trained
            .iter()
            .map(|a| (a - 0.5).abs())
            .fold(0.0f32, f32::max)
    };
    let held = run(1e4);
    assert!(held < 0.03, "λ = 1e4: max |α − ½| = {held}");
    let free = run(0.0);
    assert!(free > 0.1, "λ = 0: max |α − ½| = {free}");
}
