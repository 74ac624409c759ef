//! The `position2d` interface (4): planar mobile bases.

use super::{Bbox3d, Pose2d, Pose3d};

xdr_struct! {
    /// Odometric pose, velocity and stall flag (DATA STATE).
    pub struct Position2dDataState = "player_position2d_data_t" {
        /// Pose estimate (m, m, rad).
        pos: Pose2d,
        /// Velocity in the robot frame (m/s, m/s, rad/s).
        vel: Pose2d,
        /// 1 when stalled.
        stall: u8,
    }

    /// Velocity command.
    pub struct Position2dCmdVel = "player_position2d_cmd_vel_t" {
        /// Velocity (m/s, m/s, rad/s).
        vel: Pose2d,
        /// Motor state.
        state: u8,
    }

    /// Position command.
    pub struct Position2dCmdPos = "player_position2d_cmd_pos_t" {
        /// Goal pose.
        pos: Pose2d,
        /// Velocity to move at.
        vel: Pose2d,
        /// Motor state.
        state: u8,
    }

    /// Car-like command: speed and turning angle.
    pub struct Position2dCmdCar = "player_position2d_cmd_car_t" {
        /// Forward speed (m/s).
        velocity: f64,
        /// Turning angle (rad); Stage uses it as a turn rate.
        angle: f64,
    }

    /// Speed and absolute heading command.
    pub struct Position2dCmdVelHead = "player_position2d_cmd_vel_head_t" {
        /// Forward speed (m/s).
        velocity: f64,
        /// Heading (rad).
        angle: f64,
    }

    /// Robot geometry (GET_GEOM reply, DATA GEOM).
    pub struct Position2dGeom = "player_position2d_geom_t" {
        /// Pose of the base relative to the robot's origin.
        pose: Pose3d,
        /// Size.
        size: Bbox3d,
    }

    /// Motor power on/off.
    pub struct Position2dPowerConfig = "player_position2d_power_config_t" {
        /// 0 off, otherwise on.
        state: u8,
    }

    /// Velocity control mode.
    pub struct Position2dVelocityModeConfig = "player_position2d_velocity_mode_config_t" {
        /// Driver-specific mode.
        value: u32,
    }

    /// Position control mode.
    pub struct Position2dPositionModeReq = "player_position2d_position_mode_req_t" {
        /// 0 velocity, 1 position.
        state: u32,
    }

    /// Sets the odometry estimate.
    pub struct Position2dSetOdomReq = "player_position2d_set_odom_req_t" {
        /// New estimate.
        pose: Pose2d,
    }

    /// Speed PID gains.
    pub struct Position2dSpeedPidReq = "player_position2d_speed_pid_req_t" {
        /// Proportional gain.
        kp: f32,
        /// Integral gain.
        ki: f32,
        /// Derivative gain.
        kd: f32,
    }

    /// Position PID gains.
    pub struct Position2dPositionPidReq = "player_position2d_position_pid_req_t" {
        /// Proportional gain.
        kp: f32,
        /// Integral gain.
        ki: f32,
        /// Derivative gain.
        kd: f32,
    }

    /// Speed profile for position control.
    pub struct Position2dSpeedProfReq = "player_position2d_speed_prof_req_t" {
        /// Maximum speed (m/s).
        speed: f32,
        /// Maximum acceleration (m/s²).
        acc: f32,
    }
}
