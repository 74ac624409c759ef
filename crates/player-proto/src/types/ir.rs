//! The `ir` interface (22).

use super::Pose3d;

xdr_struct! {
    /// Voltages and ranges (DATA RANGES).
    pub struct IrDataRanges = "player_ir_data_t" {
        /// Raw voltages.
        voltages: Vec<f32>,
        /// Ranges (m).
        ranges: Vec<f32>,
    }

    /// Sensor poses (POSE reply).
    pub struct IrPose = "player_ir_pose_t" {
        /// One pose per sensor.
        poses: Vec<Pose3d>,
    }

    /// Power on/off.
    pub struct IrPowerReq = "player_ir_power_req_t" {
        /// 0 off, otherwise on.
        state: u8,
    }
}
