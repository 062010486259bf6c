//! How the build holds the LTC kernels' 16 lanes (`src/ltc/lanes.rs`) is
//! named wherever a run's speed is reported, the host check behind
//! `render`'s note reads the processor right, and `merge` keeps runs of
//! different layouts apart: they compute the same images at different
//! speeds.

mod common;

use common::study::{compare_options, flat_reference, tiny};
use ltcguide::experiment::compare::{CompareOptions, run_compare};
use ltcguide::experiment::merge::merge;
use ltcguide::ltc::lanes::{LAYOUT, host_slows_under_512_bit_arithmetic, layout_note};
use ltcguide::render::{Budget, Method, RenderOptions, render};
use std::path::{Path, PathBuf};

fn temp(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("ltcguide-lanes-{name}-{}", std::process::id()))
}

/// CPUID's vendor and AVX-512 flag agree with the kernel's account of the
/// processor in /proc/cpuinfo, and the note is given exactly when the zmm
/// build runs product kernels on such a host.
#[test]
fn the_host_check_agrees_with_proc_cpuinfo() {
    let Ok(info) = std::fs::read_to_string("/proc/cpuinfo") else {
        eprintln!("skipped: this system has no /proc/cpuinfo to check CPUID against");
        return;
    };
    let field = |name: &str| {
        info.lines()
            .find(|l| l.starts_with(name))
            .and_then(|l| l.split(':').nth(1))
            .map_or(String::new(), |v| v.trim().to_string())
    };
    let intel = field("vendor_id") == "GenuineIntel";
    let avx512f = field("flags").split_whitespace().any(|f| f == "avx512f");
    assert_eq!(
        host_slows_under_512_bit_arithmetic(),
        intel && avx512f,
        "vendor_id {:?}, avx512f {avx512f}",
        field("vendor_id")
    );
    assert_eq!(
        layout_note(true).is_some(),
        intel && avx512f && LAYOUT == "zmm"
    );
    assert_eq!(layout_note(false), None);
}

/// The layout is the one the build's configuration implies, and a render's
/// statistics carry it into `--stats-json`.
#[test]
fn render_statistics_name_the_layout() {
    let expected = if cfg!(target_feature = "avx512f") {
        if cfg!(feature = "ymm-kernels") {
            "ymm-kernels"
        } else {
            "zmm"
        }
    } else if cfg!(target_feature = "avx2") {
        "avx2"
    } else {
        "portable"
    };
    assert_eq!(LAYOUT, expected);
    let opts = RenderOptions {
        method: Method::Product,
        budget: Budget::Spp(2),
        threads: 1,
        ..RenderOptions::default()
    };
    let stats = render(&tiny(), &opts).unwrap().stats;
    assert_eq!(stats.ltc_lanes, LAYOUT);
    let json = serde_json::to_value(&stats).unwrap();
    assert_eq!(json["ltc_lanes"], LAYOUT, "{json}");
}

/// `render` gives the note on a product render of a glossy scene exactly
/// when the host check says the zmm kernels slow it, and never for path
/// tracing.
#[test]
fn render_notes_the_build_to_use_where_zmm_slows_the_host() {
    let out = temp("note");
    std::fs::create_dir_all(&out).unwrap();
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-glossy");
    for (method, expected) in [("product", layout_note(true)), ("pt", None)] {
        let run = std::process::Command::new(env!("CARGO_BIN_EXE_ltcguide"))
            .arg("render")
            .arg(&scene)
            .args(["--spp", "1", "--threads", "1", "--method", method, "--out"])
            .arg(out.join(format!("{method}.exr")))
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(0), "{stderr}");
        let note = stderr
            .lines()
            .find(|l| l.contains("--features ymm-kernels"));
        assert_eq!(note, expected.as_deref(), "{method}: {stderr}");
    }
    std::fs::remove_dir_all(&out).ok();
}

fn settings_line(dir: &Path) -> String {
    std::fs::read_to_string(dir.join("summary.md"))
        .unwrap()
        .lines()
        .find(|l| l.starts_with("Path settings: "))
        .unwrap()
        .to_owned()
}

/// The product's settings name a ymm-kernels build, so `merge` refuses to
/// pool its runs with the default build's; runs of one build still pool.
#[test]
fn merge_keeps_runs_of_different_layouts_apart() {
    let [a, b, flipped, pooled, refused] = ["a", "b", "flipped", "pooled", "refused"].map(temp);
    for (dir, first_run) in [(&a, 0), (&b, 1)] {
        let opts = CompareOptions {
            first_run,
            use_plan: false,
            ..compare_options(vec![Method::Product], dir)
        };
        run_compare(&tiny(), &flat_reference(), &opts).unwrap();
    }
    const PHRASE: &str = ", LTC kernels in 256-bit halves (ymm-kernels build)";
    let line = settings_line(&b);
    assert_eq!(line.contains(PHRASE), LAYOUT == "ymm-kernels", "{line}");
    // Run b as the other layout's build would have written it.
    std::fs::create_dir_all(&flipped).unwrap();
    for entry in std::fs::read_dir(&b).unwrap() {
        let path = entry.unwrap().path();
        std::fs::copy(&path, flipped.join(path.file_name().unwrap())).unwrap();
    }
    let summary = std::fs::read_to_string(flipped.join("summary.md")).unwrap();
    let other = if line.contains(PHRASE) {
        line.replace(PHRASE, "")
    } else {
        line.replace(
            "cosine lobes: radiance",
            &format!("cosine lobes: radiance{PHRASE}"),
        )
    };
    assert_ne!(other, line);
    std::fs::write(flipped.join("summary.md"), summary.replace(&line, &other)).unwrap();
    merge(&pooled, &[a.clone(), b.clone()], false).unwrap();
    let err = merge(&refused, &[a.clone(), flipped.clone()], false).unwrap_err();
    assert!(err.contains("differ in"), "{err}");
    assert!(!refused.exists());
    for dir in [a, b, flipped, pooled] {
        std::fs::remove_dir_all(dir).ok();
    }
}
