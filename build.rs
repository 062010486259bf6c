// JPEG textures are decoded by libjpeg-turbo's decoder with its defaults, as
// Mitsuba 3 decodes them (see src/texture/jpeg.rs). The library is the copy
// vendored in the `mozjpeg-sys` crate, compiled from C by its own build script
// (default features off: no nasm, no cmake) and linked statically, so a
// build needs a C compiler and nothing else (no system libjpeg).
//
// Our shim is compiled against that copy's headers: mozjpeg-sys declares
// `links = "jpeg"` and prints `cargo:include=<dirs>` (its generated
// jconfig.h and the vendored jpeglib.h), which cargo hands to this script as
// DEP_JPEG_INCLUDE. The struct layouts the shim sees then match the library
// it links against, whatever libjpeg headers the system may also have.
use std::env;

fn main() {
    zmm_kernels_cfg();
    println!("cargo:rerun-if-changed=src/texture/jpeg_shim.c");
    let include = env::var_os("DEP_JPEG_INCLUDE")
        .expect("DEP_JPEG_INCLUDE unset: mozjpeg-sys must be a [dependencies] entry");
    let mut build = cc::Build::new();
    for dir in env::split_paths(&include) {
        build.include(dir);
    }
    build
        .file("src/texture/jpeg_shim.c")
        .warnings(true)
        .compile("ltc_jpeg_shim");
}

/// `zmm_kernels`: the wide LTC kernels hold their 16 lanes in one zmm
/// register, i.e. the build has AVX-512 and the `ymm-kernels` feature is off
/// (src/ltc/lanes.rs says why a build would turn it on).
fn zmm_kernels_cfg() {
    println!("cargo::rustc-check-cfg=cfg(zmm_kernels)");
    let features = env::var("CARGO_CFG_TARGET_FEATURE").unwrap_or_default();
    let avx512f = features.split(',').any(|f| f == "avx512f");
    if avx512f && env::var_os("CARGO_FEATURE_YMM_KERNELS").is_none() {
        println!("cargo::rustc-cfg=zmm_kernels");
    }
}
