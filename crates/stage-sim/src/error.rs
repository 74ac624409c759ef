//! The crate's error type.

use thiserror::Error;

use crate::node::ModelId;

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
    /// A model of the wrong type for the call (a ranger's scans asked of a position model, …).
    #[error("model {id}: {msg}")]
    BadModel {
        /// The id given.
        id: ModelId,
        /// What was expected.
        msg: String,
    },
    /// A model id that does not belong to this world: its index is past the world's last model
    /// (an id kept from a bigger world, or a number that was never checked).
    #[error("model id {id} does not belong to this world (it has {models} models)")]
    ForeignModel {
        /// The id given.
        id: ModelId,
        /// How many models the world has.
        models: usize,
    },
}

/// `Result` with this crate's [`enum@Error`].
pub type Result<T> = std::result::Result<T, Error>;
