//! The `gripper` interface (3).

use super::{Bbox3d, Pose3d};

xdr_struct! {
    /// Gripper state (`PLAYER_GRIPPER_STATE_*`), break-beam bits and stored objects.
    pub struct GripperDataState = "player_gripper_data_t" {
        /// Open, closed, moving or error.
        state: u8,
        /// Break-beam bit mask.
        beams: u32,
        /// Objects in storage.
        stored: u8,
    }

    /// Gripper geometry (GET_GEOM reply).
    pub struct GripperGeom = "player_gripper_geom_t" {
        /// Pose relative to the parent.
        pose: Pose3d,
        /// Outside size.
        outer_size: Bbox3d,
        /// Inside size of the open fingers.
        inner_size: Bbox3d,
        /// Number of break beams.
        num_beams: u8,
        /// Storage capacity.
        capacity: u8,
    }
}
