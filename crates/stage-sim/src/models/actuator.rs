//! `actuator` (spec §13). Stage 4.1.1 computes the joint position and a clamped velocity but
//! never applies it (the motion code is commented out), so the joint never moves; we report the
//! same values.

use crate::desc::{ActuatorDesc, ActuatorKind};
use crate::pose::Pose;

/// Actuator control mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ActuatorMode {
    /// Goal is a speed.
    Velocity,
    /// Goal is a position.
    Position,
}

/// What Player's `actarray` reports.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ActuatorData {
    /// Sim time of the update (µs).
    pub time_us: u64,
    /// Joint position (projection of the pose on the axis, or the heading).
    pub position: f64,
    /// The goal (Stage reports the goal as the speed).
    pub speed: f64,
    /// Velocity Stage computes (and does not apply).
    pub computed_velocity: f64,
    /// Moving iff the goal is non-zero.
    pub moving: bool,
}

/// Actuator state.
#[derive(Clone, Debug)]
pub struct ActuatorModel {
    /// Configuration.
    pub cfg: ActuatorDesc,
    /// Control mode.
    pub mode: ActuatorMode,
    /// Goal.
    pub goal: f64,
    /// Latest data.
    pub data: ActuatorData,
}

impl ActuatorModel {
    /// An idle actuator.
    pub fn new(cfg: ActuatorDesc) -> Self {
        ActuatorModel {
            cfg,
            mode: ActuatorMode::Velocity,
            goal: 0.0,
            data: ActuatorData::default(),
        }
    }

    /// One update from the model's local pose.
    pub fn update(&mut self, pose: &Pose, time_us: u64) {
        let c = &self.cfg;
        let pos = match c.kind {
            ActuatorKind::Linear => pose.x * c.axis[0] + pose.y * c.axis[1] + pose.z * c.axis[2],
            ActuatorKind::Rotational => pose.a,
        };
        let vel = match self.mode {
            ActuatorMode::Velocity => {
                let v = self.goal.clamp(-c.max_speed, c.max_speed);
                if (pos <= c.min_position && v < 0.0) || (pos >= c.max_position && v > 0.0) {
                    0.0
                } else {
                    v
                }
            }
            ActuatorMode::Position => (self.goal - pos).clamp(-c.max_speed, c.max_speed),
        };
        self.data = ActuatorData {
            time_us,
            position: pos,
            speed: self.goal,
            computed_velocity: vel,
            moving: self.goal != 0.0,
        };
    }
}
