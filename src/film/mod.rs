//! Image output: EXR and PNG writers, written atomically.

pub mod exr_io;

use std::path::{Path, PathBuf};

/// A sibling temporary path for atomic writes.
pub fn temp_path_for(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    path.with_file_name(format!(".{name}.tmp{}", std::process::id()))
}

/// Renames a finished temporary file over its destination.
pub fn commit_temp(tmp: &Path, path: &Path) -> Result<(), String> {
    std::fs::rename(tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(tmp);
        format!("cannot write '{}': {e}", path.display())
    })
}

pub mod compare;
pub mod image;
pub mod metrics;
pub mod png_io;
