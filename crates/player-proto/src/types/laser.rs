//! The `laser` interface (6), deprecated upstream in favour of ranger. Floats, unlike ranger.

use super::{Bbox3d, Pose2d, Pose3d};
use crate::constants::PLAYER_LASER_MAX_FILTER_PARAMS;

xdr_struct! {
    /// A scan (DATA SCAN).
    pub struct LaserDataScan = "player_laser_data_t" {
        /// Start angle (rad).
        min_angle: f32,
        /// End angle (rad).
        max_angle: f32,
        /// Angular resolution (rad).
        resolution: f32,
        /// Maximum range (m).
        max_range: f32,
        /// Ranges (m).
        ranges: Vec<f32>,
        /// Intensities, byte-packed.
        intensity: Vec<u8>,
        /// Scan id.
        id: u32,
    }

    /// A scan with the pose it was taken at (DATA SCANPOSE).
    pub struct LaserDataScanpose = "player_laser_data_scanpose_t" {
        /// The scan.
        scan: LaserDataScan,
        /// Laser pose.
        pose: Pose2d,
    }

    /// A scan with an explicit bearing per range (DATA SCANANGLE).
    pub struct LaserDataScanangle = "player_laser_data_scanangle_t" {
        /// Maximum range (m).
        max_range: f32,
        /// Ranges (m).
        ranges: Vec<f32>,
        /// Bearings (rad).
        angles: Vec<f32>,
        /// Intensities, byte-packed.
        intensity: Vec<u8>,
        /// Scan id.
        id: u32,
    }

    /// Laser geometry (GET_GEOM reply).
    pub struct LaserGeom = "player_laser_geom_t" {
        /// Pose.
        pose: Pose3d,
        /// Size.
        size: Bbox3d,
    }

    /// Scan configuration (SET_CONFIG / GET_CONFIG).
    pub struct LaserConfig = "player_laser_config_t" {
        /// Start angle (rad).
        min_angle: f32,
        /// End angle (rad).
        max_angle: f32,
        /// Angular resolution (rad).
        resolution: f32,
        /// Maximum range (m).
        max_range: f32,
        /// Range resolution (m).
        range_res: f32,
        /// Intensity data on/off.
        intensity: u8,
        /// Scan frequency (Hz).
        scanning_frequency: f32,
    }

    /// Laser power on/off.
    pub struct LaserPowerConfig = "player_laser_power_config_t" {
        /// 0 off, otherwise on.
        state: u8,
    }

    /// Serial number (GET_ID reply).
    pub struct LaserGetIdConfig = "player_laser_get_id_config_t" {
        /// Serial number.
        serial_number: u32,
    }

    /// Internal filter settings.
    pub struct LaserSetFilterConfig = "player_laser_set_filter_config_t" {
        /// `PLAYER_LASER_FILTER_*`.
        filter_type: u8,
        /// At most `PLAYER_LASER_MAX_FILTER_PARAMS` parameters.
        parameters: Vec<f32> [max PLAYER_LASER_MAX_FILTER_PARAMS],
    }
}
