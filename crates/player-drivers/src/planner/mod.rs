//! Path planners: drivers that provide a `planner` device.

pub mod wavefront;
