//! The `ptz` interface (8): pan-tilt-zoom units.

use super::{Bbox3d, Pose3d};

xdr_struct! {
    /// Current state (DATA STATE).
    pub struct PtzDataState = "player_ptz_data_t" {
        /// Pan (rad).
        pan: f32,
        /// Tilt (rad).
        tilt: f32,
        /// Field of view (rad).
        zoom: f32,
        /// Pan speed (rad/s).
        panspeed: f32,
        /// Tilt speed (rad/s).
        tiltspeed: f32,
        /// Driver-specific status.
        status: u32,
    }

    /// Absolute command (CMD STATE).
    pub struct PtzCmdState = "player_ptz_cmd_t" {
        /// Pan (rad).
        pan: f32,
        /// Tilt (rad).
        tilt: f32,
        /// Field of view (rad).
        zoom: f32,
        /// Pan speed (rad/s).
        panspeed: f32,
        /// Tilt speed (rad/s).
        tiltspeed: f32,
    }

    /// Status (STATUS reply).
    pub struct PtzReqStatus = "player_ptz_req_status_t" {
        /// Driver-specific status.
        status: u32,
    }

    /// Geometry (GEOM reply, DATA GEOM).
    pub struct PtzGeom = "player_ptz_geom_t" {
        /// Pose.
        pos: Pose3d,
        /// Size.
        size: Bbox3d,
    }

    /// Unit-specific command and reply.
    pub struct PtzReqGeneric = "player_ptz_req_generic_t" {
        /// Command words.
        config: Vec<u32>,
    }

    /// Position or velocity control.
    pub struct PtzReqControlMode = "player_ptz_req_control_mode_t" {
        /// `PLAYER_PTZ_VELOCITY_CONTROL` or `PLAYER_PTZ_POSITION_CONTROL`.
        mode: u32,
    }
}
