//! The crate's error type.

use thiserror::Error;

/// Why a world could not be built or a call was refused.
#[derive(Debug, Error)]
pub enum Error {
    /// The description is inconsistent (bad parent index, block with fewer than 2 points, …).
    #[error("{source_loc}: model `{model}`: {msg}")]
    InvalidModel {
        /// Model name.
        model: String,
        /// Where it was defined.
        source_loc: String,
        /// What is wrong.
        msg: String,
    },
    /// The worldfile could not be loaded.
    #[error(transparent)]
    Worldfile(#[from] worldfile::Error),
    /// A world-level setting is unusable.
    #[error("world: {0}")]
    InvalidWorld(String),
    /// A model id that does not exist or has the wrong type for the call.
    #[error("model {id}: {msg}")]
    BadModel {
        /// The id given.
        id: u32,
        /// What was expected.
        msg: String,
    },
}

/// `Result` with this crate's [`enum@Error`].
pub type Result<T> = std::result::Result<T, Error>;
