//! The `fiducial` interface (10).

use super::{Bbox2d, Bbox3d, Pose3d};

xdr_struct! {
    /// One detected fiducial (100 bytes on the wire).
    pub struct FiducialItem = "player_fiducial_item_t" {
        /// Fiducial id (-1 when not identifiable).
        id: i32,
        /// Pose relative to the sensor.
        pose: Pose3d,
        /// Pose uncertainty.
        upose: Pose3d,
    }

    /// Detected fiducials (DATA SCAN).
    pub struct FiducialDataScan = "player_fiducial_data_t" {
        /// The detections.
        fiducials: Vec<FiducialItem>,
    }

    /// Sensor geometry (GET_GEOM reply).
    pub struct FiducialGeom = "player_fiducial_geom_t" {
        /// Pose.
        pose: Pose3d,
        /// Size.
        size: Bbox3d,
        /// Size of the fiducials.
        fiducial_size: Bbox2d,
    }

    /// Field of view.
    pub struct FiducialFov = "player_fiducial_fov_t" {
        /// Minimum range (m).
        min_range: f32,
        /// Maximum range (m).
        max_range: f32,
        /// View angle (rad).
        view_angle: f32,
    }

    /// The id a sensor's own fiducial shows.
    pub struct FiducialId = "player_fiducial_id_t" {
        /// Id.
        id: u32,
    }
}
