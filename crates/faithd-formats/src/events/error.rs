//! The one error type of the event-file boundary.
//!
//! Every variant that comes from the bytes of a file names the byte offset (and, where
//! there is one, the field) so that a person holding a hex dump can find the damage.

use std::path::PathBuf;

/// What went wrong while reading or writing a recorded event file.
#[derive(Debug, thiserror::Error)]
pub enum SourceError {
    /// The file could not be opened or created at all.
    #[error("{}: {source}", path.display())]
    Open {
        path: PathBuf,
        source: std::io::Error,
    },

    /// The operating system failed a read or write (not a format problem).
    #[error("I/O error at byte {offset_bytes}: {source}")]
    Io {
        offset_bytes: u64,
        source: std::io::Error,
    },

    /// The file ends inside a field.
    #[error(
        "truncated {field} at byte {offset_bytes}: needed {needed_bytes} bytes, the file ends after {got_bytes}"
    )]
    Truncated {
        field: &'static str,
        offset_bytes: u64,
        needed_bytes: u64,
        got_bytes: u64,
    },

    /// The file does not start with the signature of the format it was opened as.
    #[error("bad magic at byte {offset_bytes}: expected {expected:?}, found {found:?}")]
    BadMagic {
        offset_bytes: u64,
        expected: &'static str,
        found: String,
    },

    /// A size read from the file is beyond what any real recording uses; refusing it
    /// keeps a hostile header from making the reader allocate gigabytes.
    #[error("{field} at byte {offset_bytes} is {value}, beyond the limit of {limit}")]
    TooLarge {
        field: &'static str,
        offset_bytes: u64,
        value: u64,
        limit: u64,
    },

    /// A field holds a value the format does not allow.
    #[error("invalid {field} at byte {offset_bytes}: {reason}")]
    Invalid {
        field: &'static str,
        offset_bytes: u64,
        reason: String,
    },

    /// A line of a text event file does not parse.
    #[error("line {line}, byte {offset_bytes}: {reason}")]
    TextLine {
        line: u64,
        offset_bytes: u64,
        reason: String,
    },

    /// A writer was handed something its format cannot represent.
    #[error("cannot write {what}: {reason}")]
    Unrepresentable { what: &'static str, reason: String },
}

impl SourceError {
    /// The byte offset in the file the error points at, when it points at one.
    pub fn offset_bytes(&self) -> Option<u64> {
        match self {
            SourceError::Io { offset_bytes, .. }
            | SourceError::Truncated { offset_bytes, .. }
            | SourceError::BadMagic { offset_bytes, .. }
            | SourceError::TooLarge { offset_bytes, .. }
            | SourceError::Invalid { offset_bytes, .. }
            | SourceError::TextLine { offset_bytes, .. } => Some(*offset_bytes),
            SourceError::Open { .. } | SourceError::Unrepresentable { .. } => None,
        }
    }

    pub(crate) fn invalid(
        field: &'static str,
        offset_bytes: u64,
        reason: impl Into<String>,
    ) -> Self {
        SourceError::Invalid {
            field,
            offset_bytes,
            reason: reason.into(),
        }
    }

    pub(crate) fn write_io(source: std::io::Error, offset_bytes: u64) -> Self {
        SourceError::Io {
            offset_bytes,
            source,
        }
    }
}
