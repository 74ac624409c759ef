//! Player's `server/drivers/position/`: drivers that provide a `position2d` over another one,
//! adding local navigation that drives the base to goals among the obstacles its range
//! sensors see.
//!
//! * [`vfh`] — Vector Field Histogram+;
//! * [`nd`] — Nearness Diagram navigation;
//! * [`snd`] — Smooth Nearness-Diagram navigation (laser only, a round robot);
//! * [`mbicp`] — not navigation: the base's odometry corrected by matching consecutive
//!   laser scans (metric-based ICP).

pub mod mbicp;
pub mod nd;
pub mod snd;
pub mod vfh;
