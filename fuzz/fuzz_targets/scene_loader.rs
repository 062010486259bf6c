//! Fuzzes `ltcguide::scene::load_scene_from_str` on an XML scene plus the OBJ
//! mesh it may reference.
//!
//! Input layout: `XML bytes [0x00 OBJ bytes]`. A NUL can never occur in a
//! well-formed XML document, so the split costs the fuzzer nothing. The OBJ
//! part is written to `mesh.obj` in a per-process directory that also holds
//! small valid images (`tex.png`, `tex.exr`) and one with NaN pixels
//! (`nan.exr`), so `filename` properties in seeds resolve and the mutator
//! reaches the mesh, texture and envmap code instead of stopping at "file
//! not found".
//!
//! Beyond "no panic", the target checks the loader's promises: an error is
//! one line naming a file, a line within that file and an element, and a
//! scene that loads has finite bounds and at least one light.
#![no_main]

use libfuzzer_sys::fuzz_target;
use ltcguide::math::Spectrum;
use ltcguide::scene::{SceneError, load_scene_from_str};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

fn work_dir() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        // Per process, so parallel jobs (`-jobs`/`-fork`) do not race on mesh.obj.
        let dir = std::env::temp_dir().join(format!("ltcguide-fuzz-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("create the fuzz work directory");
        let px = vec![Spectrum::new(0.25, 0.5, 0.75); 4];
        ltcguide::film::exr_io::write_rgb(&dir.join("tex.exr"), 2, 2, &px).expect("tex.exr");
        let nan = vec![Spectrum::splat(f32::NAN); 4];
        ltcguide::film::exr_io::write_rgb(&dir.join("nan.exr"), 2, 2, &nan).expect("nan.exr");
        let rgb: Vec<u8> = (0..12).map(|i| (i * 20) as u8).collect();
        ltcguide::film::png_io::write_png_rgb8(&dir.join("tex.png"), 2, 2, &rgb).expect("tex.png");
        dir
    })
}

/// Lines an editor can show: a position just after a final newline is on
/// the (empty) line after the last one.
fn line_count(text: &str) -> u32 {
    text.split('\n').count() as u32
}

fn check_error(err: &SceneError, scene: &Path, xml: &str, obj: &[u8]) {
    let text = err.to_string();
    assert!(
        !text.contains('\n') && !text.contains('\r'),
        "error is not one line: {text:?}"
    );
    assert!(!err.element.is_empty(), "error names no element: {text}");
    assert!(
        !err.file.as_os_str().is_empty(),
        "error names no file: {text}"
    );
    // Only the scene and its mesh are ever read as text, so any other file
    // named by an error is the mesh under a different relative spelling.
    let lines = if err.file == scene {
        line_count(xml)
    } else {
        line_count(&String::from_utf8_lossy(obj))
    };
    assert!(
        err.line <= lines,
        "error line {} beyond the {lines} lines of {}: {text}",
        err.line,
        err.file.display()
    );
}

fuzz_target!(|data: &[u8]| {
    let (xml, obj) = match data.iter().position(|&b| b == 0) {
        Some(i) => (&data[..i], &data[i + 1..]),
        None => (data, &[][..]),
    };
    // `load_scene` rejects non-UTF-8 files before parsing; nothing to reach here.
    let Ok(xml) = std::str::from_utf8(xml) else {
        return;
    };
    let dir = work_dir();
    std::fs::write(dir.join("mesh.obj"), obj).expect("write mesh.obj");
    let scene_path = dir.join("scene.xml");
    match load_scene_from_str(xml, &scene_path) {
        Ok(scene) => {
            let (lo, hi) = scene.bounds;
            assert!(
                lo.is_finite() && hi.is_finite(),
                "scene loaded with non-finite bounds {lo:?} {hi:?}"
            );
            // A scene without emitters is rejected, so none may vanish later.
            assert!(
                !scene.lights.lights.is_empty(),
                "scene loaded without lights"
            );
        }
        Err(e) => check_error(&e, &scene_path, xml, obj),
    }
});
