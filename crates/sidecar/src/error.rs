//! Errors of reading and writing sidecar files; every one names the file.

use std::fmt;
use std::io;
use std::path::{Path, PathBuf};

/// What went wrong with a sidecar file.
#[derive(Debug)]
#[non_exhaustive]
pub enum SidecarErrorKind {
    Io(io::Error),
    /// The EXR decoder or encoder failed.
    Exr {
        message: String,
    },
    /// The file lacks the header attribute `name` (not a sidecar of this format).
    MissingAttribute {
        name: String,
    },
    /// A header attribute has the wrong type or an unusable value.
    BadAttribute {
        name: String,
        detail: String,
    },
    /// A format version this reader does not know.
    UnsupportedVersion {
        found: i32,
    },
    /// The file is of another kind (e.g. probes where layers were expected).
    WrongKind {
        expected: &'static str,
        found: String,
    },
    /// The sidecar's size differs from the image it is paired with.
    SizeMismatch {
        expected: (u32, u32),
        found: (u64, u64),
    },
    /// The data window is not the whole frame (an unmerged crop).
    Crop,
    /// The sidecar was written with another depth table (another render).
    Stale {
        expected: u64,
        found: u64,
    },
    /// A channel the format requires is missing.
    MissingChannel {
        name: String,
        found: Vec<String>,
    },
    /// A channel the format does not define.
    UnexpectedChannel {
        name: String,
    },
    /// A value that is NaN or infinite.
    NonFinite {
        channel: String,
        x: u32,
        y: u32,
        value: f32,
    },
    /// Larger than the reader's limits allow.
    TooLarge {
        what: &'static str,
        size: u64,
        limit: u64,
    },
    /// The in-memory data is inconsistent (e.g. a layer of the wrong length); a writer bug.
    Inconsistent {
        detail: String,
    },
}

/// A sidecar error with the file it concerns.
#[derive(Debug)]
pub struct SidecarError {
    pub path: PathBuf,
    pub kind: SidecarErrorKind,
}

impl SidecarError {
    pub(crate) fn new(path: &Path, kind: SidecarErrorKind) -> SidecarError {
        SidecarError { path: path.to_path_buf(), kind }
    }
}

impl fmt::Display for SidecarError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: error: ", self.path.display())?;
        use SidecarErrorKind::*;
        match &self.kind {
            Io(e) => write!(f, "{e}"),
            Exr { message } => write!(f, "invalid OpenEXR sidecar: {message}"),
            MissingAttribute { name } => {
                write!(f, "not an lrt-depth sidecar: header attribute `{name}` is missing")
            }
            BadAttribute { name, detail } => write!(f, "header attribute `{name}`: {detail}"),
            UnsupportedVersion { found } => write!(
                f,
                "sidecar format version {found} is not supported (this reader knows version {})",
                crate::FORMAT_VERSION
            ),
            WrongKind { expected, found } => {
                write!(f, "sidecar holds `{found}` data, expected `{expected}`")
            }
            SizeMismatch { expected, found } => {
                write!(f, "sidecar is {}x{} but the image is {}x{}", found.0, found.1, expected.0, expected.1)
            }
            Crop => write!(f, "sidecar covers only a crop of the frame (merge the tiles first)"),
            Stale { expected, found } => write!(
                f,
                "sidecar belongs to another render: depth fingerprint {found:016x}, the depth table's is {expected:016x}"
            ),
            MissingChannel { name, found } => {
                write!(f, "channel `{name}` is missing (found: {})", found.join(", "))
            }
            UnexpectedChannel { name } => write!(f, "channel `{name}` is not part of the format"),
            NonFinite { channel, x, y, value } => {
                write!(f, "channel `{channel}` holds {value} at pixel ({x}, {y}); values must be finite")
            }
            TooLarge { what, size, limit } => {
                write!(f, "{what} is {size}, more than the limit of {limit}")
            }
            Inconsistent { detail } => write!(f, "inconsistent sidecar data: {detail}"),
        }
    }
}

impl std::error::Error for SidecarError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match &self.kind {
            SidecarErrorKind::Io(e) => Some(e),
            _ => None,
        }
    }
}
