//! Readers for Stage 4.1.1 worldfiles (`.world`, `.inc`) and Player 3.0.2 configuration files
//! (`.cfg`), producing a resolved model tree with Stage's defaults and units applied.
//!
//! Two levels:
//! - the **document** level ([`Document`], from [`loader::load_document`]): entities in
//!   pre-order with their parent, type, source location and raw properties (token text with
//!   locations and a `used` flag). Both languages share the lexer and parser, with their
//!   documented differences ([`Dialect`]).
//! - the **resolved** level for worlds ([`WorldSpec::load`]): settings, window, and models in
//!   pre-order, each with its typed properties in metres and radians and Stage's defaults, its
//!   body as blocks in the body frame, and a per-type spec ([`models::TypeSpec`]). For cfg files,
//!   [`CfgFile::load`] gives the driver blocks with parsed device addresses. What a server makes
//!   of them (drivers, model bindings, `player --check`) is the server's business, not this
//!   crate's.
//!
//! Every error is an [`Error`] that prints like a compiler diagnostic (`file:line:col`, the
//! offending text, the include chain). Nothing Stage would accept is rejected, except where
//! Stage silently builds a partial world after an error; Stage 3 forms found in the shipped
//! worlds are accepted with [`Warning`]s.

pub mod bitmap;
pub mod body;
pub mod cfg;
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

pub use bitmap::BitmapRows;
pub use body::BlockSpec;
pub use cfg::{CfgFile, DeviceAddr, DriverSpec, Host};
pub use color::{ColorSpec, Rgba};
pub use document::{Document, Entity, EntityId, Property, Units, Value, ValueKind, ValueRange};
pub use error::{Error, ErrorKind, Warning};
pub use lexer::Dialect;
pub use loader::{Limits, LoadOptions};
pub use models::{ModelType, TypeSpec};
pub use reader::Pose;
pub use source::{FileId, Location, SourceLoc, SourceMap};
pub use world::{ModelId, ModelSpec, WindowSpec, WorldSettings, WorldSpec};
