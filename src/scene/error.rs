//! Scene loading errors: one line naming the file, the line and the element.

use std::fmt;
use std::path::{Path, PathBuf};

#[derive(Clone, Debug)]
pub struct SceneError {
    pub file: PathBuf,
    /// 1-based line, 0 when the error concerns the whole file.
    pub line: u32,
    /// The XML element (e.g. `<shape type="obj">`) or file part concerned.
    pub element: String,
    pub message: String,
}

impl SceneError {
    pub fn new(
        file: &Path,
        line: u32,
        element: impl Into<String>,
        message: impl Into<String>,
    ) -> Self {
        SceneError {
            file: file.to_path_buf(),
            line,
            element: element.into(),
            message: message.into(),
        }
    }
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}:{}: {}: {}",
            self.file.display(),
            self.line,
            one_line(&self.element),
            one_line(&self.message)
        )
    }
}

/// Parsers quote the offending input and elements quote attribute values
/// (`&#10;` and `&#13;` survive XML normalisation), so either can carry line
/// breaks or other control characters that would break the one-line promise.
fn one_line(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_control() || c == '\u{2028}' || c == '\u{2029}' {
                ' '
            } else {
                c
            }
        })
        .collect()
}

impl std::error::Error for SceneError {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn display_is_one_line_whatever_the_parts_hold() {
        let e = SceneError::new(
            Path::new("s.xml"),
            3,
            "<bsdf type=\"a\nb\">",
            "expected '>' not '\r'\u{2028}x\u{85}",
        );
        let text = e.to_string();
        assert_eq!(
            text,
            "s.xml:3: <bsdf type=\"a b\">: expected '>' not ' ' x "
        );
        assert_eq!(text.lines().count(), 1);
    }
}
