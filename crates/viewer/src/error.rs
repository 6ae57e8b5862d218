//! The viewer's error type.

use std::path::PathBuf;

/// Everything that can go wrong in the viewer. Nothing in the crate panics on bad input.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ViewerError {
    /// A file could not be read or written.
    #[error("{}: {source}", path.display())]
    Io { path: PathBuf, source: std::io::Error },
    /// A file was read but its content is not acceptable.
    #[error("{}: {message}", path.display())]
    BadInput { path: PathBuf, message: String },
    /// The image, the depth table and the camera disagree on the image size.
    #[error("size mismatch: {first_what} is {}x{} but {second_what} is {}x{}", first.0, first.1, second.0, second.1)]
    SizeMismatch { first_what: String, first: (u32, u32), second_what: String, second: (u32, u32) },
    /// The scene's camera or depth range cannot be used by the viewer.
    #[error("camera: {0}")]
    Camera(String),
    /// A live object, a light choice or an in-memory input is not usable.
    #[error("invalid input: {0}")]
    Invalid(String),
    /// No usable GPU adapter (a software one counts) was found.
    #[error("no GPU adapter: {0}")]
    NoAdapter(String),
    /// The adapter cannot do what the viewer needs (size limits, compute shaders).
    #[error("the GPU adapter cannot do this: {0}")]
    Unsupported(String),
    /// wgpu reported an error (validation, out of memory, device lost).
    #[error("GPU error: {0}")]
    Gpu(String),
    /// The window system failed.
    #[error("window: {0}")]
    Window(String),
}
