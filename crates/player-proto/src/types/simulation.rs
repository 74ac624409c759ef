//! The `simulation` interface (31).

use super::{Pose2d, Pose3d};
use crate::xdr::Text;

xdr_struct! {
    /// A model's planar pose (GET_POSE2D / SET_POSE2D).
    pub struct SimulationPose2dReq = "player_simulation_pose2d_req_t" {
        /// Model name, NUL counted.
        name: Text,
        /// Pose in the parent frame.
        pose: Pose2d,
    }

    /// A model's pose in space (GET_POSE3D / SET_POSE3D).
    pub struct SimulationPose3dReq = "player_simulation_pose3d_req_t" {
        /// Model name, NUL counted.
        name: Text,
        /// Pose in the parent frame.
        pose: Pose3d,
        /// Simulated time (µs under Stage).
        simtime: f64,
    }

    /// A model property (GET_PROPERTY / SET_PROPERTY).
    pub struct SimulationPropertyReq = "player_simulation_property_req_t" {
        /// Model name, NUL counted.
        name: Text,
        /// Property name, NUL counted.
        prop: Text,
        /// Index (unused by Stage).
        index: u32,
        /// Raw host-memory bytes of the value (little-endian floats from x86 clients): a `char*`
        /// on the wire, but binary, so kept as bytes.
        value: Vec<u8>,
    }
}
