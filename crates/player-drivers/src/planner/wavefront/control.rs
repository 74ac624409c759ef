//! The wavefront driver's execution logic (the body of upstream's `Wavefront::Main` in
//! position-control mode): when to (re)plan, which waypoint to drive to, when a waypoint or
//! the goal is reached, and what the planner reports. Plain state, no I/O: the driver feeds
//! it poses and plans and sends the motions it returns.

use player_proto::{PlannerData, Pose2d};

/// Settings from the cfg (upstream defaults in [`super::WavefrontOptions`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ControlSettings {
    /// A waypoint (and the goal) is reached within this distance (m).
    pub dist_eps: f64,
    /// The goal's heading is reached within this angle (rad).
    pub ang_eps: f64,
    /// Replan after moving this far since the last plan (m); negative: never.
    pub replan_dist_thresh: f64,
    /// ...and at least this long since it (s); negative: never.
    pub replan_min_time: f64,
    /// Turn on the spot before every waypoint that lies more than 45 degrees off the
    /// robot's heading; otherwise only before the first real one.
    pub always_rotate: bool,
    /// Steer the robot with velocity commands towards a carrot on the plan, replanning every
    /// cycle (`velocity_control 1`), instead of sending waypoints as position goals.
    pub velocity: Option<VelocityGains>,
}

/// `velocity_control`'s gains (options `control_tv`, `control_av`, `control_a`), in m/s, rad/s
/// and rad.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VelocityGains {
    /// Translational speed at the nearest and at the farthest carrot (`control_tv`, default
    /// [0.1 0.5]).
    pub tv: (f64, f64),
    /// Turn rate for no heading error and for a half-turn error (`control_av`, default
    /// [10 90] degrees/s).
    pub av: (f64, f64),
    /// Largest heading error at which the robot still drives forward, for the nearest and the
    /// farthest carrot (`control_a`, default [5 20] degrees).
    pub a: (f64, f64),
}

impl Default for VelocityGains {
    fn default() -> VelocityGains {
        VelocityGains {
            tv: (0.1, 0.5),
            av: (10f64.to_radians(), 90f64.to_radians()),
            a: (5f64.to_radians(), 20f64.to_radians()),
        }
    }
}

/// How far ahead on the plan the carrot is looked for (m), and how much a near carrot is
/// penalised (upstream's fixed `maxd` and `distweight`).
pub const CARROT_MAX_DIST: f64 = 2.0;
/// See [`CARROT_MAX_DIST`].
pub const CARROT_DIST_WEIGHT: f64 = 10.0;

/// What the driver should send to the position device it drives.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Motion {
    /// Zero velocities (upstream's `StopPosition`).
    Stop,
    /// A position command to this pose, in the output device's (odometric) frame.
    GoTo(Pose2d),
    /// A velocity command: forward speed (m/s) and turn rate (rad/s) (velocity control).
    Velocity {
        /// Forward speed (m/s).
        tv: f64,
        /// Turn rate (rad/s).
        av: f64,
    },
}

/// Upstream's `angle_diff`: the signed difference `a - b`, in (-pi, pi].
pub use ::pose::angle::diff_rem_euclid as angle_diff;

/// Maps a pose from the localisation frame to the output device's frame, given where both
/// place the robot now (upstream's `LocalizeToPosition`): the waypoints are planned in the map
/// frame but the position device wants goals in its own odometry.
pub fn localize_to_position(position: Pose2d, localize: Pose2d, p: (f64, f64, f64)) -> Pose2d {
    let offset_a = angle_diff(position.pa, localize.pa);
    let (s, c) = offset_a.sin_cos();
    let off_x = position.px - (localize.px * c - localize.py * s);
    let off_y = position.py - (localize.px * s + localize.py * c);
    Pose2d {
        px: p.0 * c - p.1 * s + off_x,
        py: p.0 * s + p.1 * c + off_y,
        pa: p.2 + offset_a,
    }
}

/// The execution state (upstream's member variables of the same names).
#[derive(Clone, Debug)]
pub struct Control {
    settings: ControlSettings,
    /// Robot motion allowed (PLAYER_PLANNER_REQ_ENABLE).
    pub enabled: bool,
    stopped: bool,
    at_goal: bool,
    new_goal: bool,
    target: Pose2d,
    /// Pose from the output device (its odometry).
    position: Pose2d,
    /// Pose from the localisation device (the map frame).
    localize: Pose2d,
    waypoint: Pose2d,
    waypoint_odom: Pose2d,
    /// Index of the next waypoint to take, -1 when idle or done.
    curr_waypoint: i64,
    waypoints: Vec<(f64, f64)>,
    rotate_waypoint: bool,
    last_replan: (f64, f64, f64),
    /// A plan just came in: take its first waypoint on the next drive.
    fresh_plan: bool,
    /// Counts goals, so a plan for an earlier goal that finishes late is not taken.
    goal_seq: u64,
    /// Velocity control: which way the robot turns on the spot at the goal (0 not yet
    /// chosen; upstream's `rotate_dir`).
    rotate_dir: f64,
}

impl Control {
    /// Idle, at no goal, as upstream's `MainSetup` leaves it.
    pub fn new(settings: ControlSettings) -> Control {
        Control {
            settings,
            enabled: true,
            stopped: true,
            at_goal: true,
            new_goal: false,
            target: Pose2d::default(),
            position: Pose2d::default(),
            localize: Pose2d::default(),
            waypoint: Pose2d::default(),
            waypoint_odom: Pose2d::default(),
            curr_waypoint: -1,
            waypoints: Vec::new(),
            rotate_waypoint: false,
            last_replan: (0.0, 0.0, 0.0),
            goal_seq: 0,
            fresh_plan: false,
            rotate_dir: 0.0,
        }
    }

    /// A new goal (PLAYER_PLANNER_CMD_GOAL): planned for on the next cycle.
    pub fn set_goal(&mut self, goal: Pose2d) {
        self.target = goal;
        self.new_goal = true;
        self.at_goal = false;
        self.goal_seq += 1;
    }

    /// Which goal a plan started now is for (pass it back to [`Control::plan_ready`]).
    pub fn goal_seq(&self) -> u64 {
        self.goal_seq
    }

    /// The output device's pose.
    pub fn set_position(&mut self, pose: Pose2d) {
        self.position = pose;
    }

    /// The localisation device's pose.
    pub fn set_localize(&mut self, pose: Pose2d) {
        self.localize = pose;
    }

    /// Where the robot is, in the map frame.
    pub fn localize(&self) -> Pose2d {
        self.localize
    }

    /// The goal.
    pub fn target(&self) -> Pose2d {
        self.target
    }

    /// The current plan's waypoints (map frame).
    pub fn waypoints(&self) -> &[(f64, f64)] {
        &self.waypoints
    }

    /// Whether a plan is due at time `t`: a new goal, or (upstream's replan rule) the robot
    /// moved more than `replan_dist_thresh` and `replan_min_time` passed since the last plan
    /// while a goal is pending.
    pub fn wants_plan(&self, t: f64) -> bool {
        let s = &self.settings;
        let (lt, lx, ly) = self.last_replan;
        let moved = (self.localize.px - lx).hypot(self.localize.py - ly);
        let replan = s.replan_dist_thresh >= 0.0
            && moved > s.replan_dist_thresh
            && s.replan_min_time >= 0.0
            && t - lt > s.replan_min_time
            && !self.at_goal;
        // Velocity control plans every cycle until the goal is reached.
        let steering = s.velocity.is_some() && !self.at_goal;
        self.new_goal || replan || steering
    }

    /// Whether the next plan must be global (a new goal): otherwise a local plan may do.
    pub fn new_goal(&self) -> bool {
        self.new_goal
    }

    /// Velocity control between plans: once the goal is reached the robot is stopped (once);
    /// otherwise the last command stands until the next plan.
    pub fn steer_idle(&mut self) -> Option<Motion> {
        if self.at_goal { self.stop() } else { None }
    }

    /// Velocity control's step after the plan made this cycle for goal `seq` (upstream's
    /// `velocity_control` branch of `Wavefront::Main`): `global_ok` when a global plan was made
    /// (or a local one from an existing global path), `has_path` when a global path exists,
    /// `carrot` the point to steer for. At the goal (distance and heading) the robot stops
    /// and the plan is done; on top of it, it turns on the spot; elsewhere it turns towards
    /// the carrot and drives forward while the carrot lies within the allowed heading error,
    /// faster for a farther carrot.
    pub fn steer(
        &mut self,
        seq: u64,
        global_ok: bool,
        has_path: bool,
        carrot: Option<(f64, f64)>,
    ) -> Option<Motion> {
        let g = self.settings.velocity?;
        if seq != self.goal_seq {
            return None;
        }
        if global_ok {
            self.new_goal = false;
        }
        if !has_path || self.at_goal {
            return self.stop();
        }
        let l = self.localize;
        let goal_d = (l.px - self.target.px).hypot(l.py - self.target.py);
        if goal_d < self.settings.dist_eps
            && angle_diff(self.target.pa, l.pa).abs() < self.settings.ang_eps
        {
            self.new_goal = false;
            self.curr_waypoint = -1;
            self.at_goal = true;
            return self.stop();
        }
        let Some((wx, wy)) = carrot else {
            tracing::debug!("wavefront: failed to find a carrot");
            return self.stop();
        };
        // For clients: the plan is the robot and the carrot.
        self.curr_waypoint = 0;
        self.waypoints = vec![(l.px, l.py), (wx, wy)];
        self.waypoint = Pose2d {
            px: wx,
            py: wy,
            pa: 0.0,
        };
        let d = (l.px - wx).hypot(l.py - wy);
        let bearing = (wy - l.py).atan2(wx - l.px);
        let max_error = g.a.0 + (d / CARROT_MAX_DIST) * (g.a.1 - g.a.0);
        let ad = angle_diff(bearing, l.pa);
        let turn = g.av.0 + (ad.abs() / std::f64::consts::PI) * (g.av.1 - g.av.0);
        let (tv, av) = if goal_d < self.settings.dist_eps {
            // On top of the goal: turn on the spot, always the same way (upstream turns by the
            // carrot's bearing here, not the goal's heading).
            if self.rotate_dir == 0.0 {
                self.rotate_dir = if ad < 0.0 { -1.0 } else { 1.0 };
            }
            (0.0, self.rotate_dir * turn)
        } else {
            self.rotate_dir = 0.0;
            let tv = if ad.abs() > max_error {
                0.0
            } else {
                g.tv.0 + (d / CARROT_MAX_DIST) * (g.tv.1 - g.tv.0)
            };
            (tv, if ad < 0.0 { -turn } else { turn })
        };
        self.stopped = false;
        Some(Motion::Velocity { tv, av })
    }

    /// A plan for goal number `seq` made from `from` (the map-frame position planning started
    /// at, at time `t`). Empty `waypoints` means no path: a new goal is then abandoned
    /// (reported as not valid, the robot stopped); a replan that fails leaves the current
    /// plan in force. A plan for an earlier goal is dropped (the new goal is still due).
    pub fn plan_ready(&mut self, seq: u64, t: f64, from: (f64, f64), waypoints: Vec<(f64, f64)>) {
        if seq != self.goal_seq {
            return;
        }
        if waypoints.is_empty() {
            tracing::warn!(
                "wavefront: no path from ({:.3}, {:.3}) to ({:.3}, {:.3}, {:.1} deg)",
                from.0,
                from.1,
                self.target.px,
                self.target.py,
                self.target.pa.to_degrees()
            );
            if self.new_goal || self.curr_waypoint < 0 {
                self.new_goal = false;
                self.curr_waypoint = -1;
                self.waypoints.clear();
            }
        } else {
            self.waypoints = waypoints;
            self.curr_waypoint = 0;
            // Upstream sets `new_goal` again here so that its driving step, later in the same
            // cycle, takes the first waypoint at once; a flag of its own keeps that from
            // asking for yet another plan when planning and driving are separate calls.
            self.new_goal = false;
            self.fresh_plan = true;
        }
        self.last_replan = (t, from.0, from.1);
    }

    /// One control cycle while not planning: the motions to send (none, a stop, or a
    /// position goal; upstream re-sends the current waypoint every cycle).
    pub fn drive(&mut self) -> Option<Motion> {
        if !self.enabled {
            return self.stop();
        }
        let s = self.settings;
        let going_for_target = self.curr_waypoint == self.waypoints.len() as i64;
        let to_goal = (self.localize.px - self.target.px).hypot(self.localize.py - self.target.py);
        let angle = angle_diff(self.waypoint_odom.pa, self.position.pa).abs();
        if going_for_target && to_goal < s.dist_eps && angle < s.ang_eps {
            self.curr_waypoint = -1;
            self.fresh_plan = false;
            self.at_goal = true;
            return self.stop();
        }
        if self.curr_waypoint < 0 {
            return self.stop();
        }
        let to_waypoint =
            (self.localize.px - self.waypoint.px).hypot(self.localize.py - self.waypoint.py);
        let turned =
            angle_diff(self.waypoint_odom.pa, self.position.pa).abs() < std::f64::consts::FRAC_PI_4;
        if self.fresh_plan
            || (self.rotate_waypoint && turned)
            || (!self.rotate_waypoint && to_waypoint < s.dist_eps)
        {
            if going_for_target {
                // The last waypoint is reached but not the goal's heading: wait.
                return None;
            }
            let (wx, wy) = self.waypoints[self.curr_waypoint as usize];
            self.waypoint = Pose2d {
                px: wx,
                py: wy,
                pa: self.target.pa,
            };
            self.curr_waypoint += 1;
            self.rotate_waypoint = false;
            if s.always_rotate || self.curr_waypoint == 2 {
                let dist = (wx - self.localize.px).hypot(wy - self.localize.py);
                let heading = (wy - self.localize.py).atan2(wx - self.localize.px);
                if dist > s.dist_eps
                    && angle_diff(heading, self.localize.pa).abs() > std::f64::consts::FRAC_PI_4
                {
                    // Turn on the spot towards it first, then come back for it.
                    self.waypoint = Pose2d {
                        px: self.localize.px,
                        py: self.localize.py,
                        pa: heading,
                    };
                    self.curr_waypoint -= 1;
                    self.rotate_waypoint = true;
                }
            }
            self.fresh_plan = false;
        }
        let w = self.waypoint;
        self.waypoint_odom = localize_to_position(self.position, self.localize, (w.px, w.py, w.pa));
        self.stopped = false;
        Some(Motion::GoTo(self.waypoint_odom))
    }

    /// A stop, unless already stopped.
    pub fn stop(&mut self) -> Option<Motion> {
        if self.stopped {
            None
        } else {
            self.stopped = true;
            Some(Motion::Stop)
        }
    }

    /// Marks the robot as moving (so the next stop is sent), e.g. after setup.
    pub fn assume_moving(&mut self) {
        self.stopped = false;
    }

    /// The planner's state (upstream's `PutPlannerData`).
    pub fn data(&self) -> PlannerData {
        let valid = !self.waypoints.is_empty();
        let done = valid && self.curr_waypoint < 0;
        let mut d = PlannerData {
            valid: valid.into(),
            done: done.into(),
            pos: self.localize,
            goal: self.target,
            ..PlannerData::default()
        };
        if valid && !done {
            d.waypoint = self.waypoint;
            d.waypoint_idx = self.curr_waypoint as i32;
            d.waypoints_count = self.waypoints.len() as u32;
        }
        d
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::pose;

    fn settings() -> ControlSettings {
        ControlSettings {
            dist_eps: 0.5,
            ang_eps: 10f64.to_radians(),
            replan_dist_thresh: 2.0,
            replan_min_time: 2.0,
            always_rotate: true,
            velocity: None,
        }
    }

    fn at(c: &mut Control, p: Pose2d) {
        c.set_position(p);
        c.set_localize(p);
    }

    #[test]
    fn angles_wrap() {
        assert!((angle_diff(3.0, -3.0) - (6.0 - 2.0 * std::f64::consts::PI)).abs() < 1e-12);
        assert!((angle_diff(0.5, 0.25) - 0.25).abs() < 1e-12);
        assert!((angle_diff(-0.5, 0.25) + 0.75).abs() < 1e-12);
    }

    #[test]
    fn localisation_frame_maps_to_odometry() {
        // Odometry says (1, 0, 0) where the map says (5, 5, 90 deg).
        let p = localize_to_position(
            pose(1.0, 0.0, 0.0),
            pose(5.0, 5.0, std::f64::consts::FRAC_PI_2),
            (5.0, 6.0, std::f64::consts::FRAC_PI_2),
        );
        // One metre ahead in the map is one metre ahead in odometry.
        assert!(
            (p.px - 2.0).abs() < 1e-9 && p.py.abs() < 1e-9 && p.pa.abs() < 1e-9,
            "{p:?}"
        );
    }

    #[test]
    fn drives_waypoint_by_waypoint_to_the_goal() {
        let mut c = Control::new(settings());
        at(&mut c, pose(0.0, 0.0, 0.0));
        assert!(!c.wants_plan(0.0));
        c.set_goal(pose(4.0, 2.0, 0.0));
        assert!(c.wants_plan(0.0));
        c.plan_ready(
            c.goal_seq(),
            0.0,
            (0.0, 0.0),
            vec![(0.0, 0.0), (4.0, 0.0), (4.0, 2.0)],
        );
        assert!(!c.wants_plan(0.1));
        // Waypoint 0 is where the robot is.
        assert_eq!(c.drive(), Some(Motion::GoTo(pose(0.0, 0.0, 0.0))));
        assert_eq!(c.data().waypoint_idx, 1);
        assert_eq!(c.drive(), Some(Motion::GoTo(pose(4.0, 0.0, 0.0))));
        at(&mut c, pose(3.8, 0.0, 0.0));
        // (4, 2) is 90 degrees off the heading: turn first.
        let Some(Motion::GoTo(turn)) = c.drive() else {
            panic!()
        };
        assert!((turn.pa - (2.0f64).atan2(0.2)).abs() < 1e-9 && turn.px == 3.8);
        at(&mut c, pose(3.8, 0.0, 1.4));
        assert_eq!(c.drive(), Some(Motion::GoTo(pose(4.0, 2.0, 0.0))));
        let d = c.data();
        assert_eq!((d.valid, d.done, d.waypoints_count), (1, 0, 3));
        at(&mut c, pose(4.0, 1.9, 1.4));
        // Close enough, but still heading the wrong way: wait for the turn.
        assert_eq!(c.drive(), None);
        at(&mut c, pose(4.0, 1.9, 0.05));
        assert_eq!(c.drive(), Some(Motion::Stop));
        let d = c.data();
        assert_eq!((d.valid, d.done, d.waypoint_idx), (1, 1, 0));
        assert_eq!(c.drive(), None);
        assert!(!c.wants_plan(100.0));
    }

    #[test]
    fn a_late_plan_for_an_old_goal_is_dropped() {
        let mut c = Control::new(settings());
        c.set_goal(pose(3.0, 0.0, 0.0));
        let old = c.goal_seq();
        c.set_goal(pose(0.0, 3.0, 0.0));
        c.plan_ready(old, 0.0, (0.0, 0.0), vec![(0.0, 0.0), (3.0, 0.0)]);
        assert!(c.wants_plan(0.1));
        assert_eq!(c.data().valid, 0);
        c.plan_ready(c.goal_seq(), 0.1, (0.0, 0.0), vec![(0.0, 0.0), (0.0, 3.0)]);
        assert_eq!(c.waypoints(), &[(0.0, 0.0), (0.0, 3.0)]);
    }

    #[test]
    fn replans_after_moving_far_enough_for_long_enough() {
        let mut c = Control::new(settings());
        at(&mut c, pose(0.0, 0.0, 0.0));
        c.set_goal(pose(10.0, 0.0, 0.0));
        c.plan_ready(c.goal_seq(), 1.0, (0.0, 0.0), vec![(0.0, 0.0), (10.0, 0.0)]);
        c.drive();
        at(&mut c, pose(2.5, 0.0, 0.0));
        assert!(!c.wants_plan(2.5));
        assert!(c.wants_plan(3.5));
        at(&mut c, pose(1.5, 0.0, 0.0));
        assert!(!c.wants_plan(3.5));
    }

    #[test]
    fn no_path_is_reported_and_stops() {
        let mut c = Control::new(settings());
        c.assume_moving();
        c.set_goal(pose(10.0, 0.0, 0.0));
        c.plan_ready(c.goal_seq(), 0.0, (0.0, 0.0), Vec::new());
        assert!(!c.wants_plan(0.1));
        assert_eq!(c.drive(), Some(Motion::Stop));
        let d = c.data();
        assert_eq!((d.valid, d.done, d.waypoint_idx), (0, 0, 0));
        assert_eq!(d.goal, pose(10.0, 0.0, 0.0));
    }

    #[test]
    fn velocity_control_steers_for_the_carrot_and_stops_at_the_goal() {
        let mut c = Control::new(ControlSettings {
            velocity: Some(VelocityGains::default()),
            ..settings()
        });
        c.set_goal(pose(3.0, 0.0, 0.0));
        at(&mut c, pose(0.0, 0.0, 0.0));
        assert!(c.wants_plan(0.0) && c.new_goal());
        let seq = c.goal_seq();
        // Straight ahead, 1 m: half way between the speed limits, the least turn.
        let Some(Motion::Velocity { tv, av }) = c.steer(seq, true, true, Some((1.0, 0.0))) else {
            panic!()
        };
        assert!((tv - 0.3).abs() < 1e-12 && (av - 10f64.to_radians()).abs() < 1e-12);
        assert!(!c.new_goal(), "a global plan was made");
        assert!(c.wants_plan(0.1), "plans every cycle until there");
        // A carrot to the left, beyond the allowed heading error: turn on the spot.
        let Some(Motion::Velocity { tv, av }) = c.steer(seq, false, true, Some((0.0, 1.0))) else {
            panic!()
        };
        assert_eq!(tv, 0.0);
        assert!(
            (av - 50f64.to_radians()).abs() < 1e-12,
            "{}",
            av.to_degrees()
        );
        let d = c.data();
        assert_eq!((d.valid, d.done, d.waypoints_count), (1, 0, 2));
        assert_eq!((d.waypoint.px, d.waypoint.py), (0.0, 1.0));
        // To the right, the turn is negative.
        let Some(Motion::Velocity { av, .. }) = c.steer(seq, false, true, Some((0.0, -1.0))) else {
            panic!()
        };
        assert!(av < 0.0);
        // No carrot: stop. A plan for an older goal: nothing.
        assert_eq!(c.steer(seq, false, true, None), Some(Motion::Stop));
        assert_eq!(c.steer(seq - 1, false, true, Some((1.0, 0.0))), None);
        // At the goal, heading within epsilon: stopped, done, no more plans.
        at(&mut c, pose(2.8, 0.1, 0.05));
        c.assume_moving();
        assert_eq!(
            c.steer(seq, false, true, Some((3.0, 0.0))),
            Some(Motion::Stop)
        );
        assert_eq!(c.data().done, 1);
        assert!(!c.wants_plan(10.0));
        assert_eq!(c.steer_idle(), None, "already stopped");
    }

    #[test]
    fn disabled_stops_once() {
        let mut c = Control::new(settings());
        c.set_goal(pose(3.0, 0.0, 0.0));
        c.plan_ready(c.goal_seq(), 0.0, (0.0, 0.0), vec![(0.0, 0.0), (3.0, 0.0)]);
        assert!(matches!(c.drive(), Some(Motion::GoTo(_))));
        c.enabled = false;
        assert_eq!(c.drive(), Some(Motion::Stop));
        assert_eq!(c.drive(), None);
        c.enabled = true;
        assert!(matches!(c.drive(), Some(Motion::GoTo(_))));
    }
}
