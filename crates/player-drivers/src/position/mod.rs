//! Player's `server/drivers/position/`: drivers that provide a `position2d` over another one,
//! adding navigation (`vfh`).

pub mod vfh;
