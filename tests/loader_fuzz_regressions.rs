//! Inputs the `scene_loader` fuzz target (`fuzz/`) found crashing, replayed
//! with the same checks as the target, plus a readable case per root cause.

use ltcguide::math::Spectrum;
use ltcguide::scene::{SceneError, load_scene_from_str};
use std::path::{Path, PathBuf};

/// The fuzz target's work directory: the mesh part of the input as
/// `mesh.obj`, and the images seeds refer to.
fn work_dir(name: &str, obj: &[u8]) -> PathBuf {
    let dir =
        std::env::temp_dir().join(format!("ltcguide-fuzz-regr-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("mesh.obj"), obj).unwrap();
    let px = vec![Spectrum::new(0.25, 0.5, 0.75); 4];
    ltcguide::film::exr_io::write_rgb(&dir.join("tex.exr"), 2, 2, &px).unwrap();
    let nan = vec![Spectrum::splat(f32::NAN); 4];
    ltcguide::film::exr_io::write_rgb(&dir.join("nan.exr"), 2, 2, &nan).unwrap();
    let rgb: Vec<u8> = (0..12).map(|i| (i * 20) as u8).collect();
    ltcguide::film::png_io::write_png_rgb8(&dir.join("tex.png"), 2, 2, &rgb).unwrap();
    dir
}

/// Loads `xml` next to `obj` and checks what the fuzz target checks.
fn load(name: &str, xml: &str, obj: &[u8]) -> Result<(), SceneError> {
    let dir = work_dir(name, obj);
    let scene_path = dir.join("scene.xml");
    let result = load_scene_from_str(xml, &scene_path);
    std::fs::remove_dir_all(&dir).ok();
    match result {
        Ok(scene) => {
            let (lo, hi) = scene.bounds;
            assert!(lo.is_finite() && hi.is_finite(), "{name}: bounds {lo} {hi}");
            assert!(!scene.lights.lights.is_empty(), "{name}: no lights");
            Ok(())
        }
        Err(e) => {
            let text = e.to_string();
            assert_eq!(text.lines().count(), 1, "{name}: {text:?}");
            assert!(!text.contains('\r'), "{name}: {text:?}");
            assert!(!e.element.is_empty(), "{name}: {text}");
            let lines = if e.file == scene_path {
                xml.split('\n').count()
            } else {
                String::from_utf8_lossy(obj).split('\n').count()
            };
            assert!(
                e.line as usize <= lines,
                "{name}: line {} of {lines}",
                e.line
            );
            Err(e)
        }
    }
}

#[test]
fn every_fuzz_crash_input_now_loads_or_fails_cleanly() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/fuzz");
    let mut count = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let data = std::fs::read(&path).unwrap();
        let (xml, obj) = match data.iter().position(|&b| b == 0) {
            Some(i) => (&data[..i], &data[i + 1..]),
            None => (&data[..], &[][..]),
        };
        let xml = std::str::from_utf8(xml).expect("crash inputs have UTF-8 XML");
        let _ = load(&name, xml, obj);
        count += 1;
    }
    assert!(count > 0, "no crash inputs in {}", dir.display());
}

#[test]
fn a_carriage_return_quoted_by_the_xml_parser_stays_on_one_line() {
    let xml = "<scene version=\"3.0.0\">\n<integer name=\"a\" value=\"5\"/\r\r\n</scene>";
    let e = load("cr", xml, b"").unwrap_err();
    assert!(e.message.contains("malformed XML"), "{e}");
    assert_eq!(e.line, 2);
}

const HEAD: &str = r#"<scene version="3.0.0">
<sensor type="perspective"><float name="fov" value="40"/><film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film></sensor>
"#;
const LIGHT: &str = r#"<bsdf type="diffuse"/><emitter type="area"><rgb name="radiance" value="1, 1, 1"/></emitter>"#;

/// Finite numbers whose transformed geometry overflows f32 used to reach the
/// BVH build with infinite bounds and panic inside obvhs.
#[test]
fn geometry_beyond_the_coordinate_limit_is_a_located_error() {
    // Between the limit and where areas overflow: used to load with its light dropped.
    let big_obj = b"v 1e17 0 0\nv 0 1e17 0\nv 0 0 1e17\nf 1 2 3\n";
    let cases: [(&str, &str, &[u8]); 3] = [
        (
            "rectangle",
            r#"<transform name="to_world"><matrix value="0.5 0 0 0 0 3.4028235e38 0 -1 3 0 0.5 0 0 0 0 1"/></transform>"#,
            b"",
        ),
        (
            "sphere",
            r#"<point name="center" x="3e38"/><float name="radius" value="3e38"/>"#,
            b"",
        ),
        (
            "obj",
            r#"<string name="filename" value="mesh.obj"/><boolean name="face_normals" value="true"/>"#,
            big_obj,
        ),
    ];
    for (ty, props, obj) in cases {
        let xml = format!("{HEAD}<shape type=\"{ty}\">\n{props}{LIGHT}</shape>\n</scene>\n");
        let e = load(ty, &xml, obj).expect_err(ty);
        assert_eq!(e.line, 3, "{ty}: {e}");
        assert_eq!(e.element, format!("<shape type=\"{ty}\">"), "{e}");
        assert!(e.message.contains("coordinates too large"), "{ty}: {e}");
    }
}

/// Just inside the limit an emitting mesh keeps a finite area, so its light
/// is not silently dropped.
#[test]
fn geometry_inside_the_coordinate_limit_loads_with_its_light() {
    let obj = b"v 9e8 -9e8 0\nv -9e8 9e8 0\nv 0 0 9e8\nv 9e8 9e8 9e8\nf 1 2 3\nf 2 3 4\n";
    let xml = format!(
        "{HEAD}<shape type=\"obj\"><string name=\"filename\" value=\"mesh.obj\"/><boolean name=\"face_normals\" value=\"true\"/>{LIGHT}</shape>\n</scene>\n"
    );
    let dir = work_dir("inside", obj);
    let scene = load_scene_from_str(&xml, &dir.join("scene.xml")).expect("loads");
    std::fs::remove_dir_all(&dir).ok();
    assert_eq!(scene.lights.lights.len(), 1);
}
