//! Player 3.0.2's drivers other than `stage`, one module per driver as in Player's
//! `server/drivers/`. Each module exposes a `register` function; [`register_all`] adds every
//! driver of this crate to a [`DriverRegistry`] under its Player name.

#![warn(missing_docs)]

use player_server::DriverRegistry;

pub mod forward;
pub mod laserposeinterpolator;
pub mod passthrough;
pub mod vfh;

/// Registers every driver of this crate under its Player 3.0.2 name.
pub fn register_all(registry: &mut DriverRegistry) {
    laserposeinterpolator::register(registry);
    passthrough::register(registry);
    vfh::register(registry);
}
