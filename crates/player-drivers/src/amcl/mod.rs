//! `amcl`: adaptive Monte-Carlo localisation, as Player 3.0.2's driver.
//!
//! The robot's pose is tracked by a particle filter ([`pf`]) whose particle count adapts by
//! KLD-sampling: many particles while the pose is uncertain, few once it is known.

pub mod histogram;
pub mod pdf;
pub mod pf;
pub mod pose;
