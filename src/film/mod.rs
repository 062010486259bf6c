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

/// Fails before any work is spent on an output that could not be written:
/// creates the path's directory and, as the final atomic write will, a
/// temporary file beside it (removed again at once). A render that ran for
/// an hour must not end on a path it could have refused at the start.
pub fn ensure_writable(path: &Path) -> Result<(), String> {
    if path.is_dir() {
        return Err(format!(
            "cannot write '{}': it is a directory",
            path.display()
        ));
    }
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .map_err(|e| format!("cannot create '{}': {e}", dir.display()))?;
    }
    let tmp = temp_path_for(path);
    std::fs::File::create(&tmp).map_err(|e| format!("cannot write '{}': {e}", path.display()))?;
    let _ = std::fs::remove_file(&tmp);
    Ok(())
}

/// The file `path` names, whether or not it exists yet: its longest
/// existing ancestor resolved (symbolic links and `..` included), the rest
/// appended with `.` and `..` applied, since a directory still to be made
/// holds no links. Two paths to one file resolve alike.
pub fn resolved_path(path: &Path) -> PathBuf {
    use std::path::Component;
    let absolute = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    let components: Vec<Component> = absolute.components().collect();
    for existing in (1..=components.len()).rev() {
        let Ok(mut resolved) = components[..existing]
            .iter()
            .collect::<PathBuf>()
            .canonicalize()
        else {
            continue;
        };
        for c in &components[existing..] {
            match c {
                Component::ParentDir => {
                    resolved.pop();
                }
                Component::CurDir => {}
                other => resolved.push(other),
            }
        }
        return resolved;
    }
    absolute
}

/// Refuses a list of a command's output files in which two name the same
/// file, which would leave only the later write.
pub fn check_distinct_outputs(outputs: &[(&str, PathBuf)]) -> Result<(), String> {
    for (i, (what_a, a)) in outputs.iter().enumerate() {
        for (what_b, b) in &outputs[..i] {
            if resolved_path(a) == resolved_path(b) {
                return Err(format!(
                    "{what_b} and {what_a} both name '{}'; one would replace the other",
                    a.display()
                ));
            }
        }
    }
    Ok(())
}

/// Writes `bytes` to `path` through a temporary file beside it, so that a
/// failed write never leaves a truncated file in its place.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), String> {
    let tmp = temp_path_for(path);
    std::fs::write(&tmp, bytes).map_err(|e| format!("cannot write '{}': {e}", path.display()))?;
    commit_temp(&tmp, path)
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
