//! Player 3.0.2's drivers other than `stage`, one module per driver as in Player's
//! `server/drivers/`. Each module exposes a `register` function; [`register_all`] adds every
//! driver of this crate to a [`DriverRegistry`] under its Player name.
//!
//! * [`mapfile`] — a `map` read from an image file;
//! * [`mapscale`], [`mapcspace`] — the map transforms (a map resampled to another resolution,
//!   and the configuration space of a round robot): their algorithms and options, for drivers
//!   that read their source map from another device once the server can give them one.

#![warn(missing_docs)]

mod error;
pub mod mapcspace;
pub mod mapfile;
pub mod mapscale;
mod options;

pub use error::Error;
use player_server::DriverRegistry;

/// Registers every driver of this crate under its Player 3.0.2 name.
pub fn register_all(registry: &mut DriverRegistry) {
    mapfile::register(registry);
}
