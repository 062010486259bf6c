//! A comparison folder's files as `compare` and `merge` own them: which
//! names they write, when a folder may be written into, and the machine
//! line of `summary.md` that records what its text rounds (the exact budget)
//! or never says (which reference the errors were measured against).

use super::compare::method_name;
use super::cost::COST_CSV;
use crate::film::image::Image;
use crate::film::{ensure_writable, resolved_path};
use crate::render::Method;
use clap::ValueEnum;
use std::path::{Path, PathBuf};

/// The files that say what a folder's study is: one of them present means
/// the folder holds a comparison (or a pooled one).
pub const STUDY_FILES: [&str; 4] = ["curves.csv", COST_CSV, "curves.svg", "summary.md"];

/// The final-image files of `method` in a comparison folder.
pub fn image_files(method: Method) -> [String; 3] {
    let name = method_name(method);
    [
        format!("{name}.exr"),
        format!("{name}.png"),
        format!("{name}-error.png"),
    ]
}

/// Every name a comparison may have written into a folder: its study files
/// and the images of every method, not only this study's, since a stale
/// image of another method would stand beside the new summary as its own.
pub fn comparison_files(dir: &Path) -> Vec<PathBuf> {
    let images = Method::value_variants()
        .iter()
        .flat_map(|&m| image_files(m));
    STUDY_FILES
        .iter()
        .map(|s| s.to_string())
        .chain(images)
        .map(|name| dir.join(name))
        .collect()
}

/// The files a comparison left in `dir`; the folder holds a study when one
/// of them is a study file.
pub fn existing_study(dir: &Path) -> Vec<PathBuf> {
    let existing: Vec<PathBuf> = comparison_files(dir)
        .into_iter()
        // A directory under one of the names is no file of a study: the
        // writability check refuses it by what it is.
        .filter(|p| p.symlink_metadata().is_ok_and(|m| !m.is_dir()))
        .collect();
    let holds_study = existing.iter().any(|p| {
        p.file_name()
            .is_some_and(|n| STUDY_FILES.iter().any(|s| n == *s))
    });
    if holds_study { existing } else { Vec::new() }
}

/// The refusal for a folder that already holds a study, naming its files.
pub fn occupied_error(command: &str, dir: &Path, existing: &[PathBuf]) -> String {
    let names: Vec<String> = existing
        .iter()
        .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
        .collect();
    format!(
        "'{}' already holds a comparison ({}): {command} would replace it or leave its files \
         beside the new study's; give --overwrite to replace them, or another --out",
        dir.display(),
        names.join(", ")
    )
}

/// Removes the files a comparison writes from `dir` (no other file), so
/// that a study written over an earlier one leaves nothing of it behind.
pub fn remove_comparison_files(dir: &Path) -> Result<(), String> {
    for path in comparison_files(dir) {
        match std::fs::remove_file(&path) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => return Err(format!("cannot remove '{}': {e}", path.display())),
        }
    }
    Ok(())
}

/// Refuses a comparison that would write over or remove its own reference.
pub fn check_reference_not_output(reference: &Path, dir: &Path) -> Result<(), String> {
    let reference_file = resolved_path(reference);
    for out in comparison_files(dir) {
        if resolved_path(&out) == reference_file {
            return Err(format!(
                "the reference '{}' is '{}', a file compare writes or replaces: the study \
                 would overwrite the image it measures against (copy the reference elsewhere or \
                 choose another --out)",
                reference.display(),
                out.display()
            ));
        }
    }
    Ok(())
}

/// Makes `dir` and checks every file the comparison will write there is
/// writable, before hours of rendering could end on one that is not.
pub fn check_writable(dir: &Path, methods: &[Method]) -> Result<(), String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create '{}': {e}", dir.display()))?;
    let images = methods.iter().flat_map(|&m| image_files(m));
    for name in STUDY_FILES.iter().map(|s| s.to_string()).chain(images) {
        ensure_writable(&dir.join(name))?;
    }
    Ok(())
}

/// A path-independent fingerprint of a reference: its size and the 64-bit
/// FNV-1a hash of its pixels' f32 bits, so that the same pack checked out
/// elsewhere gives the same fingerprint and a re-rendered one does not.
pub fn reference_fingerprint(image: &Image) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for p in &image.pixels {
        for c in [p.x, p.y, p.z] {
            for b in c.to_bits().to_le_bytes() {
                h ^= b as u64;
                h = h.wrapping_mul(0x0100_0000_01b3);
            }
        }
    }
    format!("{}x{} fnv1a64 {h:016x}", image.width, image.height)
}

/// The opening of the summary's machine line, an HTML comment (hidden where
/// the page is rendered) after its closing "Files:" line.
const RECORD_PREFIX: &str = "<!-- ltcguide study: ";
const RECORD_SUFFIX: &str = " -->";

/// What a summary's machine line records; `None` where it was not recorded
/// (summaries written before the line existed, or pooled from such).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StudyRecord {
    /// The budget per run in seconds, exactly (the text says it to 0.1 s).
    pub budget: Option<f64>,
    pub reference: Option<String>,
}

impl StudyRecord {
    /// The machine line, with a newline; empty when nothing is recorded.
    pub fn line(&self) -> String {
        let mut parts = Vec::new();
        if let Some(b) = self.budget {
            // `{}` prints the shortest text that parses back to the same f64.
            parts.push(format!("budget_seconds={b}"));
        }
        if let Some(r) = &self.reference {
            parts.push(format!("reference={r}"));
        }
        if parts.is_empty() {
            return String::new();
        }
        format!("{RECORD_PREFIX}{}{RECORD_SUFFIX}\n", parts.join("; "))
    }

    /// The record of a summary (empty when it has no machine line).
    pub fn parse(summary: &str) -> Result<StudyRecord, String> {
        let mut record = StudyRecord::default();
        let Some(line) = summary.lines().find(|l| l.starts_with(RECORD_PREFIX)) else {
            return Ok(record);
        };
        let inner = line[RECORD_PREFIX.len()..]
            .strip_suffix(RECORD_SUFFIX)
            .ok_or_else(|| format!("its machine line is not closed: '{line}'"))?;
        for part in inner.split("; ") {
            match part.split_once('=') {
                Some(("budget_seconds", v)) => {
                    let b: f64 = v
                        .parse()
                        .map_err(|_| format!("its machine line's budget '{v}' is not a number"))?;
                    record.budget = Some(b);
                }
                Some(("reference", v)) => record.reference = Some(v.to_string()),
                _ => return Err(format!("its machine line has an unknown part '{part}'")),
            }
        }
        Ok(record)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_record_reads_back_exactly() {
        let r = StudyRecord {
            budget: Some(0.249),
            reference: Some("64x64 fnv1a64 00000000deadbeef".into()),
        };
        let text = format!("# s\n\nFiles: x\n{}", r.line());
        assert_eq!(StudyRecord::parse(&text).unwrap(), r);
        assert_eq!(StudyRecord::parse("# s\n").unwrap(), StudyRecord::default());
        assert_eq!(StudyRecord::default().line(), "");
    }

    #[test]
    fn the_fingerprint_follows_the_pixels() {
        let image = |v: f32| Image {
            width: 2,
            height: 1,
            pixels: vec![glam::Vec3::splat(v); 2],
        };
        assert_eq!(
            reference_fingerprint(&image(0.5)),
            reference_fingerprint(&image(0.5))
        );
        assert_ne!(
            reference_fingerprint(&image(0.5)),
            reference_fingerprint(&image(0.5000001))
        );
        assert!(reference_fingerprint(&image(0.5)).starts_with("2x1 fnv1a64 "));
    }
}
