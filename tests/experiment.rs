//! `compare` on a tiny scene with a tiny budget writes well-formed files,
//! side by side and on the CPU clock, and refuses a reference of the wrong
//! size or options it cannot run; `replot` and the pages' ratio script.
//! The ablation and the attribution are in `ablation_attribution.rs`.

mod common;

use common::study::{compare_options, flat_reference, settings, tiny};
use ltcguide::experiment::compare::{CompareOptions, run_compare};
use ltcguide::experiment::cost::{COST_CSV, COST_HEADING, parse_cost_csv};
use ltcguide::experiment::curves::{CSV_HEADER, parse_csv};
use ltcguide::experiment::summary_text::FINAL_ERRORS_HEADER;
use ltcguide::film::exr_io::{read_image, write_rgb};
use ltcguide::film::image::Image;
use ltcguide::film::metrics::{relmse, relmse_trimmed};
use ltcguide::guiding::trial::FALLBACK_IMAGE;
use ltcguide::integrator::path::RouletteMode;
use ltcguide::render::{Budget, Method, RenderOptions, TimeBase, render};

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
            // Leaving the worst pixels out lowers relMSE or keeps it (they
            // are the largest terms), and every snapshot has the figure.
            for x in &r {
                let t = x.relmse_trimmed.expect("every row has a trimmed relMSE");
                assert!(t > 0.0 && t <= x.relmse, "{m}: {t} against {}", x.relmse);
            }
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
    assert!(summary.contains(FINAL_ERRORS_HEADER), "{summary}");
    // The trimmed relMSE of a run's last row is the metric of its final
    // image: the first run's, which compare saves as <method>.exr.
    for m in ["pt", "radiance", "product"] {
        let image = read_image(&dir.join(format!("{m}.exr"))).unwrap();
        let last = rows.iter().rfind(|r| r.method == m && r.run == 0).unwrap();
        let expected = relmse_trimmed(&image, &reference).unwrap().unwrap();
        let got = last.relmse_trimmed.unwrap();
        assert!(
            (got - expected).abs() <= 1e-6 * expected,
            "{m}: {got} against {expected}"
        );
        assert!(expected < relmse(&image, &reference).unwrap());
    }
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
        format!("{CSV_HEADER}\npt,0,1.0,1,0.1,0.2,0.1\n"),
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
