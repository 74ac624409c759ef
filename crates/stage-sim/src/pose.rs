//! Poses and Stage's heading fold, from the `pose` crate every crate shares (stage-models.md
//! §1.1); re-exported here under the paths the simulator's modules and its users name.

pub use ::pose::Pose;
pub use ::pose::angle::normalize;
