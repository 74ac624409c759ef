//! Position drivers, as Player's `server/drivers/position/`: local navigation that drives a
//! `position2d` base to goals among the obstacles its range sensors see.
//!
//! * [`nd`] — Nearness Diagram navigation.

pub mod nd;
