//! Per-type model behaviour and the data each type publishes.

pub mod actuator;
pub mod blobfinder;
pub mod camera;
pub mod fiducial;
pub mod gripper;
pub mod position;
pub mod ranger;
