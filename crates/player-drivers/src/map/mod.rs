//! Player's `server/drivers/map/`: `mapfile` serves a map read from an image; `mapscale` and
//! `mapcspace` serve a map they read from another map device, transformed.

pub(crate) mod fetch;
pub mod mapcspace;
pub mod mapfile;
pub mod mapscale;
pub mod transform;
