//! The `ranger` interface (62). Doubles, unlike laser and sonar.

use super::{Bbox3d, Pose3d};

xdr_struct! {
    /// Scan configuration (GET_CONFIG / SET_CONFIG).
    pub struct RangerConfig = "player_ranger_config_t" {
        /// Start angle (rad).
        min_angle: f64,
        /// End angle (rad).
        max_angle: f64,
        /// Angular resolution (rad).
        angular_res: f64,
        /// Minimum range (m).
        min_range: f64,
        /// Maximum range (m).
        max_range: f64,
        /// Range resolution (m).
        range_res: f64,
        /// Scan frequency (Hz).
        frequency: f64,
    }

    /// Device and element geometry (GET_GEOM reply, DATA GEOM).
    pub struct RangerGeom = "player_ranger_geom_t" {
        /// Device pose.
        pose: Pose3d,
        /// Device size.
        size: Bbox3d,
        /// One pose per sensor element.
        element_poses: Vec<Pose3d>,
        /// One size per sensor element.
        element_sizes: Vec<Bbox3d>,
    }

    /// Ranges (DATA RANGE).
    pub struct RangerDataRange = "player_ranger_data_range_t" {
        /// Ranges (m).
        ranges: Vec<f64>,
    }

    /// Ranges with optional geometry and configuration (DATA RANGESTAMPED).
    pub struct RangerDataRangestamped = "player_ranger_data_rangestamped_t" {
        /// The ranges.
        data: RangerDataRange,
        /// Whether `geom` is valid.
        have_geom: u8,
        /// Geometry.
        geom: RangerGeom,
        /// Whether `config` is valid.
        have_config: u8,
        /// Configuration.
        config: RangerConfig,
    }

    /// Intensities (DATA INTNS).
    pub struct RangerDataIntns = "player_ranger_data_intns_t" {
        /// Intensities.
        intensities: Vec<f64>,
    }

    /// Intensities with optional geometry and configuration (DATA INTNSSTAMPED).
    pub struct RangerDataIntnsstamped = "player_ranger_data_intnsstamped_t" {
        /// The intensities.
        data: RangerDataIntns,
        /// Whether `geom` is valid.
        have_geom: u8,
        /// Geometry.
        geom: RangerGeom,
        /// Whether `config` is valid.
        have_config: u8,
        /// Configuration.
        config: RangerConfig,
    }

    /// Power on/off.
    pub struct RangerPowerConfig = "player_ranger_power_config_t" {
        /// 0 off, otherwise on.
        state: u8,
    }

    /// Intensity data on/off.
    pub struct RangerIntnsConfig = "player_ranger_intns_config_t" {
        /// 0 off, otherwise on.
        state: u8,
    }
}
