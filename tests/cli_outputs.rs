//! `render` refuses what it could not finish before it renders: an output
//! path it cannot write, or an AOV the run will not have. Each case checks
//! the exit code, the one error line, and that no image was written (the
//! render did not run). Also what the CLI reports and writes: guards that
//! fired, EXR files reproducible byte for byte, and the scene's max depth.
//! `compare`'s and `error`'s refusals are in `cli_compare.rs`.

mod common;

use common::{default_scene, work_dir};
use std::path::Path;
use std::process::Command;

/// A mirror sphere under an area light: no vertex a guide could sample.
const DELTA_ONLY: &str = r#"<scene version="3.0.0">
	<sensor type="perspective">
		<float name="fov" value="45"/>
		<transform name="to_world"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
		<film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film>
	</sensor>
	<shape type="sphere"><bsdf type="conductor"/></shape>
	<shape type="rectangle">
		<transform name="to_world"><matrix value="1 0 0 0  0 -1 0 0  0 0 -1 3  0 0 0 1"/></transform>
		<bsdf type="conductor"/>
		<emitter type="area"><rgb name="radiance" value="1, 1, 1"/></emitter>
	</shape>
</scene>
"#;

/// Runs `render SCENE --spp 1 ARGS` and returns (exit code, stderr).
fn render(scene: &Path, args: &[&str]) -> (Option<i32>, String) {
    let run = Command::new(env!("CARGO_BIN_EXE_ltcguide"))
        .arg("render")
        .arg(scene)
        .args(["--spp", "1", "--threads", "1"])
        .args(args)
        .output()
        .unwrap();
    (
        run.status.code(),
        String::from_utf8_lossy(&run.stderr).into_owned(),
    )
}

/// Exit 2 with one error line containing `expect`, and no render: its
/// summary line ("… spp in … s") never printed, no file in `dir` but
/// `keep`.
fn assert_refused(code: Option<i32>, stderr: &str, expect: &str, dir: &Path, keep: &[&str]) {
    assert_eq!(code, Some(2), "{stderr}");
    let errors: Vec<&str> = stderr.lines().filter(|l| l.starts_with("error:")).collect();
    assert_eq!(errors.len(), 1, "{stderr}");
    assert!(errors[0].contains(expect), "{stderr}");
    assert!(
        !stderr.contains(" spp in "),
        "rendered before refusing: {stderr}"
    );
    let left: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| !keep.contains(&n.as_str()))
        .collect();
    assert!(left.is_empty(), "{left:?}");
}

#[test]
fn unwritable_outputs_are_refused_before_the_render() {
    let dir = work_dir("unwritable");
    std::fs::write(dir.join("file"), b"").unwrap();
    std::fs::create_dir(dir.join("dir.exr")).unwrap();
    let keep = ["file", "dir.exr"];
    let out = dir.join("o.exr");
    let out = out.to_str().unwrap();
    // The image's directory cannot be created (its parent is a file).
    let bad_dir = dir.join("file/o.exr");
    let (code, err) = render(&default_scene(), &["--out", bad_dir.to_str().unwrap()]);
    assert_refused(code, &err, "cannot create", &dir, &keep);
    // The image path is a directory.
    let as_dir = dir.join("dir.exr");
    let (code, err) = render(&default_scene(), &["--out", as_dir.to_str().unwrap()]);
    assert_refused(code, &err, "is a directory", &dir, &keep);
    // The statistics cannot be written: before, the image was written and
    // the run still failed at its end.
    let stats = dir.join("file/s.json");
    let args = ["--out", out, "--stats-json", stats.to_str().unwrap()];
    let (code, err) = render(&default_scene(), &args);
    assert_refused(code, &err, "cannot create", &dir, &keep);
    // A writable one in a directory still to be made is made and written.
    let stats = dir.join("new/s.json");
    let (code, err) = render(
        &default_scene(),
        &["--out", out, "--stats-json", stats.to_str().unwrap()],
    );
    assert_eq!(code, Some(0), "{err}");
    let json = std::fs::read_to_string(&stats).unwrap();
    assert!(json.contains("\"paths_per_second\""), "{json}");
    assert!(dir.join("o.exr").is_file() && dir.join("o.png").is_file());
    // No temporary file is left behind by the checks.
    let stray: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .chain(std::fs::read_dir(dir.join("new")).unwrap())
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".tmp"))
        .collect();
    assert!(stray.is_empty(), "{stray:?}");
    std::fs::remove_dir_all(&dir).ok();
}

/// Every file `render` writes is checked before it renders: two flags
/// naming one file (the statistics would replace the image or its preview,
/// and the summary line still named the image), and a preview or alpha AOV
/// that cannot be written (the image was written, then the run failed).
#[test]
fn outputs_naming_one_file_or_unwritable_previews_are_refused_before_the_render() {
    let dir = work_dir("distinct");
    let path = |name: &str| dir.join(name).to_str().unwrap().to_owned();
    let out = path("r.exr");
    for (stats, twin) in [
        (path("r.exr"), "--out"),
        (path("r.png"), "the PNG preview"),
        (
            format!("{}/./sub/../r.png", dir.display()),
            "the PNG preview",
        ),
    ] {
        let (code, err) = render(&default_scene(), &["--out", &out, "--stats-json", &stats]);
        assert_refused(
            code,
            &err,
            &format!("{twin} and --stats-json both name"),
            &dir,
            &[],
        );
    }
    std::fs::create_dir(dir.join("p.png")).unwrap();
    let (code, err) = render(&default_scene(), &["--out", &path("p.exr")]);
    assert_refused(code, &err, "is a directory", &dir, &["p.png"]);
    std::fs::create_dir(dir.join("a-alpha.png")).unwrap();
    let aov = [
        "--out",
        &path("a.exr"),
        "--method",
        "radiance",
        "--no-plan",
        "--aov",
        "alpha",
        "--stats-json",
        &path("a.json"),
    ];
    let (code, err) = render(&default_scene(), &aov);
    assert_refused(
        code,
        &err,
        "is a directory",
        &dir,
        &["p.png", "a-alpha.png"],
    );
    // The alpha AOV beside the image is also one of its names.
    let (code, err) = render(
        &default_scene(),
        &[
            "--out",
            &path("b.exr"),
            "--method",
            "radiance",
            "--no-plan",
            "--aov",
            "alpha",
        ]
        .into_iter()
        .chain(["--stats-json", &path("b-alpha.exr")])
        .collect::<Vec<_>>(),
    );
    assert_refused(
        code,
        &err,
        "the alpha AOV and --stats-json both name",
        &dir,
        &["p.png", "a-alpha.png"],
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn an_alpha_aov_without_guiding_is_refused_before_the_render() {
    let dir = work_dir("aov");
    let out = dir.join("o.exr");
    let out = out.to_str().unwrap();
    // Path tracing learns no α.
    let (code, err) = render(&default_scene(), &["--out", out, "--aov", "alpha"]);
    assert_refused(code, &err, "needs a guided method", &dir, &[]);
    // A guided method whose plan drops guiding (only delta materials).
    let scene = dir.join("delta.xml");
    std::fs::write(&scene, DELTA_ONLY).unwrap();
    let args = ["--out", out, "--aov", "alpha", "--method", "radiance"];
    let (code, err) = render(&scene, &args);
    assert_refused(code, &err, "only delta materials", &dir, &["delta.xml"]);
    // With guiding the AOV is written next to the image.
    let args = ["--out", out, "--aov", "alpha", "--method", "radiance"];
    let (code, err) = render(&default_scene(), &args);
    assert_eq!(code, Some(0), "{err}");
    assert!(dir.join("o-alpha.exr").is_file(), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

/// Argument errors come before the scene is read: a long load (the pack's
/// largest scenes take seconds) is not spent on a run that cannot start.
/// The scene path does not exist, so any error but the argument's own
/// means the scene was read first.
#[test]
fn bad_arguments_are_refused_before_the_scene_is_read() {
    let dir = work_dir("args");
    let missing = dir.join("no-such-scene.xml");
    let out = dir.join("o.exr");
    let out = out.to_str().unwrap();
    for (args, expect) in [
        (&["--bsdf-fraction", "2"][..], "--bsdf-fraction"),
        (&["--max-depth", "0"], "--max-depth"),
        (&["--spatial-threshold", "0"], "--spatial-threshold"),
        (&["--bsdf-fraction-l2=-1"], "--bsdf-fraction-l2"),
        (&["--bsdf-fraction-l2", "NaN"], "--bsdf-fraction-l2"),
        (
            &["--bsdf-fraction-l2", "0.1", "--bsdf-fraction", "0.5"],
            "--bsdf-fraction",
        ),
        (&["--adrrs-window", "0.5"], "--adrrs-window"),
        (&["--radiance-share", "1"], "--radiance-share"),
        (&["--radiance-share", "NaN"], "--radiance-share"),
        (
            &["--method", "product", "--guide-support", "hemisphere"],
            "--guide-support hemisphere applies to --method radiance",
        ),
        // Path tracing has no adjoint estimate: it ran with classic roulette.
        (&["--rr", "adrrs"], "--rr adrrs needs a guide"),
        // A clock is for a time budget; with --spp it would do nothing.
        (&["--clock", "cpu"], "--clock cpu"),
    ] {
        let (code, err) = render(&missing, &[&["--out", out][..], args].concat());
        assert_refused(code, &err, expect, &dir, &[]);
    }
    let (code, err) = render(&missing, &["--out", out, "--aov", "alpha"]);
    assert_refused(code, &err, "needs a guided method", &dir, &[]);
    let (code, err) = render(&missing, &["--out", dir.join("o.png").to_str().unwrap()]);
    assert_refused(code, &err, "--out must name an .exr file", &dir, &[]);
    // A good set of arguments reaches the scene, which is then missing.
    let (code, err) = render(&missing, &["--out", out]);
    assert_refused(code, &err, "no-such-scene.xml", &dir, &[]);
    std::fs::remove_dir_all(&dir).ok();
}

/// A constant emitter of radiance 3e38 around a small white square that
/// emits 3e38 too: the camera sees sky (samples of 3e38, two of which
/// overflowed an f32 sum) and the square, whose emission plus the sky it
/// reflects overflows to ∞, which the path guard zeroes and counts.
const OVERFLOWING: &str = r#"<scene version="3.0.0">
	<sensor type="perspective">
		<float name="fov" value="45"/>
		<transform name="to_world"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
		<film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film>
	</sensor>
	<shape type="rectangle">
		<bsdf type="diffuse"><rgb name="reflectance" value="1, 1, 1"/></bsdf>
		<emitter type="area"><rgb name="radiance" value="3e38, 3e38, 3e38"/></emitter>
	</shape>
	<emitter type="constant"><rgb name="radiance" value="3e38, 3e38, 3e38"/></emitter>
</scene>
"#;

/// Guards that fire are reported without --stats-json: a `guards:` line
/// on stdout naming the counters that fired, and a warning on stderr; a
/// render where none fires prints neither. The image stays finite.
#[test]
fn guards_that_fire_are_reported_by_render_and_compare() {
    let dir = work_dir("guards");
    let scene = dir.join("overflow.xml");
    std::fs::write(&scene, OVERFLOWING).unwrap();
    let out = dir.join("o.exr");
    let run = |scene: &Path| {
        Command::new(env!("CARGO_BIN_EXE_ltcguide"))
            .arg("render")
            .arg(scene)
            .args([
                "--spp",
                "2",
                "--threads",
                "1",
                "--out",
                out.to_str().unwrap(),
            ])
            .output()
            .unwrap()
    };
    let r = run(&scene);
    let (stdout, stderr) = (
        String::from_utf8_lossy(&r.stdout),
        String::from_utf8_lossy(&r.stderr),
    );
    assert_eq!(r.status.code(), Some(0), "{stderr}");
    let guards: Vec<&str> = stdout
        .lines()
        .filter(|l| l.starts_with("guards: "))
        .collect();
    assert_eq!(guards.len(), 1, "{stdout}");
    assert!(guards[0].contains("image_nonfinite_samples "), "{stdout}");
    // Only the counters that fired.
    assert!(!guards[0].contains(" 0"), "{stdout}");
    assert!(
        stderr
            .lines()
            .any(|l| l.starts_with("warning: ") && l.contains("guarded")),
        "{stderr}"
    );
    let image = ltcguide::film::exr_io::read_image(&out).unwrap();
    assert!(
        image.pixels.iter().all(|p| p.is_finite()),
        "{:?}",
        image.pixels
    );
    assert!(
        image.pixels.iter().any(|p| p.x > 1e38),
        "the sky is in the image"
    );
    let r = run(&default_scene());
    assert_eq!(r.status.code(), Some(0));
    assert!(!String::from_utf8_lossy(&r.stdout).contains("guards:"));
    assert!(!String::from_utf8_lossy(&r.stderr).contains("guarded"));

    // compare notes them in its summary.
    let reference = dir.join("ref.exr");
    ltcguide::film::exr_io::write_rgb(&reference, 8, 8, &[glam::Vec3::ONE; 64]).unwrap();
    let cmp = dir.join("cmp");
    let r = Command::new(env!("CARGO_BIN_EXE_ltcguide"))
        .arg("compare")
        .arg(&scene)
        .args(["--reference", reference.to_str().unwrap(), "--time", "0.2"])
        .args(["--runs", "1", "--methods", "pt", "--threads", "1"])
        .args(["--out", cmp.to_str().unwrap()])
        .output()
        .unwrap();
    assert_eq!(
        r.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&r.stderr)
    );
    let summary = std::fs::read_to_string(cmp.join("summary.md")).unwrap();
    let section = summary.split("## Guards").nth(1).expect(&summary);
    assert!(
        section.contains("- pt, seed 1000: image_nonfinite_samples "),
        "{summary}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// The same pixels always make the same EXR file, byte for byte, so a
/// checksum tells whether a render was reproduced. Compressed on several
/// threads, the blocks had been written in the order the threads finished
/// them; eight writes of a noisy image (40 blocks of different compressed
/// sizes) would then all have to finish alike.
#[test]
fn the_same_pixels_make_the_same_exr_file() {
    use ltcguide::film::exr_io::{read_image, write_rgb};
    let dir = work_dir("exr-bytes");
    let (w, h) = (320, 640);
    let mut rng = ltcguide::sampling::Rng::new(7, 0);
    let pixels: Vec<glam::Vec3> = (0..w * h)
        .map(|i| {
            // Smooth rows compress well, noisy ones do not: blocks of
            // different sizes take different times.
            let noise = if (i / w / 16) % 2 == 0 {
                0.0
            } else {
                rng.next_f32()
            };
            glam::Vec3::new(0.25 + noise, (i % w) as f32 / w as f32, 0.5)
        })
        .collect();
    let files: Vec<Vec<u8>> = (0..8)
        .map(|k| {
            let path = dir.join(format!("same-{k}.exr"));
            write_rgb(&path, w, h, &pixels).unwrap();
            std::fs::read(&path).unwrap()
        })
        .collect();
    for (k, f) in files.iter().enumerate().skip(1) {
        assert!(f == &files[0], "write {k} differs from write 0");
    }
    let back = read_image(&dir.join("same-0.exr")).unwrap();
    assert_eq!((back.width, back.height), (w, h));
    assert!(back.pixels.iter().zip(&pixels).all(|(a, b)| a == b));
    std::fs::remove_dir_all(&dir).ok();
}

/// `max_depth` as the scene format defines it: `-1` and a scene without the
/// element are unlimited, as in Mitsuba (both rendered at 10 segments), a
/// value is taken as it is, and `--max-depth` overrides the scene.
#[test]
fn the_scenes_max_depth_is_mitsubas() {
    let dir = work_dir("max-depth");
    let scene = |integrator: &str| {
        format!(
            r#"<scene version="3.0.0">{integrator}
	<sensor type="perspective">
		<float name="fov" value="45"/>
		<transform name="to_world"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
		<film type="hdrfilm"><integer name="width" value="4"/><integer name="height" value="4"/></film>
	</sensor>
	<shape type="sphere"><bsdf type="diffuse"/></shape>
	<emitter type="constant"><rgb name="radiance" value="1, 1, 1"/></emitter>
</scene>"#
        )
    };
    let depth = |n: &str| {
        format!(r#"<integrator type="path"><integer name="max_depth" value="{n}"/></integrator>"#)
    };
    for (name, integrator, args, expect) in [
        ("minus-one", depth("-1"), &[][..], "null"),
        ("missing", String::new(), &[], "null"),
        ("three", depth("3"), &[], "3"),
        ("override", depth("-1"), &["--max-depth", "5"], "5"),
    ] {
        let path = dir.join(format!("{name}.xml"));
        std::fs::write(&path, scene(&integrator)).unwrap();
        let (out, stats) = (
            dir.join(format!("{name}.exr")),
            dir.join(format!("{name}.json")),
        );
        let (code, err) = render(
            &path,
            &[
                &[
                    "--out",
                    out.to_str().unwrap(),
                    "--stats-json",
                    stats.to_str().unwrap(),
                ][..],
                args,
            ]
            .concat(),
        );
        assert_eq!(code, Some(0), "{name}: {err}");
        let json = std::fs::read_to_string(&stats).unwrap();
        assert!(
            json.contains(&format!("\"max_depth\": {expect}")),
            "{name}: {json}"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}
