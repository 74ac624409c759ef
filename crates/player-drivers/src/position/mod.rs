//! Position drivers, as Player's `server/drivers/position/`: local navigation that drives a
//! `position2d` base to goals among the obstacles its range sensors see.
//!
//! * [`nd`] — Nearness Diagram navigation;
//! * [`snd`] — Smooth Nearness-Diagram navigation (laser only, a round robot).

pub mod nd;
pub mod snd;
