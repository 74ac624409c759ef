//! The `sonar` interface (5), deprecated upstream in favour of ranger.

use super::Pose3d;

xdr_struct! {
    /// Range readings (m, floats).
    pub struct SonarDataRanges = "player_sonar_data_t" {
        /// One range per transducer.
        ranges: Vec<f32>,
    }

    /// Transducer poses (GET_GEOM reply, DATA GEOM).
    pub struct SonarGeom = "player_sonar_geom_t" {
        /// One pose per transducer.
        poses: Vec<Pose3d>,
    }

    /// Sonar power on/off.
    pub struct SonarPowerConfig = "player_sonar_power_config_t" {
        /// 0 off, otherwise on.
        state: u8,
    }
}
