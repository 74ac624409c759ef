//! Readers for Stage 4.1.1 worldfiles (`.world`, `.inc`) and Player 3.0.2 configuration files
//! (`.cfg`), producing a resolved model tree with Stage's defaults and units applied.

pub mod document;
pub mod error;
pub mod lexer;
pub mod loader;
pub mod numeric;
mod parser;
pub mod source;

pub use document::{Document, Entity, EntityId, Property, Units, Value, ValueKind};
pub use error::{Error, ErrorKind, Warning};
pub use lexer::Dialect;
pub use loader::{Limits, LoadOptions};
pub use source::{FileId, Location, SourceLoc, SourceMap};
