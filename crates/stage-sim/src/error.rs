//! The crate's error type.

use thiserror::Error;

use crate::node::ModelId;
use worldfile::models::ModelType;

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
    /// Built without allocating: callers may use a type-specific getter as a type test.
    #[error("model {id} is a `{}` model, not {expected}", found.name())]
    BadModel {
        /// The id given.
        id: ModelId,
        /// The model's type.
        found: ModelType,
        /// What the call needs ("a ranger", …).
        expected: &'static str,
    },
    /// A block index past the model's blocks.
    #[error("model {id} has {blocks} block(s), no block {block}")]
    NoBlock {
        /// The id given.
        id: ModelId,
        /// The block index given.
        block: usize,
        /// How many blocks the model has.
        blocks: usize,
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
