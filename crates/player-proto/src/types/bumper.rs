//! The `bumper` interface (14).

use super::Pose3d;

xdr_struct! {
    /// Bumper states, one byte each (DATA STATE).
    pub struct BumperDataState = "player_bumper_data_t" {
        /// 1 pressed, 0 not.
        bumpers: Vec<u8>,
    }

    /// One bumper's geometry.
    pub struct BumperDefine = "player_bumper_define_t" {
        /// Pose of the bumper's centre.
        pose: Pose3d,
        /// Length (m).
        length: f32,
        /// Radius of curvature (m).
        radius: f32,
    }

    /// Bumper geometry (GET_GEOM reply, DATA GEOM).
    pub struct BumperGeom = "player_bumper_geom_t" {
        /// One entry per bumper.
        bumper_def: Vec<BumperDefine>,
    }
}
