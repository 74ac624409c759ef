//! playerstage-rs: a Rust drop-in replacement for the Player 3.0.2 robot device server with an
//! embedded Stage 4.1.1-style simulator. This root package only re-exports the layers so that the
//! end-to-end tests in `tests/` can drive them together.

pub use player_proto;
pub use worldfile;
