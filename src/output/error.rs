//! The one error type of `output`. Every variant carries the file path, because the caller
//! (CLI or server) usually writes several files per frame and the message must say which one
//! failed. The cause is part of the message as well as the `source()` chain: the server turns
//! errors into gRPC status strings with `to_string()`, which would otherwise lose it.
use std::path::PathBuf;

#[derive(thiserror::Error, Debug)]
pub enum OutputError {
    /// Creating, writing or reading the file (or its directory) failed.
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The OpenEXR encoder or decoder failed.
    #[error("{}: OpenEXR: {source}", path.display())]
    Exr {
        path: PathBuf,
        #[source]
        source: ::exr::error::Error,
    },
    /// The PNG encoder failed.
    #[error("{}: PNG: {source}", path.display())]
    Png {
        path: PathBuf,
        #[source]
        source: image::ImageError,
    },
    /// What we were asked to write cannot be written as is (buffer lengths that disagree with
    /// the frame size, an empty image, a number that does not fit its header attribute).
    #[error("{}: cannot write: {reason}", path.display())]
    InvalidInput { path: PathBuf, reason: String },
    /// A file we read is valid OpenEXR but not what `write_exr` produces (missing channel or
    /// attribute, wrong attribute type, subsampled channel).
    #[error("{}: not a wedge EXR: {reason}", path.display())]
    Format { path: PathBuf, reason: String },
}
