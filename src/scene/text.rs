//! Scene text: reading a file as UTF-8 with the position of a bad byte, and byte offsets
//! as line and column, for the TOML loader and the Mitsuba XML reader alike.

use std::path::Path;

use crate::{Error, Result};

/// 1-based line and column of byte `offset` in `text`.
pub fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let col = before.rfind('\n').map_or(before.len(), |nl| before.len() - nl - 1) + 1;
    (line, col)
}

/// Reads a text file (a scene, an include). Bytes that are not UTF-8 are an error that
/// says where: `FILE:LINE:COL: not UTF-8 text (byte N)`.
pub fn read_text(path: &Path) -> Result<String> {
    let name = path.display();
    let bytes = std::fs::read(path).map_err(|e| Error::input(format!("`{name}`: cannot read: {e}")))?;
    String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let good = std::str::from_utf8(&e.as_bytes()[..at]).unwrap_or_default();
        let (line, col) = line_col(good, at);
        Error::input(format!("{name}:{line}:{col}: not UTF-8 text (byte {at})"))
    })
}
