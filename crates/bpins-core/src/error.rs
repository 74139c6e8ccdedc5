//! Typed errors of the core library. Every error that comes from user input names
//! the file and the key or frame it is about.

use std::path::PathBuf;

/// The message of the [`Error::Capture`] for a folder without `capture.toml` (a
/// missing folder, a mistyped path): the bindings turn it into their language's
/// file-not-found error (Python's `FileNotFoundError`).
#[cfg(feature = "io")]
pub use crate::capture::NOT_FOUND as CAPTURE_NOT_FOUND;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A capture (`capture.toml` or a frame) that cannot be read as CAPTURE.md says.
    #[error("{path}: {message}")]
    Capture { path: PathBuf, message: String },
    /// A sweep file (`bpins-sweep/1`) or a sweep's output folder that cannot be read:
    /// the file, the key (`errors[2].sigma`, `sky.sun_elevations_deg`) and what was
    /// expected.
    #[error("{path}: {key}: {message}")]
    Sweep { path: PathBuf, key: String, message: String },
    /// A calibration file that cannot be read as `bpins-calibration/1`.
    #[error("{path}: {message}")]
    Calibration { path: PathBuf, message: String },
    /// A file-system operation on `path` failed; the OS error is the source.
    #[error("{path}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A name not in its kind's registry of the catalog (`kind`: "effect" or
    /// "scene element"; `kinds` its plural).
    #[error("unknown {kind} `{name}`; known {kinds}: {known}")]
    UnknownEntry { kind: &'static str, kinds: &'static str, name: String, known: String },
    #[error("{kind} `{entry}` has no parameter `{param}`; its parameters: {known}")]
    UnknownParam { kind: &'static str, entry: String, param: String, known: String },
    #[error("{kind} parameter `{spec}`: {message}")]
    BadParam { kind: &'static str, spec: String, message: String },
    /// A value of a request or a simulation outside the range it must lie in: what
    /// it is, the value as given (with its unit) and the range.
    #[error("{what} {value}: must lie in {range}")]
    OutOfRange { what: String, value: String, range: String },
    /// Too few usable pixels or samples for what was asked (a frame all saturated,
    /// a mask that leaves nothing, a capture without frames).
    #[error("{0}")]
    TooFewSamples(String),
    /// A frame's pixels that do not match the capture's sensor (size or layout).
    #[error("{0}")]
    FrameMismatch(String),
    /// Analyzer channels that cannot resolve Stokes I, Q and U.
    #[error("{0}")]
    Analyzers(String),
    /// An effect asked of a model (a fit's) that does not have it.
    #[error("{effect} is not in the model")]
    NotInModel { effect: String },
    /// An output that cannot be serialised or encoded (a bug of bpins, not of the
    /// input): what was being written and why.
    #[error("writing {what}: {message}")]
    Encode { what: String, message: String },
    #[error("heading extraction failed: {0}")]
    Heading(String),
    /// A timestamp that is not a time this library can place the sun at: what was
    /// given and why.
    #[error("{time}: {message}")]
    Time { time: String, message: String },
    /// A place outside the Earth's coordinates.
    #[error("place: {0}")]
    Place(String),
    /// NREL SPA could not give a position (a date outside its range).
    #[error("sun position: {0}")]
    Sun(String),
    /// A report template that does not render (a bug of bpins, not of the input).
    #[error("report template {name}: {message}")]
    Template { name: String, message: String },
    /// A compute backend could not do what was asked (no device, a buffer too large).
    #[error("{backend} backend: {message}")]
    Backend { backend: String, message: String },
}

pub type Result<T, E = Error> = std::result::Result<T, E>;

/// `e` and each of its sources, `: `-joined, as the CLI prints an error (`{:#}`): an
/// I/O error's path and what the OS said of it (`calibration.toml: No such file or
/// directory`), not the path alone. A source whose text already ends the message is
/// not repeated. The C ABI and the Python bindings report errors through this.
pub fn full_message(e: &dyn std::error::Error) -> String {
    let mut text = e.to_string();
    let mut source = e.source();
    while let Some(s) = source {
        let s_text = s.to_string();
        if !text.ends_with(&s_text) {
            text = format!("{text}: {s_text}");
        }
        source = s.source();
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_full_message_says_what_the_os_said_once() {
        let e = Error::Io {
            path: "/nonexistent/calibration.toml".into(),
            source: std::io::Error::from(std::io::ErrorKind::NotFound),
        };
        assert_eq!(e.to_string(), "/nonexistent/calibration.toml");
        assert_eq!(full_message(&e), "/nonexistent/calibration.toml: entity not found");
        let plain = Error::NotInModel { effect: "crosstalk".into() };
        assert_eq!(full_message(&plain), "crosstalk is not in the model");
    }
}
