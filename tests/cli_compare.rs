//! `error` and `compare` refuse what they could not finish before they
//! render: an image with a NaN, Inf or negative pixel, an output that
//! would overwrite the reference or cannot be written, and a method named
//! twice. Each case checks the exit code and the one error line.

mod common;

use common::{default_scene, work_dir};
use std::path::Path;
use std::process::Command;

/// `error` and `compare` refuse an image with a NaN, Inf or negative
/// pixel (relMSE would be NaN): exit 2, one error line naming the file
/// and the first bad pixel; compare before it renders anything.
#[test]
fn images_with_non_finite_or_negative_pixels_are_refused() {
    use ltcguide::film::exr_io::write_rgb;
    let dir = work_dir("badref");
    let good = dir.join("good.exr");
    write_rgb(&good, 8, 8, &[glam::Vec3::splat(0.5); 64]).unwrap();
    let bin = env!("CARGO_BIN_EXE_ltcguide");
    let run = |args: &[&std::ffi::OsStr]| {
        let r = Command::new(bin).args(args).output().unwrap();
        let stdout = String::from_utf8_lossy(&r.stdout).into_owned();
        (
            r.status.code(),
            stdout,
            String::from_utf8_lossy(&r.stderr).into_owned(),
        )
    };
    let (code, stdout, err) = run(&["error".as_ref(), good.as_ref(), good.as_ref()]);
    assert_eq!(code, Some(0), "{err}");
    assert!(stdout.contains("relmse 0.000000e0"), "{stdout}");
    // 8×8 pixels hold no 16×16 block: the metrics stand, the bias line says why it is missing.
    assert!(
        stdout.contains("mean_ratio not computed: a 8×8 image holds 0 whole blocks"),
        "{stdout}"
    );
    // An 8×8 data window at (4, 4) of a 16×16 frame: read from the origin,
    // its pixels met the wrong ones of an 8×8 reference, and MAE was 0.
    {
        use exr::prelude::*;
        let attributes = LayerAttributes {
            layer_position: Vec2(4, 4),
            ..LayerAttributes::default()
        };
        let channels = SpecificChannels::rgb(|_: Vec2<usize>| (0.5f32, 0.5f32, 0.5f32));
        let layer = Layer::new((8, 8), attributes, Encoding::UNCOMPRESSED, channels);
        let mut image = Image::from_layer(layer);
        image.attributes.display_window = IntegerBounds::new((0, 0), (16, 16));
        image.write().to_file(dir.join("window.exr")).unwrap();
    }
    let window = dir.join("window.exr");
    let (code, stdout, err) = run(&["error".as_ref(), window.as_ref(), good.as_ref()]);
    assert_eq!(code, Some(2), "{stdout}");
    assert!(
        err.contains("holds pixels (4, 4)–(11, 11) of a 16×16 frame"),
        "{err}"
    );
    // One pixel has no worst 0.1 %: the other metrics stand and the run
    // succeeds (it printed them, then failed).
    let one = dir.join("one.exr");
    write_rgb(&one, 1, 1, &[glam::Vec3::splat(0.5)]).unwrap();
    let (code, stdout, err) = run(&["error".as_ref(), one.as_ref(), one.as_ref()]);
    assert_eq!(code, Some(0), "{err}");
    assert!(
        stdout.contains("relmse 0.000000e0")
            && stdout.contains("relmse_worst_0.1% not computed: an image of one pixel has no tail")
            && stdout.contains("mean_ratio not computed"),
        "{stdout}"
    );
    // 64×64 pixels hold 16 blocks: equal images have ratio 1 and z 0; a
    // noiseless image 10 % brighter has ratio 1.1 and no noise to hide it.
    let big = dir.join("big.exr");
    let brighter = dir.join("brighter.exr");
    write_rgb(&big, 64, 64, &[glam::Vec3::splat(0.5); 64 * 64]).unwrap();
    write_rgb(&brighter, 64, 64, &[glam::Vec3::splat(0.55); 64 * 64]).unwrap();
    let (code, stdout, err) = run(&["error".as_ref(), big.as_ref(), big.as_ref()]);
    assert_eq!(code, Some(0), "{err}");
    assert!(stdout.contains("mean_ratio 1.00000 ("), "{stdout}");
    assert!(
        stdout.contains("z +0.00, 16 blocks of 16×16 pixels"),
        "{stdout}"
    );
    let (code, stdout, err) = run(&["error".as_ref(), brighter.as_ref(), big.as_ref()]);
    assert_eq!(code, Some(0), "{err}");
    assert!(stdout.contains("mean_ratio 1.10000 ("), "{stdout}");
    assert!(stdout.contains("z +inf"), "{stdout}");
    for (name, value) in [("nan", f32::NAN), ("inf", f32::INFINITY), ("neg", -1.0)] {
        let mut pixels = vec![glam::Vec3::splat(0.5); 64];
        // Pixel (3, 1), and a later one: the first is named.
        pixels[8 + 3].y = value;
        pixels[40] = glam::Vec3::splat(value);
        let bad = dir.join(format!("{name}.exr"));
        write_rgb(&bad, 8, 8, &pixels).unwrap();
        for args in [
            [good.as_path(), bad.as_path()],
            [bad.as_path(), good.as_path()],
        ] {
            let (code, _, err) = run(&["error".as_ref(), args[0].as_ref(), args[1].as_ref()]);
            assert_eq!(code, Some(2), "{err}");
            let errors: Vec<&str> = err.lines().filter(|l| l.starts_with("error:")).collect();
            assert_eq!(errors.len(), 1, "{err}");
            assert!(errors[0].contains(&format!("{name}.exr")), "{err}");
            assert!(
                errors[0].contains("(3, 1)") && errors[0].contains("2 pixels"),
                "{err}"
            );
        }
        let out = dir.join(format!("cmp-{name}"));
        let (code, _, err) = run(&[
            "compare".as_ref(),
            default_scene().as_os_str(),
            "--reference".as_ref(),
            bad.as_os_str(),
            "--time".as_ref(),
            "1".as_ref(),
            "--out".as_ref(),
            out.as_os_str(),
        ]);
        assert_eq!(code, Some(2), "{err}");
        let errors: Vec<&str> = err.lines().filter(|l| l.starts_with("error:")).collect();
        assert_eq!(errors.len(), 1, "{err}");
        assert!(
            errors[0].contains(&format!("{name}.exr")) && errors[0].contains("(3, 1)"),
            "{err}"
        );
        assert!(
            !err.contains("compare: ") && !out.exists(),
            "rendered first: {err}"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Runs `compare` on the tiny analytic scene for one run of 0.1 s with
/// `args`, and returns (exit code, stderr).
fn compare(args: &[&std::ffi::OsStr]) -> (Option<i32>, String) {
    let run = Command::new(env!("CARGO_BIN_EXE_ltcguide"))
        .args(["compare", "tests/data/analytic/sphere_over_plane.xml"])
        .args(["--time", "0.1", "--runs", "1", "--threads", "1"])
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    (
        run.status.code(),
        String::from_utf8_lossy(&run.stderr).into_owned(),
    )
}

/// `compare` of path tracing alone against `reference` into `out`, with
/// `extra` flags.
fn compare_pt(reference: &Path, out: &Path, extra: &[&str]) -> (Option<i32>, String) {
    use std::ffi::OsStr;
    let mut args: Vec<&OsStr> = vec![
        "--reference".as_ref(),
        reference.as_os_str(),
        "--methods".as_ref(),
        "pt".as_ref(),
    ];
    args.extend(extra.iter().map(OsStr::new));
    args.extend([OsStr::new("--out"), out.as_os_str()]);
    compare(&args)
}

/// A uniform 64×64 reference (the tiny scene's size) at `path`.
fn write_reference(path: &Path) {
    let pixels = vec![glam::Vec3::splat(0.5); 64 * 64];
    ltcguide::film::exr_io::write_rgb(path, 64, 64, &pixels).unwrap();
}

/// `compare` never writes over or removes its own reference, whatever
/// --overwrite says and however the paths are spelt; it refuses before it
/// renders.
#[test]
fn compare_refuses_to_write_over_its_reference() {
    let dir = work_dir("own-reference");
    let (reference, cmp) = (dir.join("ref.exr"), dir.join("cmpR"));
    write_reference(&reference);
    let (code, err) = compare_pt(&reference, &cmp, &[]);
    assert_eq!(code, Some(0), "{err}");
    // The folder now holds a comparison: a second one is refused unless
    // told to overwrite, which `scripts/results.sh` relies on.
    let again = |extra: &[&str]| compare_pt(&reference, &cmp, extra);
    let summary = std::fs::read(cmp.join("summary.md")).unwrap();
    let (code, err) = again(&[]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("already holds a comparison") && err.contains("--overwrite"),
        "{err}"
    );
    assert_eq!(std::fs::read(cmp.join("summary.md")).unwrap(), summary);
    let (code, err) = again(&["--overwrite"]);
    assert_eq!(code, Some(0), "{err}");
    std::fs::copy(&reference, cmp.join("radiance.exr")).unwrap();
    let respelt = dir.join("cmpR/../cmpR");
    for own in ["pt.exr", "radiance.exr"] {
        let bytes = std::fs::read(cmp.join(own)).unwrap();
        let (code, err) = compare_pt(&cmp.join(own), &respelt, &["--overwrite"]);
        assert_eq!(code, Some(2), "{own}: {err}");
        assert!(err.contains("the reference") && err.contains(own), "{err}");
        assert!(!err.contains("compare: pt, run"), "rendered first: {err}");
        assert_eq!(std::fs::read(cmp.join(own)).unwrap(), bytes, "{own}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A method named twice would count each of its runs twice: refused before
/// the scene is read.
#[test]
fn compare_refuses_a_method_named_twice() {
    let dir = work_dir("twice");
    let out = dir.join("cmp");
    let run = Command::new(env!("CARGO_BIN_EXE_ltcguide"))
        .args(["compare", "no-such-scene.xml", "--reference", "no.exr"])
        .args(["--time", "0.1", "--methods", "pt,radiance,pt", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(2), "{err}");
    assert!(err.contains("pt twice"), "{err}");
    assert!(!out.exists());
    assert!(!out.exists());
    std::fs::remove_dir_all(&dir).ok();
}

/// Every file `compare` will write is checked before the first run: a
/// summary path that is a directory fails at once, not after every run.
#[test]
fn compare_checks_its_outputs_before_the_first_run() {
    let dir = work_dir("compare-unwritable");
    let reference = dir.join("ref.exr");
    write_reference(&reference);
    for blocked in ["summary.md", "curves.csv", "pt-error.png"] {
        let out = dir.join(format!("cmp-{blocked}"));
        std::fs::create_dir_all(out.join(blocked)).unwrap();
        let (code, err) = compare_pt(&reference, &out, &[]);
        assert_eq!(code, Some(2), "{blocked}: {err}");
        assert!(
            err.contains("is a directory") && err.contains(blocked),
            "{err}"
        );
        assert!(!err.contains("compare: pt, run"), "rendered first: {err}");
        let left: Vec<_> = std::fs::read_dir(&out).unwrap().collect();
        assert_eq!(left.len(), 1, "{blocked}: {left:?}");
    }
    std::fs::remove_dir_all(&dir).ok();
}
