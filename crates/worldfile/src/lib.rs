//! Readers for Stage 4.1.1 worldfiles (`.world`, `.inc`) and Player 3.0.2 configuration files
//! (`.cfg`), producing a resolved model tree with Stage's defaults and units applied.

pub mod bitmap;
pub mod body;
pub mod color;
mod colors_x11;
pub mod document;
pub mod error;
pub mod lexer;
pub mod loader;
pub mod models;
pub mod numeric;
mod parser;
pub mod reader;
pub mod source;
mod table;
pub mod world;

pub use document::{Document, Entity, EntityId, Property, Units, Value, ValueKind};
pub use error::{Error, ErrorKind, Warning};
pub use lexer::Dialect;
pub use loader::{Limits, LoadOptions};
pub use source::{FileId, Location, SourceLoc, SourceMap};
