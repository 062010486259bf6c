//! `compare` on a tiny scene with a tiny budget writes well-formed files,
//! and refuses a reference of the wrong size.

mod common;

use common::study::{compare_options, flat_reference, settings, tiny};
use ltcguide::experiment::compare::{CompareOptions, run_compare};
use ltcguide::experiment::cost::{COST_CSV, COST_HEADING, parse_cost_csv};
use ltcguide::experiment::curves::{CSV_HEADER, parse_csv};
use ltcguide::film::exr_io::write_rgb;
use ltcguide::film::image::Image;
use ltcguide::guiding::trial::FALLBACK_IMAGE;
use ltcguide::integrator::path::{PathSettings, RouletteMode};
use ltcguide::render::{Budget, Method, RenderOptions, TimeBase, render};
use ltcguide::scene::Scene;
use std::path::Path;

#[test]
fn compare_writes_well_formed_csv_svg_and_summary() {
    let scene = tiny();
    let reference = render(
        &scene,
        &RenderOptions {
            method: Method::Pt,
            budget: Budget::Spp(256),
            seed: 77,
            path: settings(&scene, Method::Pt),
            ..Default::default()
        },
    )
    .unwrap()
    .image;
    let dir = std::env::temp_dir().join(format!("ltcguide-compare-{}", std::process::id()));
    let methods = vec![Method::Pt, Method::Radiance, Method::Product];
    let opts = CompareOptions {
        seconds: 0.6,
        time_base: TimeBase::Wall,
        runs: 2,
        first_run: 0,
        guided_roulette: Some((RouletteMode::Off, 5.0)),
        use_plan: false,
        ..compare_options(methods.clone(), &dir)
    };
    let outcome = run_compare(&scene, &reference, &opts).unwrap();
    assert!(
        outcome.summary.contains("Per-scene plan: off"),
        "{}",
        outcome.summary
    );
    let csv = std::fs::read_to_string(dir.join("curves.csv")).unwrap();
    assert!(csv.starts_with(CSV_HEADER));
    let rows = parse_csv(&csv).unwrap();
    assert_eq!(rows.len(), outcome.rows.len());
    for (a, b) in rows.iter().zip(&outcome.rows) {
        assert_eq!((&a.method, a.run, a.spp), (&b.method, b.run, b.spp));
        let close = |x: f64, y: f64| (x - y).abs() <= 1e-6 * y.abs().max(1e-9);
        assert!(
            close(a.mae, b.mae)
                && close(a.relmse, b.relmse)
                && (a.seconds - b.seconds).abs() < 1e-5
        );
    }
    let mut falling = 0;
    for m in ["pt", "radiance", "product"] {
        for run in 0..2 {
            let r: Vec<_> = rows
                .iter()
                .filter(|r| r.method == m && r.run == run)
                .collect();
            assert!(r.len() >= 2, "{m} run {run}: {} snapshots", r.len());
            assert!(
                r.windows(2).all(|w| w[0].seconds <= w[1].seconds),
                "{m}: times not increasing"
            );
            assert!(
                r.iter()
                    .all(|x| x.mae.is_finite() && x.relmse.is_finite() && x.mae >= 0.0)
            );
            // The error falls as samples accumulate: at 8× the samples MAE
            // should be about 1/√8 ≈ 0.35 of the first snapshot's.
            let (first, last) = (r[0], *r.last().unwrap());
            assert!(last.mae < first.mae * 1.5, "{m}: error grew");
            if last.spp >= 8 * first.spp.max(1) {
                assert!(
                    last.mae < 0.7 * first.mae,
                    "{m} run {run}: MAE {} at {} spp against {} at {} spp",
                    last.mae,
                    last.spp,
                    first.mae,
                    first.spp
                );
                falling += 1;
            }
        }
        for suffix in [".exr", ".png", "-error.png"] {
            assert!(
                dir.join(format!("{m}{suffix}")).exists(),
                "{m}{suffix} missing"
            );
        }
    }
    assert!(
        falling > 0,
        "no run spanned 8× the samples of its first snapshot"
    );
    let svg = std::fs::read_to_string(dir.join("curves.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
    assert!(svg.contains("relMSE") && svg.contains("MAE"));
    let summary = std::fs::read_to_string(dir.join("summary.md")).unwrap();
    assert!(summary.contains("| product |") && summary.contains("Time-to-error speedup"));
    assert!(summary.contains("threads"));
    // The roulette override reaches the guided methods only, and the
    // summary says what every method ran with.
    assert!(summary.contains("pt: NEE, roulette classic"), "{summary}");
    // The guided methods' training rule is named (so runs across rules never pool); pt has none.
    assert!(
        summary.contains("radiance: no NEE, roulette off, training stops: budget;"),
        "{summary}"
    );
    assert!(
        summary.contains("product: no NEE, roulette off, training stops: budget, "),
        "{summary}"
    );
    assert!(
        !summary.contains("pt: NEE, roulette classic, training"),
        "{summary}"
    );
    // Each mean curve ends at the mean of its runs' final errors, the
    // figure of the summary's table, even when the runs took different
    // snapshots.
    for c in &outcome.curves {
        let finals: Vec<f64> = (0..2)
            .map(|run| {
                rows.iter()
                    .rfind(|r| r.method == c.method && r.run == run)
                    .unwrap()
                    .relmse
            })
            .collect();
        let end = c.relmse.last().unwrap().0;
        let mean = (finals[0] + finals[1]) / 2.0;
        assert!(
            (end - mean).abs() <= 1e-12 * mean,
            "{}: {end} against {mean}",
            c.method
        );
    }
    // `replot` recomputes exactly what compare wrote, from the CSV alone.
    let svg_before = std::fs::read(dir.join("curves.svg")).unwrap();
    let out = run_replot(&dir);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(std::fs::read(dir.join("curves.svg")).unwrap(), svg_before);
    assert_eq!(
        std::fs::read_to_string(dir.join("summary.md")).unwrap(),
        summary
    );
    // A cost section written by an older build is rewritten from runs.csv
    // and the plan lines, and nothing else of the summary changes.
    let cost_at = summary.find(COST_HEADING).unwrap();
    let stale = format!(
        "{}{COST_HEADING}\n\nstale text\n| pt | 1 |\n\n{}",
        &summary[..cost_at],
        &summary[summary[cost_at..]
            .find("\n## ")
            .map_or(summary.len(), |i| cost_at + i + 1)..]
    );
    assert_ne!(stale, summary);
    std::fs::write(dir.join("summary.md"), &stale).unwrap();
    assert!(run_replot(&dir).status.success());
    assert_eq!(
        std::fs::read_to_string(dir.join("summary.md")).unwrap(),
        summary
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// `ltcguide replot DIR` through the CLI.
fn run_replot(dir: &std::path::Path) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_ltcguide"))
        .arg("replot")
        .arg(dir)
        .output()
        .unwrap()
}

#[test]
fn replot_refuses_a_folder_without_a_comparison() {
    let dir = std::env::temp_dir().join(format!("ltcguide-replot-empty-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = run_replot(&dir);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("curves.csv"), "{err}");
    // A CSV without a compare summary beside it: nothing is written.
    std::fs::write(
        dir.join("curves.csv"),
        format!("{CSV_HEADER}\npt,0,1.0,1,0.1,0.2\n"),
    )
    .unwrap();
    let out = run_replot(&dir);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("summary.md"));
    assert!(!dir.join("curves.svg").exists());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn compare_refuses_a_reference_of_the_wrong_size() {
    let scene = tiny();
    let dir = std::env::temp_dir().join(format!("ltcguide-compare-bad-{}", std::process::id()));
    let opts = CompareOptions {
        seconds: 0.1,
        time_base: TimeBase::Wall,
        ..compare_options(vec![Method::Pt], &dir)
    };
    let wrong = Image {
        width: 10,
        height: 10,
        pixels: vec![glam::Vec3::ZERO; 100],
    };
    let err = run_compare(&scene, &wrong, &opts)
        .err()
        .expect("must refuse");
    assert!(err.contains("10×10") && err.contains("64×64"), "{err}");
    // And through the CLI: exit code 2, one error line.
    std::fs::create_dir_all(&dir).unwrap();
    let reference = dir.join("wrong.exr");
    write_rgb(&reference, 10, 10, &wrong.pixels).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_ltcguide"))
        .args([
            "compare",
            "tests/data/analytic/sphere_over_plane.xml",
            "--time",
            "0.1",
            "--reference",
        ])
        .arg(&reference)
        .arg("--out")
        .arg(dir.join("out"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("reference is 10×10"));
    std::fs::remove_dir_all(&dir).ok();
}

/// `run_compare` checks every method's render options before it makes its
/// folder: an infinite budget (which the positive-time check lets through)
/// or an ADRRS window below 1 would otherwise leave an empty folder behind
/// when the first render refuses them.
#[test]
fn compare_checks_every_methods_render_options_before_its_folder() {
    let dir = std::env::temp_dir().join(format!("ltcguide-compare-opts-{}", std::process::id()));
    let infinite = CompareOptions {
        seconds: f64::INFINITY,
        ..compare_options(vec![Method::Pt], &dir)
    };
    let narrow_window = CompareOptions {
        guided_roulette: Some((RouletteMode::Adrrs, 0.5)),
        ..compare_options(vec![Method::Pt, Method::Radiance], &dir)
    };
    for (opts, expected) in [
        (infinite, "--time must be"),
        (narrow_window, "--adrrs-window must be"),
    ] {
        match run_compare(&tiny(), &flat_reference(), &opts) {
            Err(err) => assert!(err.contains(expected), "{err}"),
            Ok(_) => panic!("{expected}: accepted"),
        }
        assert!(!dir.exists(), "{expected}: the folder was made");
    }
}

#[test]
fn compare_nee_choice_reaches_every_method() {
    let scene = tiny();
    let reference = flat_reference();
    for (choice, expected) in [
        (ltcguide::experiment::compare::NeeChoice::All, "nee on"),
        (ltcguide::experiment::compare::NeeChoice::None, "nee off"),
    ] {
        let dir = std::env::temp_dir().join(format!(
            "ltcguide-compare-nee-{expected}-{}",
            std::process::id()
        ));
        let opts = CompareOptions {
            nee: choice,
            ..compare_options(vec![Method::Pt, Method::Radiance], &dir)
        };
        let outcome = run_compare(&scene, &reference, &opts).unwrap();
        let plans: Vec<&str> = outcome
            .summary
            .lines()
            .filter(|l| l.contains("plan: method"))
            .collect();
        assert_eq!(plans.len(), 2, "{}", outcome.summary);
        assert!(plans.iter().all(|l| l.contains(expected)), "{plans:?}");
        std::fs::remove_dir_all(&dir).ok();
    }
}

/// Side by side, the methods of a run render at once on a share of the
/// threads: every method and run still yields its snapshots and final row,
/// in method order, and the summary says how the threads were shared and
/// what the plan decided in every run, a method's runs together.
#[test]
fn compare_side_by_side_runs_every_method_and_says_so() {
    let scene = tiny();
    let reference = flat_reference();
    let dir = std::env::temp_dir().join(format!("ltcguide-compare-sbs-{}", std::process::id()));
    let methods = vec![Method::Pt, Method::Radiance, Method::Product];
    let opts = CompareOptions {
        seconds: 0.3,
        time_base: TimeBase::Wall,
        runs: 2,
        first_run: 0,
        threads: 2,
        nee: ltcguide::experiment::compare::NeeChoice::All,
        side_by_side: true,
        ..compare_options(methods, &dir)
    };
    let outcome = run_compare(&scene, &reference, &opts).unwrap();
    let order: Vec<(&str, u32)> = outcome
        .rows
        .iter()
        .map(|r| (r.method.as_str(), r.run))
        .fold(Vec::new(), |mut v, k| {
            if v.last() != Some(&k) {
                v.push(k);
            }
            v
        });
    assert_eq!(
        order,
        [
            ("pt", 0),
            ("radiance", 0),
            ("product", 0),
            ("pt", 1),
            ("radiance", 1),
            ("product", 1)
        ]
    );
    for m in ["pt", "radiance", "product"] {
        for run in 0..2 {
            let r: Vec<_> = outcome
                .rows
                .iter()
                .filter(|r| r.method == m && r.run == run)
                .collect();
            assert!(r.len() >= 2, "{m} run {run}: {} rows", r.len());
            assert!(r.iter().all(|x| x.spp >= 1 && x.relmse.is_finite()));
        }
        assert!(dir.join(format!("{m}.exr")).exists(), "{m}.exr missing");
    }
    assert!(
        outcome
            .summary
            .contains("the methods of a run side by side on 1 of 2 threads each")
            && outcome.summary.contains("Per-scene plan: on"),
        "{}",
        outcome.summary
    );
    let plan_lines: Vec<&str> = outcome
        .summary
        .lines()
        .filter(|l| l.contains("plan: method"))
        .collect();
    let expected = ["pt", "radiance", "product"].iter().flat_map(|m| {
        [1000, 1001].map(move |seed| format!("- {m}, seed {seed}: plan: method {m} "))
    });
    assert_eq!(plan_lines.len(), 6, "{}", outcome.summary);
    for (line, prefix) in plan_lines.iter().zip(expected) {
        assert!(
            line.starts_with(&prefix),
            "{line:?} should start with {prefix:?}"
        );
    }
    // runs.csv: every run's wall and CPU seconds and spp, those of its final
    // curve row, its CPU that of its one thread (at most its wall time).
    let costs = parse_cost_csv(&std::fs::read_to_string(dir.join(COST_CSV)).unwrap()).unwrap();
    let cost_order: Vec<(&str, u32)> = costs.iter().map(|c| (c.method.as_str(), c.run)).collect();
    assert_eq!(cost_order, order);
    for c in &costs {
        let last = outcome
            .rows
            .iter()
            .rfind(|r| r.method == c.method && r.run == c.run)
            .unwrap();
        assert_eq!(c.spp, last.spp);
        // A run traces its image's samples, and more only if its plan
        // handed the rest of its budget to path tracing.
        let traced = c.traced_spp.expect("compare records traced samples");
        let seed = 1000 + c.run;
        let fell_back = plan_lines.iter().any(|l| {
            l.contains(&format!("- {}, seed {seed}: ", c.method)) && l.contains(FALLBACK_IMAGE)
        });
        assert!(
            if fell_back {
                traced > c.spp
            } else {
                traced == c.spp
            },
            "{} run {}: traced {traced}, image {} spp, fallback {fell_back}",
            c.method,
            c.run,
            c.spp
        );
        assert!((c.seconds - last.seconds).abs() < 1e-5);
        let cpu = c.cpu_seconds.expect("Linux has a per-thread CPU clock");
        assert!(
            cpu > 0.0 && cpu <= c.seconds * 1.05 + 0.05,
            "{} run {}: {cpu} CPU s in {} s on one thread",
            c.method,
            c.run,
            c.seconds
        );
    }
    let is_method_row = |l: &&str| {
        l.starts_with("| pt |") || l.starts_with("| radiance |") || l.starts_with("| product |")
    };
    let mut section = outcome
        .summary
        .lines()
        .skip_while(|l| *l != COST_HEADING)
        .take_while(|l| *l == COST_HEADING || !l.starts_with("## "));
    let cost_lines: Vec<&str> = section
        .by_ref()
        .take_while(|l| !l.starts_with("Counting every sample"))
        .filter(is_method_row)
        .collect();
    assert_eq!(cost_lines.len(), 3, "{}", outcome.summary);
    // The traced table follows where a run left passes out, with every method.
    let traced_rows = section.filter(is_method_row).count();
    let any_left_out = costs.iter().any(|c| c.traced_spp > Some(c.spp));
    assert_eq!(
        traced_rows,
        if any_left_out { 3 } else { 0 },
        "{}",
        outcome.summary
    );
    // Radiance is the base: its three ratios are 1.
    assert!(
        cost_lines[1].ends_with("| 1.000 | 1.000 | 1.000 |"),
        "{}",
        cost_lines[1]
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// On the CPU clock, each run's budget is its own CPU time: its final curve
/// row is at the budget, within a pass, and at most the CPU time its pool
/// measured (which also holds the snapshots), however the three runs
/// share the cores; the summary and the plot say which clock it was, and
/// `merge` will not pool it with a wall-clock comparison.
#[test]
fn compare_on_the_cpu_clock_gives_each_run_its_cpu_budget() {
    let scene = tiny();
    let reference = flat_reference();
    let dir = std::env::temp_dir().join(format!("ltcguide-compare-cpu-{}", std::process::id()));
    let budget = 0.4;
    let opts = CompareOptions {
        seconds: budget,
        time_base: TimeBase::Cpu,
        runs: 1,
        threads: 2,
        side_by_side: true,
        ..compare_options(vec![Method::Pt, Method::Radiance, Method::Product], &dir)
    };
    let outcome = run_compare(&scene, &reference, &opts).unwrap();
    let costs = parse_cost_csv(&std::fs::read_to_string(dir.join(COST_CSV)).unwrap()).unwrap();
    assert_eq!(costs.len(), 3);
    for c in &costs {
        let last = outcome.rows.iter().rfind(|r| r.method == c.method).unwrap();
        let cpu = c.cpu_seconds.expect("Linux has a per-thread CPU clock");
        assert!(
            last.seconds <= cpu + 1e-3 && (budget * 0.5..budget * 1.5).contains(&last.seconds),
            "{}: clock {} s, CPU {cpu} s, budget {budget} s",
            c.method,
            last.seconds
        );
    }
    assert!(
        outcome
            .summary
            .contains("Budget 0.4 CPU s per thread per run (training included)"),
        "{}",
        outcome.summary
    );
    let svg = std::fs::read_to_string(dir.join("curves.svg")).unwrap();
    assert!(svg.contains("CPU seconds per thread"));
    let wall_dir = dir.join("wall");
    let wall = CompareOptions {
        time_base: TimeBase::Wall,
        methods: vec![Method::Pt],
        first_run: 1,
        out_dir: wall_dir.clone(),
        ..opts.clone()
    };
    run_compare(&scene, &reference, &wall).unwrap();
    let err =
        ltcguide::experiment::merge::merge(&dir.join("pooled"), &[dir.clone(), wall_dir], false)
            .unwrap_err();
    assert!(err.contains("budget"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

/// A window ratio below 1 (or not a number) would make every ADRRS
/// decision invalid and switch roulette off silently: render and compare
/// refuse it with exit code 2 and one error line.
#[test]
fn adrrs_window_below_one_is_refused() {
    let dir = std::env::temp_dir().join(format!("ltcguide-window-{}", std::process::id()));
    for window in ["0.5", "NaN"] {
        let render = std::process::Command::new(env!("CARGO_BIN_EXE_ltcguide"))
            .args([
                "render",
                "tests/data/analytic/sphere_over_plane.xml",
                "--spp",
                "1",
            ])
            .args(["--adrrs-window", window, "--out"])
            .arg(dir.join("x.exr"))
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .output()
            .unwrap();
        let compare = std::process::Command::new(env!("CARGO_BIN_EXE_ltcguide"))
            .args([
                "compare",
                "tests/data/analytic/sphere_over_plane.xml",
                "--time",
                "0.1",
            ])
            .args(["--reference", "tests/data/analytic/sphere_over_plane.xml"])
            .args(["--adrrs-window", window, "--out"])
            .arg(dir.join("out"))
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .output()
            .unwrap();
        for out in [render, compare] {
            assert_eq!(out.status.code(), Some(2));
            let err = String::from_utf8_lossy(&out.stderr);
            assert!(err.contains("--adrrs-window must be"), "{err}");
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A negative or non-finite L2 weight of the BSDF fraction is refused by
/// compare and attribute with exit code 2 and one error line, before the
/// scene is read (it does not exist here).
#[test]
fn bsdf_fraction_l2_out_of_range_is_refused_by_the_study_commands() {
    let dir = std::env::temp_dir().join(format!("ltcguide-l2-{}", std::process::id()));
    let missing = dir.join("no-such-scene.xml");
    for lambda in ["-1", "NaN", "inf"] {
        let l2 = format!("--bsdf-fraction-l2={lambda}");
        let compare = std::process::Command::new(env!("CARGO_BIN_EXE_ltcguide"))
            .arg("compare")
            .arg(&missing)
            .args(["--time", "0.1", "--reference", "none.exr", &l2, "--out"])
            .arg(dir.join("out"))
            .output()
            .unwrap();
        let attribute = std::process::Command::new(env!("CARGO_BIN_EXE_ltcguide"))
            .arg("attribute")
            .arg(&missing)
            .arg(&l2)
            .output()
            .unwrap();
        for out in [compare, attribute] {
            let err = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(2), "{err}");
            assert!(err.contains("--bsdf-fraction-l2 must be"), "{err}");
            assert_eq!(err.trim().lines().count(), 1, "{err}");
        }
    }
    assert!(!dir.exists());
}

/// The ablation times the paper's three kernels with the paper's product
/// (every vertex, cosine lobes included, so that a diffuse scene exercises
/// them) and no plan, then the plan rows: with the plan, without it, and without it at
/// the paper's setting, against which the savings are stated.
#[test]
fn ablation_reports_every_kernel_and_plan_row() {
    let scene = tiny();
    let out = ltcguide::experiment::ablation::run_ablation(
        &scene,
        2,
        0,
        settings(&scene, Method::Product),
        false,
    )
    .unwrap();
    let names: Vec<&str> = out.kernels.iter().map(|r| r.variant.as_str()).collect();
    assert_eq!(names, ["naive", "optimized", "simd"]);
    assert_eq!(out.plan.len(), 3);
    assert!(out.plan[2].variant.contains("every vertex, cosine product"));
    assert!(
        out.kernels
            .iter()
            .chain(&out.plan)
            .all(|r| r.spp == 2 && r.seconds > 0.0),
        "{}",
        out.markdown
    );
    assert!(out.markdown.contains("| naive |") && out.markdown.contains("| 100 % |"));
    // The kernels run without the plan, so no strategy trial can hand part
    // of a kernel's samples to another strategy; the plan rows say what
    // their runs ended with.
    assert!(
        out.kernels
            .iter()
            .all(|r| r.outcome == "the method as such"),
        "{}",
        out.markdown
    );
    assert!(out.markdown.contains("| after the strategy trial |"));
    use ltcguide::experiment::ablation::trial_outcome;
    use ltcguide::guiding::trial::{CHEAPER_WEIGHTS, FALLBACK_IMAGE};
    assert_eq!(
        trial_outcome(Some(&format!(
            "plan: … | guiding does not pay here …, and {FALLBACK_IMAGE}"
        ))),
        "path tracing with NEE: the image holds its passes alone"
    );
    assert_eq!(
        trial_outcome(Some(&format!(
            "plan: … | product {CHEAPER_WEIGHTS} (efficiency …)"
        ))),
        "radiance weights"
    );
    assert_eq!(
        trial_outcome(Some("plan: … | plan disabled")),
        "the method as such"
    );
    assert!(
        out.plan_line
            .contains("every vertex takes radiance weights"),
        "{}",
        out.plan_line
    );
}

/// The attribution's pairs differ only in the method: on a scene whose
/// lobes are all cosines, product guiding takes radiance weights at every
/// vertex, so every variance factor is 1 up to rounding (a pair rendered
/// with different seeds or settings would be off by percents). On a
/// glossy floor the product changes the variances, and every factor is a
/// finite positive ratio.
#[test]
fn attribution_pairs_differ_only_in_the_method() {
    use ltcguide::experiment::attribution::{AttributionOptions, ClassSplit, run_attribution};
    use ltcguide::experiment::pixel_classes::PixelClass;
    let options = |scene: &Scene, exact_integrals| AttributionOptions {
        spp: 8,
        seeds: 2,
        threads: 2,
        path: settings(scene, Method::Product),
        guide_fraction: 0.2,
        other_roulette: RouletteMode::Classic,
        exact_integrals,
        bsdf_fraction_l2: None,
        clock: TimeBase::Cpu,
        progress: false,
    };
    let diffuse = tiny();
    let out = run_attribution(&diffuse, &options(&diffuse, true)).unwrap();
    assert_eq!(out.factors.len(), 9, "{}", out.markdown);
    assert!(
        out.markdown
            .contains("seconds of each render's own CPU time per thread"),
        "{}",
        out.markdown
    );
    // No glossy first vertex: nothing to split there.
    assert!(out.at_glossy.is_empty() && !out.markdown.contains("At the glossy first vertices"));
    for f in &out.factors {
        assert_eq!(f.per_seed.len(), 2);
        if f.name.contains("variance") || f.name.starts_with("expected relMSE") {
            for v in &f.per_seed {
                assert!((v - 1.0).abs() < 1e-4, "{}: {v}\n{}", f.name, out.markdown);
            }
        }
    }
    // The split by first vertex: no glossy pixels, ratios 1 where radiance
    // guiding has variance, and pixels and shares that add up.
    assert!(
        out.by_class
            .iter()
            .all(|c| !matches!(c.class, PixelClass::Glossy | PixelClass::GlossyCoat))
    );
    let total = |f: fn(&ClassSplit) -> f64| out.by_class.iter().map(f).sum::<f64>();
    assert!((total(|c| c.pixels) - 1.0).abs() < 1e-9);
    assert!((total(|c| c.radiance_share) - 1.0).abs() < 1e-9);
    for c in out.by_class.iter().filter(|c| c.radiance_share > 0.0) {
        assert!(
            c.per_seed.iter().all(|v| (v - 1.0).abs() < 1e-4),
            "{}",
            out.markdown
        );
    }
    // Different seeds give different renders: the ratios are not trivially 1.
    let seeds_differ =
        out.alpha[0] != out.alpha[1] || out.factors.iter().any(|f| f.per_seed[0] != f.per_seed[1]);
    assert!(seeds_differ, "{}", out.markdown);

    let glossy_xml = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/analytic/sphere_over_plane.xml"),
    )
    .unwrap()
    .replacen(
        r#"<bsdf type="diffuse"><rgb name="reflectance" value="0.5, 0.5, 0.5"/></bsdf>"#,
        r#"<bsdf type="roughconductor"><float name="alpha" value="0.1"/></bsdf>"#,
        1,
    )
    .replace(r#"value="2"/></integrator>"#, r#"value="4"/></integrator>"#);
    let glossy =
        ltcguide::scene::load_scene_from_str(&glossy_xml, Path::new("glossy.xml")).unwrap();
    let out = run_attribution(&glossy, &options(&glossy, false)).unwrap();
    assert_eq!(out.factors.len(), 8, "{}", out.markdown);
    assert!(
        out.factors
            .iter()
            .all(|f| f.mean() > 0.0 && f.mean().is_finite())
    );
    for per_sample in &out.factors[2..4] {
        assert!(
            per_sample.per_seed.iter().all(|v| (v - 1.0).abs() > 1e-3),
            "{}: the product changed nothing on a glossy floor\n{}",
            per_sample.name,
            out.markdown
        );
    }
    assert!(
        out.markdown
            .contains("At zero overhead the product would reach")
    );
    // The floor is glossy: the product's own distribution acts there.
    let floor = out
        .by_class
        .iter()
        .find(|c| c.class == PixelClass::Glossy)
        .expect("the glossy floor's pixels are classed glossy");
    assert!(floor.pixels > 0.1 && floor.radiance_share > 0.0);
    assert!(
        floor.per_seed.iter().all(|v| (v - 1.0).abs() > 1e-3),
        "{}",
        out.markdown
    );
    assert!(
        out.markdown
            .contains("| glossy GGX lobe (α ≤ 0.5), most of the weight |")
    );
    // At the glossy first vertices: the learned pair's ratio is the class
    // split's, fixing α does change the product's variance, and no ratio is
    // off by the orders of magnitude a normaliser from other renders gave
    // (a firefly weighed by a third render's dark pixel).
    let names: Vec<&str> = out.at_glossy.iter().map(|f| f.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "product / radiance, learned α",
            "product / radiance, BSDF fraction fixed",
            "product: fixed / learned α",
            "radiance: fixed / learned α"
        ]
    );
    let row = |i: usize| &out.at_glossy[i].per_seed;
    for s in 0..2 {
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * b.abs();
        assert!(close(row(0)[s], floor.per_seed[s]), "{}", out.markdown);
        for r in 0..4 {
            assert!(row(r)[s] > 0.05 && row(r)[s] < 20.0, "{}", out.markdown);
        }
        assert!((row(2)[s] - 1.0).abs() > 1e-3, "{}", out.markdown);
    }
    assert!(out.markdown.contains("| product: fixed / learned α |"));

    // `--bsdf-fraction-l2` reaches both methods' learned fractions: a huge
    // λ holds α at ½, none lets it move.
    let alpha_at = |lambda: f64| {
        let opts = AttributionOptions {
            seeds: 1,
            spp: 32,
            bsdf_fraction_l2: Some(lambda),
            ..options(&glossy, false)
        };
        let out = run_attribution(&glossy, &opts).unwrap();
        assert!(
            out.markdown
                .contains(&format!("NEE off, BSDF fraction's L2 λ = {lambda},")),
            "{}",
            out.markdown
        );
        out.alpha[0]
    };
    let (held, free) = (alpha_at(1e4), alpha_at(0.0));
    let off_half = |a: (f64, f64)| [(a.0 - 0.5).abs(), (a.1 - 0.5).abs()];
    assert!(off_half(held).iter().all(|&d| d < 1e-3), "{held:?}");
    assert!(off_half(free).iter().all(|&d| d > 3e-3), "{free:?}");
}

/// Pixels are classed by the floor's material as the product treats it:
/// a sharp conductor is glossy, a plastic's coat over its base is a coat,
/// and GGX rougher than 0.5 is a cosine lobe. The light's own pixels (a
/// black diffuse sphere, where paths end) have no vertex to guide, and
/// every other pixel sees the floor.
#[test]
fn pixel_classes_follow_the_product_treatment_of_the_material() {
    use ltcguide::experiment::pixel_classes::{PixelClass, class_counts, classify};
    let xml = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/analytic/sphere_over_plane.xml"),
    )
    .unwrap();
    let floor = r#"<bsdf type="diffuse"><rgb name="reflectance" value="0.5, 0.5, 0.5"/></bsdf>"#;
    let cases = [
        (floor, PixelClass::Cosine),
        (
            r#"<bsdf type="roughconductor"><float name="alpha" value="0.1"/></bsdf>"#,
            PixelClass::Glossy,
        ),
        (
            r#"<bsdf type="roughconductor"><float name="alpha" value="0.8"/></bsdf>"#,
            PixelClass::Cosine,
        ),
        (
            r#"<bsdf type="roughplastic"><float name="alpha" value="0.1"/></bsdf>"#,
            PixelClass::GlossyCoat,
        ),
    ];
    for (bsdf, want) in cases {
        let scene = ltcguide::scene::load_scene_from_str(
            &xml.replacen(floor, bsdf, 1),
            Path::new("classes.xml"),
        )
        .unwrap();
        let classes = classify(&scene);
        assert_eq!(classes.len(), 64 * 64);
        let counts = class_counts(&classes);
        let i = PixelClass::ALL.iter().position(|&c| c == want).unwrap();
        // The floor fills the view but for the sphere's few pixels.
        assert!(counts[i] > 64 * 64 * 9 / 10, "{bsdf}: {counts:?}");
        assert!(counts[3] > 0, "{bsdf}: {counts:?}");
        assert_eq!(counts[i] + counts[3], 64 * 64, "{bsdf}: {counts:?}");
    }
}

#[test]
fn attribution_refuses_options_it_cannot_run() {
    use ltcguide::experiment::attribution::{AttributionOptions, check};
    let scene = tiny();
    let good = AttributionOptions {
        spp: 8,
        seeds: 1,
        threads: 0,
        path: settings(&scene, Method::Product),
        guide_fraction: 0.2,
        other_roulette: RouletteMode::Classic,
        exact_integrals: false,
        bsdf_fraction_l2: None,
        clock: TimeBase::Wall,
        progress: false,
    };
    assert!(check(&good).is_ok());
    assert!(
        check(&AttributionOptions {
            bsdf_fraction_l2: Some(0.0),
            ..good.clone()
        })
        .is_ok()
    );
    let bad = [
        AttributionOptions {
            spp: 1,
            ..good.clone()
        },
        AttributionOptions {
            seeds: 0,
            ..good.clone()
        },
        AttributionOptions {
            guide_fraction: 1.0,
            ..good.clone()
        },
        AttributionOptions {
            guide_fraction: f32::NAN,
            ..good.clone()
        },
        AttributionOptions {
            other_roulette: RouletteMode::Adrrs,
            ..good.clone()
        },
        AttributionOptions {
            bsdf_fraction_l2: Some(-0.01),
            ..good.clone()
        },
        AttributionOptions {
            bsdf_fraction_l2: Some(f64::NAN),
            ..good.clone()
        },
        AttributionOptions {
            bsdf_fraction_l2: Some(f64::INFINITY),
            ..good.clone()
        },
        AttributionOptions {
            path: PathSettings {
                adrrs_window: 0.5,
                ..good.path
            },
            ..good.clone()
        },
        AttributionOptions {
            path: PathSettings {
                max_depth: Some(0),
                ..good.path
            },
            ..good.clone()
        },
    ];
    for opts in bad {
        assert!(check(&opts).is_err(), "{opts:?}");
    }
}

/// `scripts/ratios.py` counts the runs' trial outcomes by the phrases of the
/// trial's plan notes: a reworded note would silently count as no outcome.
#[test]
fn the_ratio_script_looks_for_the_trials_phrases() {
    use ltcguide::guiding::trial::{CHEAPER_WEIGHTS, FALLBACK_IMAGE, GUIDING_KEPT};
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/scripts/ratios.py");
    let script = std::fs::read_to_string(path).unwrap();
    let phrase = |name: &str| -> String {
        let line = script
            .lines()
            .find(|l| l.starts_with(&format!("{name} = \"")))
            .unwrap_or_else(|| panic!("{path} defines no {name}"));
        line[name.len() + 4..line.len() - 1].to_string()
    };
    assert_eq!(phrase("PT_IMAGE"), FALLBACK_IMAGE);
    assert_eq!(phrase("FALLBACK_DECLINED"), GUIDING_KEPT);
    let radiance = phrase("RADIANCE_WEIGHTS");
    assert!(
        format!("product {CHEAPER_WEIGHTS}").starts_with(&radiance),
        "{radiance}"
    );
}
