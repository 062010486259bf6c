//! `compare --first-run` continues a study with new seeds, and `merge` pools
//! the comparisons: the pooled tables are those of the pooled rows, and
//! comparisons of different things, or of one seed twice, are refused with
//! nothing written.

mod common;

use common::study::{compare_options, flat_reference, tiny};
use ltcguide::experiment::compare::{CompareOptions, run_compare, run_options};
use ltcguide::experiment::cost::{COST_CSV, COST_HEADING, CostRow, parse_cost_csv};
use ltcguide::experiment::curves::{CurveRow, parse_csv};
use ltcguide::experiment::merge::merge;
use ltcguide::render::{Method, TimeBase};
use std::path::{Path, PathBuf};

fn temp(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("ltcguide-merge-{name}-{}", std::process::id()))
}

/// One comparison of pt and radiance, `runs` runs from `first_run` on.
fn study(dir: &Path, first_run: u32, runs: u32, seconds: f64) -> Vec<CurveRow> {
    let opts = CompareOptions {
        runs,
        first_run,
        seconds,
        time_base: TimeBase::Wall,
        use_plan: false,
        ..compare_options(vec![Method::Pt, Method::Radiance], dir)
    };
    run_compare(&tiny(), &flat_reference(), &opts).unwrap().rows
}

fn rows_in(dir: &Path) -> Vec<CurveRow> {
    parse_csv(&std::fs::read_to_string(dir.join("curves.csv")).unwrap()).unwrap()
}

fn costs_in(dir: &Path) -> Vec<CostRow> {
    parse_cost_csv(&std::fs::read_to_string(dir.join(COST_CSV)).unwrap()).unwrap()
}

fn run_cli(args: &[&std::ffi::OsStr]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_ltcguide"))
        .args(args)
        .output()
        .unwrap()
}

#[test]
fn merged_comparisons_pool_every_run_and_recompute_the_tables() {
    let (a, b, out) = (temp("a"), temp("b"), temp("out"));
    let rows_a = study(&a, 0, 1, 0.2);
    let rows_b = study(&b, 1, 2, 0.2);
    // --first-run numbers the runs and their seeds on from it.
    assert!(rows_b.iter().all(|r| r.run == 1 || r.run == 2));
    let summary_b = std::fs::read_to_string(b.join("summary.md")).unwrap();
    assert!(
        summary_b.contains("2 runs per method (seeds 1001–1002)"),
        "{summary_b}"
    );
    let merged = merge(&out, &[a.clone(), b.clone()], false).unwrap();
    assert_eq!(merged.runs, [0, 1, 2]);
    // Every row of both, grouped by method then run, none changed.
    let pooled = rows_in(&out);
    assert_eq!(pooled.len(), rows_a.len() + rows_b.len());
    for method in ["pt", "radiance"] {
        let expected: Vec<&CurveRow> = [&rows_a, &rows_b]
            .into_iter()
            .flat_map(|rows| rows.iter().filter(|r| r.method == method))
            .collect();
        let got: Vec<&CurveRow> = pooled.iter().filter(|r| r.method == method).collect();
        assert_eq!(got.len(), expected.len());
        for (g, e) in got.iter().zip(&expected) {
            assert_eq!((g.run, g.spp), (e.run, e.spp));
            assert!((g.relmse - e.relmse).abs() <= 1e-9 * e.relmse.abs().max(1e-12));
        }
        // The table's mean relMSE is the mean of the three runs' final rows.
        let finals: Vec<f64> = (0..3)
            .map(|run| {
                pooled
                    .iter()
                    .rfind(|r| r.method == method && r.run == run)
                    .unwrap()
                    .relmse
            })
            .collect();
        let mean = finals.iter().sum::<f64>() / 3.0;
        let line = merged
            .summary
            .lines()
            .find(|l| l.starts_with(&format!("| {method} |")))
            .unwrap();
        let shown: f64 = line
            .split('|')
            .nth(3)
            .unwrap()
            .split('±')
            .next()
            .unwrap()
            .trim()
            .parse()
            .unwrap();
        assert!((shown - mean).abs() <= 1e-4 * mean, "{line}: mean {mean}");
    }
    let s = &merged.summary;
    assert!(s.contains("3 runs per method (seeds 1000–1002)"), "{s}");
    assert!(
        s.contains("Pooled by `ltcguide merge` from 2 comparisons"),
        "{s}"
    );
    assert!(s.contains("Time-to-error speedup"), "{s}");
    assert_eq!(std::fs::read_to_string(out.join("summary.md")).unwrap(), *s);
    // runs.csv pools every run's cost, grouped by method then run.
    let costs = costs_in(&out);
    let keys: Vec<(&str, u32)> = costs.iter().map(|c| (c.method.as_str(), c.run)).collect();
    assert_eq!(
        keys,
        [
            ("pt", 0),
            ("pt", 1),
            ("pt", 2),
            ("radiance", 0),
            ("radiance", 1),
            ("radiance", 2)
        ]
    );
    for c in &costs {
        let last = pooled
            .iter()
            .rfind(|r| r.method == c.method && r.run == c.run)
            .unwrap();
        assert_eq!(c.spp, last.spp);
    }
    assert!(s.contains(COST_HEADING), "{s}");
    assert!(!s.contains("predate"), "{s}");
    let svg = std::fs::read_to_string(out.join("curves.svg")).unwrap();
    assert!(svg.contains("(3 runs)"));
    // The pooled folder is a comparison itself: replot recomputes its
    // curves exactly from its CSV.
    let replot = run_cli(&["replot".as_ref(), out.as_os_str()]);
    assert!(replot.status.success());
    assert_eq!(
        std::fs::read_to_string(out.join("curves.svg")).unwrap(),
        svg
    );
    assert_eq!(std::fs::read_to_string(out.join("summary.md")).unwrap(), *s);
    // Pooling a pooled folder again keeps each plan line's own comparison,
    // without naming the pooled folder in front of it a second time.
    let (d, again) = (temp("d"), temp("again"));
    study(&d, 3, 1, 0.2);
    let twice = merge(&again, &[out.clone(), d.clone()], false).unwrap();
    let plans: Vec<&str> = twice
        .summary
        .lines()
        .filter(|l| l.contains(": plan: "))
        .collect();
    assert_eq!(plans.len(), 8, "{}", twice.summary);
    for (line, dir) in plans.iter().zip([&a, &a, &b, &b, &b, &b, &d, &d]) {
        assert!(
            line.starts_with(&format!("- `{}`: ", dir.display())) && !line.contains("`: `"),
            "{line}"
        );
    }
    assert_eq!(costs_in(&again).len(), 8);
    for d in [a, b, d, again, out] {
        std::fs::remove_dir_all(d).ok();
    }
}

#[test]
fn merge_refuses_a_seed_twice_and_different_studies() {
    let (a, b, c, out) = (temp("ra"), temp("rb"), temp("rc"), temp("rout"));
    study(&a, 0, 1, 0.2);
    study(&b, 0, 1, 0.2);
    study(&c, 1, 1, 0.3);
    let err = merge(&out, &[a.clone(), b.clone()], false).unwrap_err();
    assert!(err.contains("run 0 (seed 1000) is in both"), "{err}");
    let err = merge(&out, &[a.clone(), c.clone()], false).unwrap_err();
    assert!(err.contains("differ in budget"), "{err}");
    assert!(merge(&out, std::slice::from_ref(&a), false).is_err());
    // Run numbers past u32::MAX are refused before anything renders.
    let past = CompareOptions {
        first_run: u32::MAX,
        ..compare_options(vec![Method::Pt], &out)
    };
    match run_compare(&tiny(), &flat_reference(), &past) {
        Err(err) => assert!(err.contains("--first-run"), "{err}"),
        Ok(_) => panic!("run numbers past u32::MAX were accepted"),
    }
    assert!(!out.exists(), "a refused merge wrote {}", out.display());
    // Through the CLI: exit 2, the reason on stderr, nothing written.
    let cli = run_cli(&[
        "merge".as_ref(),
        "--out".as_ref(),
        out.as_os_str(),
        a.as_os_str(),
        b.as_os_str(),
    ]);
    assert_eq!(cli.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&cli.stderr).contains("is in both"));
    assert!(!out.exists());
    for d in [a, b, c] {
        std::fs::remove_dir_all(d).ok();
    }
}

#[test]
fn merge_pools_the_costs_it_has_and_refuses_a_broken_runs_csv() {
    let (a, b, out) = (temp("ca"), temp("cb"), temp("cout"));
    study(&a, 0, 1, 0.2);
    study(&b, 1, 1, 0.2);
    // A comparison made before runs.csv existed: the pooled table covers the
    // other's runs and names the one left out.
    std::fs::remove_file(a.join(COST_CSV)).unwrap();
    let merged = merge(&out, &[a.clone(), b.clone()], false).unwrap();
    let runs: Vec<u32> = costs_in(&out).iter().map(|c| c.run).collect();
    assert_eq!(runs, [1, 1]);
    assert!(
        merged.summary.contains(COST_HEADING)
            && merged.summary.contains(
                "covers seeds 1001, the runs that recorded it; seeds 1000 predate `runs.csv`"
            ),
        "{}",
        merged.summary
    );
    // `replot` rebuilds the pooled cost section, coverage note included,
    // exactly as `merge` wrote it.
    let pooled = std::fs::read_to_string(out.join("summary.md")).unwrap();
    let replotted = ltcguide::experiment::replot::replot(&out).unwrap();
    assert!(replotted.cost_rewritten);
    assert_eq!(
        std::fs::read_to_string(out.join("summary.md")).unwrap(),
        pooled
    );
    // No source with costs: no table, and no stale runs.csv in `out`.
    let c = temp("cc");
    study(&c, 2, 1, 0.2);
    std::fs::remove_file(b.join(COST_CSV)).unwrap();
    std::fs::remove_file(c.join(COST_CSV)).unwrap();
    let merged = merge(&out, &[a.clone(), b.clone(), c.clone()], false).unwrap();
    assert!(!merged.summary.contains(COST_HEADING));
    assert!(!out.join(COST_CSV).exists());
    // A runs.csv that lacks a run of curves.csv is refused, nothing written.
    std::fs::remove_dir_all(&b).unwrap();
    study(&b, 1, 1, 0.2);
    let text = std::fs::read_to_string(b.join(COST_CSV)).unwrap();
    let cut: Vec<&str> = text
        .lines()
        .filter(|l| !l.starts_with("radiance,"))
        .collect();
    std::fs::write(b.join(COST_CSV), cut.join("\n")).unwrap();
    let fresh = temp("cfresh");
    let err = merge(&fresh, &[a.clone(), b.clone()], false).unwrap_err();
    assert!(err.contains("one row for each run"), "{err}");
    assert!(!fresh.exists());
    for d in [a, b, c, out] {
        std::fs::remove_dir_all(d).ok();
    }
}

/// `compare --bsdf-fraction-l2`: λ reaches every guided run, and a λ other
/// than the default enters the settings line, so `merge` refuses to pool
/// its runs with the default's, while runs that name the default pool with
/// runs made before the option existed. A bad λ is refused before anything
/// is written.
#[test]
fn merge_pools_only_runs_at_the_same_bsdf_fraction_l2() {
    let study_at = |dir: &Path, first_run: u32, lambda: Option<f64>| {
        let opts = CompareOptions {
            first_run,
            use_plan: false,
            bsdf_fraction_l2: lambda,
            ..compare_options(vec![Method::Pt, Method::Radiance], dir)
        };
        for method in [Method::Pt, Method::Radiance, Method::Product] {
            let render = run_options(&tiny(), method, first_run, &opts);
            assert_eq!(render.bsdf_fraction_l2, lambda, "{method:?}");
        }
        run_compare(&tiny(), &flat_reference(), &opts).unwrap();
        std::fs::read_to_string(dir.join("summary.md")).unwrap()
    };
    let (a, b, c) = (temp("la"), temp("lb"), temp("lc"));
    let default = study_at(&a, 0, None);
    // The grid-learned fraction is a setting of its own, refused alike.
    let grid_dir = temp("lgrid");
    let grid_opts = CompareOptions {
        first_run: 3,
        use_plan: false,
        bsdf_fraction_learning: ltcguide::guiding::adam::FractionLearning::VarianceGrid,
        ..compare_options(vec![Method::Pt, Method::Radiance], &grid_dir)
    };
    run_compare(&tiny(), &flat_reference(), &grid_opts).unwrap();
    let grid = std::fs::read_to_string(grid_dir.join("summary.md")).unwrap();
    assert!(
        grid.contains("training stops: budget, BSDF fraction learned by variance-grid. "),
        "{grid}"
    );
    let grid_refused = temp("lgridrefused");
    let err = merge(&grid_refused, &[a.clone(), grid_dir.clone()], false).unwrap_err();
    assert!(err.contains("differ in"), "{err}");
    std::fs::remove_dir_all(&grid_dir).ok();
    let named_default = study_at(&b, 1, Some(0.01));
    let other = study_at(&c, 2, Some(0.1));
    let settings = |summary: &str| {
        summary
            .lines()
            .find(|l| l.starts_with("Path settings: "))
            .unwrap()
            .to_owned()
    };
    assert_eq!(settings(&default), settings(&named_default));
    assert!(!default.contains("L2"), "{default}");
    assert!(
        settings(&other).contains("training stops: budget, BSDF fraction's L2 λ = 0.1. "),
        "{other}"
    );
    // pt learns no fraction: its settings say nothing of λ.
    let pt = settings(&other);
    assert!(
        pt.starts_with("Path settings: pt: NEE, roulette classic; "),
        "{pt}"
    );
    let (pooled, refused) = (temp("lpool"), temp("lrefused"));
    merge(&pooled, &[a.clone(), b.clone()], false).unwrap();
    let err = merge(&refused, &[a.clone(), c.clone()], false).unwrap_err();
    assert!(err.contains("differ in"), "{err}");
    assert!(!refused.exists());
    // A bad λ fails before the output folder is made.
    let bad_dir = temp("lbad");
    for lambda in [-0.1, f64::NAN, f64::INFINITY] {
        let opts = CompareOptions {
            bsdf_fraction_l2: Some(lambda),
            ..compare_options(vec![Method::Radiance], &bad_dir)
        };
        match run_compare(&tiny(), &flat_reference(), &opts) {
            Err(err) => assert!(err.contains("--bsdf-fraction-l2 must be"), "{err}"),
            Ok(_) => panic!("λ = {lambda} was accepted"),
        }
        assert!(!bad_dir.exists());
    }
    for d in [a, b, c, pooled] {
        std::fs::remove_dir_all(d).ok();
    }
}

/// The summary without its machine line: a folder made before summaries
/// recorded the exact budget and the reference.
fn without_record(dir: &Path) {
    let path = dir.join("summary.md");
    let text = std::fs::read_to_string(&path).unwrap();
    let kept: String = text
        .lines()
        .filter(|l| !l.starts_with("<!-- ltcguide study:"))
        .map(|l| format!("{l}\n"))
        .collect();
    assert_ne!(kept, text, "no machine line in {}", path.display());
    std::fs::write(&path, kept).unwrap();
}

fn file_names(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// A folder holding a comparison is refused before any run, its files
/// untouched; `overwrite` removes exactly the files a comparison writes, so
/// no image of a method the new study lacks stays beside its summary.
#[test]
fn compare_refuses_a_folder_holding_a_comparison_unless_told_to_overwrite() {
    let dir = temp("occupied");
    study(&dir, 0, 1, 0.2);
    std::fs::write(dir.join("notes.txt"), "mine").unwrap();
    let before = std::fs::read_to_string(dir.join("summary.md")).unwrap();
    let names = file_names(&dir);
    let pt_only = |overwrite| CompareOptions {
        overwrite,
        ..compare_options(vec![Method::Pt], &dir)
    };
    let err = match run_compare(&tiny(), &flat_reference(), &pt_only(false)) {
        Err(err) => err,
        Ok(_) => panic!("a folder holding a comparison was written over"),
    };
    assert!(
        err.contains("already holds a comparison") && err.contains("--overwrite"),
        "{err}"
    );
    assert_eq!(file_names(&dir), names);
    assert_eq!(
        std::fs::read_to_string(dir.join("summary.md")).unwrap(),
        before
    );
    let outcome = run_compare(&tiny(), &flat_reference(), &pt_only(true)).unwrap();
    assert!(!outcome.summary.contains("radiance"), "{}", outcome.summary);
    for gone in ["radiance.exr", "radiance.png", "radiance-error.png"] {
        assert!(!dir.join(gone).exists(), "{gone} stayed");
    }
    assert_eq!(
        std::fs::read_to_string(dir.join("notes.txt")).unwrap(),
        "mine"
    );
    assert!(dir.join("pt.exr").is_file());
    std::fs::remove_dir_all(&dir).ok();
}

/// After every run the folder is a whole smaller study: an interrupted
/// study keeps the runs it finished, and `replot` reads the folder as it
/// stands.
#[test]
fn compare_writes_its_files_after_every_run() {
    let (dir, seen) = (temp("each-run"), temp("each-run-seen"));
    let worker = {
        let dir = dir.clone();
        std::thread::spawn(move || study(&dir, 0, 3, 0.2))
    };
    let summary = dir.join("summary.md");
    while !summary.exists() && !worker.is_finished() {
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    // A copy of the folder as the first run left it (each file is written
    // whole, so a copy never holds half of one).
    std::fs::create_dir_all(&seen).unwrap();
    for name in ["summary.md", "runs.csv", "curves.csv", "curves.svg"] {
        std::fs::copy(dir.join(name), seen.join(name)).unwrap();
    }
    let finished = worker.is_finished();
    worker.join().unwrap();
    assert!(!finished, "no file was written before the last run ended");
    let first = std::fs::read_to_string(seen.join("summary.md")).unwrap();
    assert!(first.contains("1 runs per method (seeds 1000)"), "{first}");
    assert!(rows_in(&seen).iter().all(|r| r.run == 0));
    assert!(costs_in(&seen).iter().all(|c| c.run == 0));
    ltcguide::experiment::replot::replot(&seen).unwrap();
    assert!(
        std::fs::read_to_string(seen.join("curves.svg"))
            .unwrap()
            .contains("(1 runs)")
    );
    assert_eq!(run_numbers_in(&dir), [0, 1, 2]);
    for d in [dir, seen] {
        std::fs::remove_dir_all(d).ok();
    }
}

fn run_numbers_in(dir: &Path) -> Vec<u32> {
    ltcguide::experiment::curves::run_numbers(&rows_in(dir))
}

/// The summary says the budget to 0.1 s; `merge` compares the exact one
/// each summary records, and folders made before the record under the old
/// rule.
#[test]
fn merge_compares_the_exact_budget_where_recorded() {
    let (a, b, out) = (temp("xa"), temp("xb"), temp("xout"));
    study(&a, 0, 1, 0.2);
    study(&b, 1, 1, 0.249);
    let err = merge(&out, &[a.clone(), b.clone()], false).unwrap_err();
    assert!(
        err.contains("differ in budget") && err.contains("0.249"),
        "{err}"
    );
    assert!(!out.exists());
    without_record(&b);
    merge(&out, &[a.clone(), b.clone()], false).unwrap();
    for d in [a, b, out] {
        std::fs::remove_dir_all(d).ok();
    }
}

/// Under `--clock cpu` a run's budget is per thread, so runs on another
/// thread count had other compute for the same budget: not pooled.
#[test]
fn merge_refuses_runs_on_other_threads() {
    let (a, b, out) = (temp("ta"), temp("tb"), temp("tout"));
    let opts = |dir: &Path, first_run, threads| CompareOptions {
        first_run,
        threads,
        use_plan: false,
        ..compare_options(vec![Method::Pt], dir)
    };
    run_compare(&tiny(), &flat_reference(), &opts(&a, 0, 1)).unwrap();
    run_compare(&tiny(), &flat_reference(), &opts(&b, 1, 2)).unwrap();
    let err = merge(&out, &[a.clone(), b.clone()], false).unwrap_err();
    assert!(err.contains("differ in threads or machine"), "{err}");
    assert!(!out.exists());
    for d in [a, b] {
        std::fs::remove_dir_all(d).ok();
    }
}

/// Studies measured against different references are not pooled; one that
/// never recorded its reference is, and the pooled summary says which
/// sources could not be checked.
#[test]
fn merge_refuses_studies_against_different_references() {
    let (a, b, out) = (temp("fa"), temp("fb"), temp("fout"));
    study(&a, 0, 1, 0.2);
    let other = ltcguide::film::image::Image {
        pixels: vec![glam::Vec3::splat(0.6); 64 * 64],
        ..flat_reference()
    };
    let opts = CompareOptions {
        first_run: 1,
        use_plan: false,
        ..compare_options(vec![Method::Pt, Method::Radiance], &b)
    };
    run_compare(&tiny(), &other, &opts).unwrap();
    let err = merge(&out, &[a.clone(), b.clone()], false).unwrap_err();
    assert!(err.contains("differ in reference"), "{err}");
    assert!(!out.exists());
    without_record(&b);
    let merged = merge(&out, &[a.clone(), b.clone()], false).unwrap();
    let note = format!("The reference could not be checked for `{}`", b.display());
    assert!(merged.summary.contains(&note), "{}", merged.summary);
    for d in [a, b, out] {
        std::fs::remove_dir_all(d).ok();
    }
}

/// `merge --out` into a folder holding another comparison (not a source,
/// not an earlier merge's output) is refused, that comparison untouched;
/// with `overwrite` its files give way to the pooled ones.
#[test]
fn merge_refuses_to_write_over_another_comparison() {
    let (a, b, other) = (temp("oa"), temp("ob"), temp("oother"));
    study(&a, 0, 1, 0.2);
    study(&b, 1, 1, 0.2);
    study(&other, 5, 1, 0.2);
    let names = file_names(&other);
    let before = std::fs::read_to_string(other.join("curves.csv")).unwrap();
    let err = merge(&other, &[a.clone(), b.clone()], false).unwrap_err();
    assert!(err.contains("already holds a comparison"), "{err}");
    assert_eq!(file_names(&other), names);
    assert_eq!(
        std::fs::read_to_string(other.join("curves.csv")).unwrap(),
        before
    );
    merge(&other, &[a.clone(), b.clone()], true).unwrap();
    assert_eq!(run_numbers_in(&other), [0, 1]);
    assert!(!other.join("pt.exr").exists());
    for d in [a, b, other] {
        std::fs::remove_dir_all(d).ok();
    }
}

/// With a run's rows taken out of its CSVs by hand, `replot` leaves no line
/// still counting it: the budget line and the final-errors table follow
/// the CSV as the curves and the cost section do.
#[test]
fn replot_counts_the_runs_the_csv_holds() {
    let dir = temp("cut");
    study(&dir, 0, 2, 0.2);
    for name in ["curves.csv", COST_CSV] {
        let text = std::fs::read_to_string(dir.join(name)).unwrap();
        let kept: String = text
            .lines()
            .filter(|l| l.split(',').nth(1) != Some("1"))
            .map(|l| format!("{l}\n"))
            .collect();
        std::fs::write(dir.join(name), kept).unwrap();
    }
    ltcguide::experiment::replot::replot(&dir).unwrap();
    let s = std::fs::read_to_string(dir.join("summary.md")).unwrap();
    assert!(s.contains("1 runs per method (seeds 1000)"), "{s}");
    assert!(!s.contains("2 runs"), "{s}");
    let rows = rows_in(&dir);
    for method in ["pt", "radiance"] {
        let last = rows.iter().rfind(|r| r.method == method).unwrap();
        let line = s
            .lines()
            .find(|l| l.starts_with(&format!("| {method} | ")))
            .unwrap();
        assert!(
            line.contains(&format!("| {:.4e} ± 0.0e0 |", last.relmse)),
            "{line}: one run's relMSE {}",
            last.relmse
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A library caller naming a method twice is refused before the folder is
/// made, as the command refuses it.
#[test]
fn run_compare_refuses_a_method_named_twice() {
    let dir = temp("twice");
    let opts = compare_options(vec![Method::Radiance, Method::Pt, Method::Radiance], &dir);
    match run_compare(&tiny(), &flat_reference(), &opts) {
        Err(err) => assert!(err.contains("radiance twice"), "{err}"),
        Ok(_) => panic!("a method named twice was compared"),
    }
    assert!(!dir.exists());
}
