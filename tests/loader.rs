//! Scene loading: every supported element loads, every kind of bad input is
//! rejected with one clear line naming file, line and element, exit code 2,
//! no panic and no output file.

use ltcguide::scene::{load_scene, load_scene_from_str};
use std::path::{Path, PathBuf};
use std::process::Command;

fn data(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(p)
}

/// (file, the file the error must name, its line, a phrase of the reason)
const BAD: &[(&str, &str, u32, &str)] = &[
    (
        "bad_integer.xml",
        "bad_integer.xml",
        12,
        "is not an integer",
    ),
    ("bad_rgb.xml", "bad_rgb.xml", 21, "needs 3 numbers"),
    ("bad_root.xml", "bad_root.xml", 2, "root element"),
    (
        "beckmann.xml",
        "beckmann.xml",
        25,
        "unsupported microfacet distribution",
    ),
    ("corrupt_exr.xml", "corrupt_exr.xml", 27, "cannot read EXR"),
    ("empty_scene.xml", "empty_scene.xml", 2, "no <sensor>"),
    (
        "missing_attribute.xml",
        "missing_attribute.xml",
        7,
        "missing attribute 'value'",
    ),
    (
        "missing_mesh.xml",
        "missing_mesh.xml",
        24,
        "mesh file not found",
    ),
    (
        "missing_texture.xml",
        "missing_texture.xml",
        25,
        "file not found",
    ),
    ("nan_number.xml", "nan_number.xml", 7, "non-finite number"),
    (
        "negative_number.xml",
        "negative_number.xml",
        21,
        "must not be negative",
    ),
    (
        "negative_radius.xml",
        "negative_radius.xml",
        23,
        "radius must be positive",
    ),
    ("no_camera.xml", "no_camera.xml", 2, "no <sensor>"),
    ("no_emitter.xml", "no_emitter.xml", 2, "no emitter"),
    ("obj_degenerate.xml", "degenerate.obj", 5, "zero-area"),
    (
        "obj_index_out_of_range.xml",
        "out_of_range.obj",
        4,
        "out of range",
    ),
    ("obj_nan.xml", "nan.obj", 2, "non-finite"),
    (
        "singular_transform.xml",
        "singular_transform.xml",
        18,
        "singular",
    ),
    ("truncated.xml", "truncated.xml", 16, "malformed XML"),
    (
        "unknown_element.xml",
        "unknown_element.xml",
        27,
        "unsupported element",
    ),
    ("unknown_ref.xml", "unknown_ref.xml", 25, "unknown bsdf id"),
    (
        "unsupported_plugin.xml",
        "unsupported_plugin.xml",
        25,
        "unsupported bsdf type",
    ),
    ("wrong_type.xml", "wrong_type.xml", 7, "must be <float>"),
    (
        "conductor_missing_k.xml",
        "conductor_missing_k.xml",
        25,
        "needs both 'eta' and 'k'",
    ),
    (
        "twosided_two_children.xml",
        "twosided_two_children.xml",
        25,
        "exactly one inline",
    ),
    (
        "twosided_dielectric.xml",
        "twosided_dielectric.xml",
        25,
        "cannot wrap a dielectric",
    ),
    (
        "two_sensors.xml",
        "two_sensors.xml",
        27,
        "more than one <sensor>",
    ),
    ("bad_fov.xml", "bad_fov.xml", 6, "fov must be in"),
    (
        "bad_fov_axis.xml",
        "bad_fov_axis.xml",
        7,
        "unknown fov_axis",
    ),
    ("zero_film.xml", "zero_film.xml", 11, "out of range"),
    (
        "shape_without_bsdf.xml",
        "shape_without_bsdf.xml",
        23,
        "needs a bsdf",
    ),
    (
        "area_at_top_level.xml",
        "area_at_top_level.xml",
        27,
        "must be nested in a shape",
    ),
    (
        "unsupported_shape.xml",
        "unsupported_shape.xml",
        23,
        "unsupported shape type",
    ),
    (
        "nonlinear_plastic.xml",
        "nonlinear_plastic.xml",
        25,
        "nonlinear=true",
    ),
    (
        "negative_envmap_scale.xml",
        "negative_envmap_scale.xml",
        27,
        "scale must not be negative",
    ),
    (
        "unsupported_texture.xml",
        "unsupported_texture.xml",
        25,
        "unsupported texture type",
    ),
    (
        "duplicate_bsdf_id.xml",
        "duplicate_bsdf_id.xml",
        28,
        "duplicate bsdf id",
    ),
    ("zero_ior.xml", "zero_ior.xml", 25, "IORs must be positive"),
    (
        "two_emitters_on_shape.xml",
        "two_emitters_on_shape.xml",
        21,
        "at most one emitter",
    ),
    (
        "unexpected_in_bsdf.xml",
        "unexpected_in_bsdf.xml",
        25,
        "inside a bsdf",
    ),
    ("anisotropic.xml", "anisotropic.xml", 25, "anisotropic"),
    (
        "checker_rotate.xml",
        "checker_rotate.xml",
        25,
        "must be a <scale>",
    ),
    (
        "film_type.xml",
        "film_type.xml",
        11,
        "unsupported film type",
    ),
    (
        "sensor_type.xml",
        "sensor_type.xml",
        6,
        "unsupported sensor type",
    ),
    (
        "unexpected_in_shape.xml",
        "unexpected_in_shape.xml",
        25,
        "inside a shape",
    ),
    (
        "unexpected_in_sensor.xml",
        "unexpected_in_sensor.xml",
        11,
        "in <sensor>",
    ),
    (
        "two_integrators.xml",
        "two_integrators.xml",
        27,
        "more than one <integrator>",
    ),
    (
        "bad_max_depth.xml",
        "bad_max_depth.xml",
        3,
        "max_depth must be",
    ),
    (
        "bad_boolean.xml",
        "bad_boolean.xml",
        24,
        "'true' or 'false'",
    ),
    (
        "constant_no_radiance.xml",
        "constant_no_radiance.xml",
        27,
        "needs 'radiance'",
    ),
    (
        "bsdf_without_id.xml",
        "bsdf_without_id.xml",
        27,
        "missing attribute 'id'",
    ),
    ("bad_lookat.xml", "bad_lookat.xml", 9, "degenerate lookat"),
    ("no_fov.xml", "no_fov.xml", 6, "needs 'fov'"),
    (
        "rotate_not_unit.xml",
        "rotate_not_unit.xml",
        23,
        "unit length",
    ),
    (
        "matrix_last_row.xml",
        "matrix_last_row.xml",
        23,
        "last row of a matrix must be 0 0 0 1",
    ),
    (
        "duplicate_property.xml",
        "duplicate_property.xml",
        23,
        "given twice",
    ),
    (
        "nameless_property.xml",
        "nameless_property.xml",
        23,
        "missing attribute 'name'",
    ),
    ("two_films.xml", "two_films.xml", 14, "more than one <film>"),
    (
        "point_value.xml",
        "point_value.xml",
        23,
        "attribute 'value' is not part",
    ),
    (
        "scale_value.xml",
        "scale_value.xml",
        23,
        "attribute 'value' is not part",
    ),
    (
        "unknown_attribute.xml",
        "unknown_attribute.xml",
        23,
        "attribute 'units'",
    ),
    (
        "emitter_child.xml",
        "emitter_child.xml",
        23,
        "inside an emitter",
    ),
    (
        "envmap_child.xml",
        "envmap_child.xml",
        23,
        "inside an emitter",
    ),
    (
        "integrator_child.xml",
        "integrator_child.xml",
        4,
        "inside an integrator",
    ),
    (
        "texture_child.xml",
        "texture_child.xml",
        23,
        "inside a texture",
    ),
    ("film_child.xml", "film_child.xml", 13, "inside a film"),
    (
        "sampler_child.xml",
        "sampler_child.xml",
        14,
        "inside a sampler",
    ),
    (
        "obj_flattened.xml",
        "obj_flattened.xml",
        23,
        "zero area in world space",
    ),
    (
        "obj_mixed_vt.xml",
        "mixed_vt.obj",
        15,
        "with texture coordinates",
    ),
    (
        "obj_vn_unindexed.xml",
        "vn_unindexed.obj",
        8,
        "no normal indices",
    ),
    (
        "checker_matrix.xml",
        "checker_matrix.xml",
        23,
        "pure 2D scale",
    ),
    ("envmap_png.xml", "envmap_png.xml", 23, "must be an EXR"),
    (
        "empty_list_entry.xml",
        "empty_list_entry.xml",
        23,
        "empty entry",
    ),
    (
        "sensor_scale.xml",
        "sensor_scale.xml",
        9,
        "'to_world' must be a <matrix> or <lookat> or <rotate>, not <scale>",
    ),
    ("obj_no_normals.xml", "tiny.obj", 5, "needs vn normals"),
    ("obj_statement.xml", "polyline.obj", 7, "'l' statements"),
];

#[test]
fn every_bad_input_is_a_located_error() {
    for &(file, named, line, phrase) in BAD {
        let err = match load_scene(&data(&format!("bad/{file}"))) {
            Ok(_) => panic!("{file} loaded but is bad input"),
            Err(e) => e,
        };
        let text = err.to_string();
        assert!(
            !text.contains('\n'),
            "{file}: message must be one line: {text}"
        );
        assert!(
            err.file.ends_with(named),
            "{file}: names {:?}, expected {named}",
            err.file
        );
        assert_eq!(err.line, line, "{file}: {text}");
        assert!(!err.element.is_empty(), "{file}: no element in {text}");
        assert!(text.contains(phrase), "{file}: '{phrase}' not in {text}");
    }
}

#[test]
fn the_cli_exits_2_without_panic_or_output_on_bad_input() {
    let out_dir = std::env::temp_dir().join(format!("ltcguide-bad-{}", std::process::id()));
    std::fs::create_dir_all(&out_dir).unwrap();
    for &(file, named, line, _) in BAD {
        let out = out_dir.join("x.exr");
        let run = Command::new(env!("CARGO_BIN_EXE_ltcguide"))
            .args([
                "render",
                data(&format!("bad/{file}")).to_str().unwrap(),
                "--spp",
                "1",
                "--out",
            ])
            .arg(&out)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(2), "{file}: {stderr}");
        assert!(!stderr.contains("panicked"), "{file}: {stderr}");
        let errors: Vec<&str> = stderr.lines().filter(|l| l.starts_with("error:")).collect();
        assert_eq!(errors.len(), 1, "{file}: {stderr}");
        assert!(
            errors[0].contains(&format!("{named}:{line}:")),
            "{file}: {stderr}"
        );
        assert!(
            !out.exists() && !out.with_extension("png").exists(),
            "{file} left an output file"
        );
        let leftovers = std::fs::read_dir(&out_dir).unwrap().count();
        assert_eq!(leftovers, 0, "{file} left temporary files");
    }
    std::fs::remove_dir_all(&out_dir).ok();
}

#[test]
fn a_bad_cli_argument_is_a_clap_error() {
    let run = Command::new(env!("CARGO_BIN_EXE_ltcguide"))
        .args(["render", "--spp", "many"])
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&run.stderr).contains("invalid value"));
}

/// Output piped into a reader that closes early (`| head -1`): the CLI
/// ends quietly (killed by SIGPIPE, as Unix tools are) instead of
/// panicking in println! with a backtrace.
#[test]
fn a_closed_output_pipe_is_not_a_panic() {
    let mut child = Command::new(env!("CARGO_BIN_EXE_ltcguide"))
        .args(["info", data("ok/all_elements.xml").to_str().unwrap()])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Closed before the scene has loaded, so every line meets a closed pipe.
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_ne!(out.status.code(), Some(101), "{stderr}");
}

#[test]
fn every_supported_element_loads() {
    let scene = load_scene(&data("ok/all_elements.xml")).expect("loads");
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    assert_eq!(scene.camera.width, 32);
    assert_eq!(scene.max_depth, Some(5));
    // rectangle (2) + 2 quads (2 each) + cube (12) triangles, 4 spheres
    assert_eq!(scene.triangle_count(), 2 + 4 + 12);
    assert_eq!(scene.geometry.len(), 18 + 4);
    // area light + constant
    assert_eq!(scene.lights.lights.len(), 2);
    assert!(scene.lights.has_infinite());
    // 7 named + 1 inline black + 0: the light's inline bsdf
    assert_eq!(scene.materials.len(), 8);
    assert!(scene.materials[0].two_sided);
}

#[test]
fn an_ignorable_element_is_a_warning() {
    let scene = load_scene(&data("ok/ignored_integrator.xml")).expect("loads");
    assert_eq!(scene.warnings.len(), 1, "{:?}", scene.warnings);
    assert!(scene.warnings[0].contains("volpath"));
    assert!(scene.warnings[0].contains("ignored_integrator.xml:3:"));
    // Another sampler changes the noise, not the image: a warning too.
    let text = std::fs::read_to_string(data("ok/other_sampler.xml")).unwrap();
    let scene = load_scene_from_str(&text, &data("ok/other_sampler.xml")).expect("loads");
    assert!(
        scene
            .warnings
            .iter()
            .any(|w| w.contains("sampler type 'stratified' ignored")),
        "{:?}",
        scene.warnings
    );
}

#[test]
fn loading_from_a_string_is_loading_the_file_it_names() {
    let path = data("ok/all_elements.xml");
    let text = std::fs::read_to_string(&path).unwrap();
    let (a, b) = (
        load_scene(&path).unwrap(),
        load_scene_from_str(&text, &path).unwrap(),
    );
    assert_eq!(a.name, b.name);
    assert_eq!(a.geometry.len(), b.geometry.len());
    assert_eq!(a.lights.lights.len(), b.lights.lights.len());
    assert_eq!(a.materials.len(), b.materials.len());
    // Meshes resolve against the folder of the given path, and errors name it.
    let elsewhere = Path::new("/nonexistent-ltcguide/x.xml");
    let Err(err) = load_scene_from_str(&text, elsewhere) else {
        panic!("loaded with its mesh missing");
    };
    assert_eq!(err.file, elsewhere);
    assert!(err.message.contains("mesh file not found"), "{err}");
}

/// A folder stands for its `scene.xml` (the pack's layout), through the
/// library and the CLI; a folder without one is the usual read error,
/// naming the file that was looked for.
#[test]
fn a_scene_folder_loads_its_scene_xml() {
    let folder = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-glossy");
    let (a, b) = (
        load_scene(&folder).expect("the folder loads"),
        load_scene(&folder.join("scene.xml")).unwrap(),
    );
    assert_eq!(a.file, b.file);
    assert_eq!(a.name, "cornell-glossy");
    assert_eq!(a.geometry.len(), b.geometry.len());
    let empty = std::env::temp_dir().join(format!("ltcguide-empty-{}", std::process::id()));
    std::fs::create_dir_all(&empty).unwrap();
    let result = load_scene(&empty);
    std::fs::remove_dir(&empty).unwrap();
    let Err(err) = result else {
        panic!("a folder without scene.xml loaded");
    };
    assert_eq!(err.file, empty.join("scene.xml"));
    assert!(err.message.contains("cannot read scene file"), "{err}");
    let out = Command::new(env!("CARGO_BIN_EXE_ltcguide"))
        .args(["info"])
        .arg(&folder)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(String::from_utf8_lossy(&out.stdout).contains("cornell-glossy"));
}

/// The operations the subset allows still load where it allows them: a unit
/// rotate axis on an envmap, a pure-scale matrix as a checkerboard's to_uv,
/// faces that all carry vt and vn.
#[test]
fn the_subset_forms_next_to_the_refused_ones_load() {
    let xml = r#"<scene version="3.0.0">
<sensor type="perspective"><float name="fov" value="40"/></sensor>
<emitter type="envmap"><string name="filename" value="sky.exr"/><transform name="to_world"><rotate x="0.6" y="0.8" angle="30"/></transform></emitter>
<shape type="obj"><string name="filename" value="../ok/quad.obj"/><bsdf type="diffuse"><texture type="checkerboard" name="reflectance"><transform name="to_uv"><matrix value="4 0 0 0 0 2 0 0 0 0 1 0 0 0 0 1"/></transform></texture></bsdf></shape>
</scene>"#;
    let scene = load_scene_from_str(xml, &data("bad/subset.xml")).expect("loads");
    assert_eq!(scene.triangle_count(), 2);
    assert!(scene.lights.has_infinite());
}

/// Forms Mitsuba's own scenes use beyond the pack, each with one meaning the
/// loader implements exactly, still load: a shape's `id` (a name only),
/// `rotate`, `scale` (z included) and `lookat`, and an OBJ's objects,
/// groups, smoothing groups and material names, whose triangles are all read.
#[test]
fn forms_beyond_the_pack_with_one_meaning_load() {
    let dir = std::env::temp_dir().join(format!("ltcguide-loader-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let obj = "mtllib scene.mtl\no quad\ng top\nusemtl white\ns 1\nv -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\n\
               f 1 2 3\ng bottom\nusemtl grey\ns off\nf 1 3 4\n";
    std::fs::write(dir.join("grouped.obj"), obj).unwrap();
    let xml = r#"<scene version="3.0.0">
<sensor type="perspective"><float name="fov" value="40"/></sensor>
<emitter type="constant"><rgb name="radiance" value="1, 1, 1"/></emitter>
<shape type="obj" id="mesh-grouped"><string name="filename" value="grouped.obj"/><boolean name="face_normals" value="true"/><bsdf type="diffuse"/></shape>
<shape type="rectangle"><transform name="to_world"><scale x="2" y="3" z="4"/></transform><bsdf type="diffuse"/></shape>
<shape type="rectangle"><transform name="to_world"><rotate x="1" angle="90"/></transform><bsdf type="diffuse"/></shape>
<shape type="rectangle"><transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 6" up="0, 1, 0"/></transform><bsdf type="diffuse"/></shape>
</scene>"#;
    let scene = load_scene_from_str(xml, &dir.join("grouped.xml")).expect("loads");
    // Both groups' faces, and two triangles per rectangle.
    assert_eq!(scene.triangle_count(), 2 + 3 * 2);
    let (lo, hi) = scene.bounds;
    // The scaled rectangle spans x ∈ [−2, 2] and y ∈ [−3, 3]; the rotated
    // one stands in the y = 0 plane, z ∈ [−1, 1]; the looked-at one lies at z = 5.
    assert_eq!((lo.x, lo.y, hi.x, hi.y), (-2.0, -3.0, 2.0, 3.0));
    assert!(
        (lo.z + 1.0).abs() < 1e-6 && (hi.z - 5.0).abs() < 1e-6,
        "{lo} {hi}"
    );
    std::fs::remove_dir_all(&dir).ok();
}
