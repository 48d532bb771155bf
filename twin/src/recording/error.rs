//! Why a recording could not be written or read, and an error's chain of causes for the message.

use std::path::PathBuf;

/// Why a Rerun file could not be recorded, written or read.
#[derive(Debug, Clone, thiserror::Error)]
pub enum RecordingError {
    /// The file cannot be started (its path is a directory, its folder is missing or not
    /// writable), or its layout or the live viewer cannot be set up.
    #[error("cannot create the recording {}: {reason}", path.display())]
    Create {
        /// The recording's path.
        path: PathBuf,
        /// What failed, as the file system or the viewer said.
        reason: String,
    },
    /// Writing to the file, or moving the finished file into place, failed.
    #[error("cannot write the recording {}: {reason}", path.display())]
    Write {
        /// The recording's path.
        path: PathBuf,
        /// What the file system or the encoder said.
        reason: String,
    },
    /// The file cannot be opened or decoded as a Rerun recording.
    #[error("cannot read the recording {}: {reason}", path.display())]
    Read {
        /// The recording's path.
        path: PathBuf,
        /// What the file system or the decoder said.
        reason: String,
    },
}

/// An error and its sources, for messages that name the root cause.
pub(super) fn error_chain(err: &dyn std::error::Error) -> String {
    let mut message = err.to_string();
    let mut source = err.source();
    while let Some(cause) = source {
        let text = cause.to_string();
        if !message.contains(&text) {
            message.push_str(": ");
            message.push_str(&text);
        }
        source = cause.source();
    }
    message
}
