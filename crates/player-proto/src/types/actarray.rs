//! The `actarray` interface (53): actuator arrays.

use super::{Orientation3d, Point3d};

xdr_struct! {
    /// One actuator's state.
    pub struct ActarrayActuator = "player_actarray_actuator_t" {
        /// Position (m or rad).
        position: f32,
        /// Speed.
        speed: f32,
        /// Acceleration.
        acceleration: f32,
        /// Current (A).
        current: f32,
        /// `PLAYER_ACTARRAY_ACTSTATE_*` bits.
        state: u8,
    }

    /// Actuator states (DATA STATE).
    pub struct ActarrayDataState = "player_actarray_data_t" {
        /// One entry per actuator.
        actuators: Vec<ActarrayActuator>,
        /// Motor power state.
        motor_state: u8,
    }

    /// One actuator's geometry.
    pub struct ActarrayActuatorgeom = "player_actarray_actuatorgeom_t" {
        /// `PLAYER_ACTARRAY_TYPE_*`.
        kind ("type"): u8,
        /// Length (m).
        length: f32,
        /// Orientation.
        orientation: Orientation3d,
        /// Axis of motion.
        axis: Point3d,
        /// Minimum position.
        min: f32,
        /// Centre position.
        centre: f32,
        /// Maximum position.
        max: f32,
        /// Home position.
        home: f32,
        /// Configured speed.
        config_speed: f32,
        /// Has brakes.
        hasbrakes: u8,
    }

    /// Array geometry (GET_GEOM reply).
    pub struct ActarrayGeom = "player_actarray_geom_t" {
        /// One entry per actuator.
        actuators: Vec<ActarrayActuatorgeom>,
        /// Base position.
        base_pos: Point3d,
        /// Base orientation.
        base_orientation: Orientation3d,
    }

    /// Move one joint to a position.
    pub struct ActarrayPositionCmd = "player_actarray_position_cmd_t" {
        /// Joint.
        joint: i32,
        /// Target position.
        position: f32,
    }

    /// Move every joint to a position.
    pub struct ActarrayMultiPositionCmd = "player_actarray_multi_position_cmd_t" {
        /// One target per joint.
        positions: Vec<f32>,
    }

    /// Move one joint at a speed.
    pub struct ActarraySpeedCmd = "player_actarray_speed_cmd_t" {
        /// Joint.
        joint: i32,
        /// Speed.
        speed: f32,
    }

    /// Move every joint at a speed.
    pub struct ActarrayMultiSpeedCmd = "player_actarray_multi_speed_cmd_t" {
        /// One speed per joint.
        speeds: Vec<f32>,
    }

    /// Home a joint (-1: all).
    pub struct ActarrayHomeCmd = "player_actarray_home_cmd_t" {
        /// Joint.
        joint: i32,
    }

    /// Set one joint's current.
    pub struct ActarrayCurrentCmd = "player_actarray_current_cmd_t" {
        /// Joint.
        joint: i32,
        /// Current.
        current: f32,
    }

    /// Set every joint's current.
    pub struct ActarrayMultiCurrentCmd = "player_actarray_multi_current_cmd_t" {
        /// One current per joint.
        currents: Vec<f32>,
    }

    /// Power on/off.
    pub struct ActarrayPowerConfig = "player_actarray_power_config_t" {
        /// 0 off, otherwise on.
        value: u8,
    }

    /// Brakes on/off.
    pub struct ActarrayBrakesConfig = "player_actarray_brakes_config_t" {
        /// 0 off, otherwise on.
        value: u8,
    }

    /// A joint's speed for position moves.
    pub struct ActarraySpeedConfig = "player_actarray_speed_config_t" {
        /// Joint.
        joint: i32,
        /// Speed.
        speed: f32,
    }

    /// A joint's acceleration.
    pub struct ActarrayAccelConfig = "player_actarray_accel_config_t" {
        /// Joint.
        joint: i32,
        /// Acceleration.
        accel: f32,
    }
}
