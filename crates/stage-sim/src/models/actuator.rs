//! `actuator` (spec §13). Stage 4.1.1 computes the joint position and a clamped velocity but
//! never applies it (the motion code is commented out), so the joint never moves; we report the
//! same values.

use super::ModelKind;
use crate::digest::Digest;
use crate::node::{ModelId, Node};
use crate::pose::Pose;
use crate::rng::SimRng;
use crate::view::View;
use worldfile::models as wm;

/// Actuator joint type: the worldfile crate's `actuator_type` (one vocabulary for every crate).
pub use worldfile::models::ActuatorType as ActuatorKind;

/// Actuator properties (spec §13).
#[derive(Clone, Debug, PartialEq)]
pub struct ActuatorDesc {
    /// Joint type.
    pub kind: ActuatorKind,
    /// Unit axis for linear joints.
    pub axis: [f64; 3],
    /// Lower limit.
    pub min_position: f64,
    /// Upper limit.
    pub max_position: f64,
    /// Speed limit.
    pub max_speed: f64,
    /// Initial position.
    pub start_position: f64,
}

default_from_spec!(ActuatorDesc);

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
    /// The goal, which Stage reports as the speed: a position goal clamped to
    /// `[min_position, max_position]`, a speed goal as commanded (`max_speed` bounds only the
    /// computed velocity).
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

/// Actuator properties; a zero axis becomes (1, 0, 0) as in Stage.
pub(crate) fn desc_from_spec(a: &wm::ActuatorSpec, _: &mut SimRng) -> ActuatorDesc {
    let len = a.axis.iter().map(|v| v * v).sum::<f64>().sqrt();
    let axis = if len > 0.0 {
        [a.axis[0] / len, a.axis[1] / len, a.axis[2] / len]
    } else {
        [1.0, 0.0, 0.0]
    };
    ActuatorDesc {
        kind: a.actuator_type,
        axis,
        min_position: a.min_position,
        max_position: a.max_position,
        max_speed: a.max_speed,
        start_position: a.start_position.unwrap_or(0.0),
    }
}

pub(crate) fn start(desc: &ActuatorDesc, _: &Pose, _: &mut SimRng) -> ActuatorModel {
    ActuatorModel::new(desc.clone())
}

impl ModelKind for ActuatorModel {
    #[inline]
    fn update(&mut self, v: &View, _: ModelId, local: &Pose, _: &Node, _: &mut SimRng) {
        ActuatorModel::update(self, local, v.sim_time)
    }

    fn shutdown(&mut self) {
        ActuatorModel::shutdown(self)
    }

    /// Feeds the control mode, goal and joint state to the determinism digest.
    fn digest(&self, d: &mut Digest) {
        d.u64(self.mode as u64);
        d.f64(self.goal);
        let s = &self.data;
        d.u64(s.time_us);
        for v in [s.position, s.speed, s.computed_velocity] {
            d.f64(v);
        }
        d.u64(s.moving as u64);
    }
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

    /// One update (of a subscribed model) from the model's local pose, as Stage's
    /// `ModelActuator::Update`: a position goal is clamped to the position limits for good
    /// (and reported so), the velocity towards the goal to `max_speed`.
    pub fn update(&mut self, pose: &Pose, time_us: u64) {
        let c = &self.cfg;
        let pos = match c.kind {
            ActuatorKind::Linear => pose.x * c.axis[0] + pose.y * c.axis[1] + pose.z * c.axis[2],
            ActuatorKind::Rotational => pose.a,
        };
        let wanted = match self.mode {
            ActuatorMode::Velocity => {
                let g = self.goal;
                if (pos <= c.min_position && g < 0.0) || (pos >= c.max_position && g > 0.0) {
                    0.0
                } else {
                    g
                }
            }
            ActuatorMode::Position => {
                // in Stage's order: below the minimum first (so min wins if min > max)
                if self.goal < c.min_position {
                    self.goal = c.min_position;
                } else if self.goal > c.max_position {
                    self.goal = c.max_position;
                }
                self.goal - pos
            }
        };
        let vel = if wanted < -c.max_speed {
            -c.max_speed
        } else if wanted > c.max_speed {
            c.max_speed
        } else {
            wanted
        };
        self.data = ActuatorData {
            time_us,
            position: pos,
            speed: self.goal,
            computed_velocity: vel,
            moving: self.goal != 0.0,
        };
    }

    /// The last subscriber left: Stage zeroes the goal (the control mode stays).
    pub fn shutdown(&mut self) {
        self.goal = 0.0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn joint(min: f64, max: f64, max_speed: f64) -> ActuatorModel {
        ActuatorModel::new(ActuatorDesc {
            kind: ActuatorKind::Linear,
            axis: [1.0, 0.0, 0.0],
            min_position: min,
            max_position: max,
            max_speed,
            start_position: 0.0,
        })
    }

    #[test]
    fn a_position_goal_is_clamped_to_the_limits_and_reported_clamped() {
        let mut a = joint(0.0, 0.5, 1.0);
        a.mode = ActuatorMode::Position;
        a.goal = 1.0;
        a.update(&Pose::ZERO, 100);
        assert_eq!(a.goal, 0.5, "the goal itself is clamped");
        assert_eq!(a.data.speed, 0.5);
        assert_eq!(a.data.computed_velocity, 0.5);
        assert!(a.data.moving);
        a.goal = -2.0;
        a.update(&Pose::ZERO, 200);
        assert_eq!((a.data.speed, a.data.computed_velocity), (0.0, 0.0));
        assert!(!a.data.moving, "clamped to 0: idle");
        // the joint does not move in Stage 4.1.1: the position stays where the pose puts it
        assert_eq!(a.data.position, 0.0);
    }

    #[test]
    fn max_speed_bounds_the_velocity_not_the_reported_goal() {
        let mut a = joint(-1.0, 1.0, 0.25);
        a.mode = ActuatorMode::Velocity;
        a.goal = 3.0;
        a.update(&Pose::ZERO, 100);
        assert_eq!(a.data.speed, 3.0);
        assert_eq!(a.data.computed_velocity, 0.25);
        a.mode = ActuatorMode::Position;
        a.goal = -0.8;
        a.update(&Pose::ZERO, 200);
        assert_eq!((a.data.speed, a.data.computed_velocity), (-0.8, -0.25));
    }

    #[test]
    fn a_speed_goal_stops_at_a_limit_it_pushes_against() {
        let mut a = joint(0.0, 0.5, 1.0);
        a.mode = ActuatorMode::Velocity;
        a.goal = -0.5;
        a.update(&Pose::ZERO, 100);
        assert_eq!(a.data.computed_velocity, 0.0, "at the minimum, moving down");
        assert_eq!(a.data.speed, -0.5, "the goal is reported as commanded");
        a.goal = 0.5;
        a.update(&Pose::ZERO, 200);
        assert_eq!(a.data.computed_velocity, 0.5);
        a.shutdown();
        a.update(&Pose::ZERO, 300);
        assert_eq!(a.data.speed, 0.0);
        assert!(!a.data.moving);
    }
}
