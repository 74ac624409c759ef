//! `vfh`: Vector Field Histogram Plus local navigation (Player 3.0.2's
//! `server/drivers/position/vfh`).

pub mod algorithm;
pub mod navigator;
pub mod ranges;
