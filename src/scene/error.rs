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
        // Newlines inside messages (e.g. from parsers) would break the one-line promise.
        let message = self.message.replace('\n', " ");
        write!(
            f,
            "{}:{}: {}: {}",
            self.file.display(),
            self.line,
            self.element,
            message
        )
    }
}

impl std::error::Error for SceneError {}
