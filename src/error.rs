//! Error types: user errors (bad input, exit code 2) and internal errors (exit code 1).

/// A wavetrace error.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The user supplied something wrong: a scene, a mesh, a flag or an output path.
    /// The message names the file, the line/column where known, and the field.
    #[error("{0}")]
    Input(String),
    /// Something failed that is not the user's fault (an I/O failure while writing, a bug).
    #[error("internal error: {0}")]
    Internal(String),
}

impl Error {
    /// A bad-input error with the given message.
    pub fn input(msg: impl Into<String>) -> Self {
        Error::Input(msg.into())
    }

    /// A bad-input error located in a file, at an optional line/column, about a field.
    pub fn at(file: &str, loc: Option<(usize, usize)>, field: &str, msg: impl std::fmt::Display) -> Self {
        let place = match loc {
            Some((line, col)) => format!("{file}:{line}:{col}"),
            None => file.to_string(),
        };
        if field.is_empty() {
            Error::Input(format!("{place}: {msg}"))
        } else {
            Error::Input(format!("{place}: field `{field}`: {msg}"))
        }
    }

    /// An error about an output path.
    pub fn output(path: &std::path::Path, msg: impl std::fmt::Display) -> Self {
        Error::Input(format!("output `{}`: {msg}", path.display()))
    }

    /// The process exit code that reports this error: 2 for bad input, 1 otherwise.
    pub fn exit_code(&self) -> i32 {
        match self {
            Error::Input(_) => 2,
            Error::Internal(_) => 1,
        }
    }
}

/// Result with a wavetrace [`Error`].
pub type Result<T> = std::result::Result<T, Error>;
