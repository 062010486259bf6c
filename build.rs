// JPEG textures are decoded by the system libjpeg(-turbo), as Mitsuba 3
// decodes them (see src/texture/jpeg.rs); Debian: libjpeg-dev.
fn main() {
    println!("cargo:rerun-if-changed=src/texture/jpeg_shim.c");
    cc::Build::new()
        .file("src/texture/jpeg_shim.c")
        .warnings(true)
        .compile("ltc_jpeg_shim");
    println!("cargo:rustc-link-lib=jpeg");
}
