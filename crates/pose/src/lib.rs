//! Poses and headings, written once for every crate: the worldfile reader composes the poses it
//! loads with them, the simulator moves models with them, the drivers and the viewers fold
//! headings with them.
//!
//! Stage and Player fold angles in different ways, and several drivers must stay bit-identical
//! to their upstream's arithmetic, so [`angle`] holds each fold under a name that says whose it
//! is rather than one "normalize" that would quietly change results.

pub mod angle;
mod frame;

pub use frame::Pose;
