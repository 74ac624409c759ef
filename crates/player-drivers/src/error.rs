//! The crate's one error type: why a driver of this crate refuses its cfg block.

use std::path::PathBuf;

use player_server::DriverError;

/// Why a driver could not be built from its cfg block. The server prefixes the block's place
/// (`file:line`) and the driver's name when it reports one.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A required option is absent.
    #[error("option `{option}` is required: {why}")]
    MissingOption {
        /// The option's name.
        option: &'static str,
        /// What it is for.
        why: &'static str,
    },
    /// An option's value cannot be used.
    #[error("option `{option}` has an invalid value \"{value}\": {why}")]
    BadOption {
        /// The option's name (an element of an indexed family, such as `spose[3]`, included).
        option: String,
        /// The value as written.
        value: String,
        /// What is wrong with it.
        why: String,
    },
    /// An image file could not be read or decoded.
    #[error("cannot read image file {}: {source}", path.display())]
    Image {
        /// The file, as resolved against the cfg's folder.
        path: PathBuf,
        /// The decoder's reason.
        source: image::ImageError,
    },
    /// A map the options describe cannot be made (empty, or too large to hold).
    #[error("{0}")]
    Map(String),
}

impl From<Error> for DriverError {
    fn from(e: Error) -> DriverError {
        DriverError::new(e.to_string())
    }
}
