//! Driving to a goal pose with VFH, as Player 3.0.2's vfh driver does between messages: escape
//! a stall blindly if asked to, stop once within the distance and angle tolerances, run VFH
//! while further than the distance tolerance, and turn in place to the goal heading once there.

use player_proto::{Pose2d, Position2dCmdPos, Position2dCmdVel};

use super::algorithm::Vfh;
use super::ranges::HalfDegreeRanges;

/// How close is close enough, and how to escape a stall.
#[derive(Clone, Debug, PartialEq)]
pub struct GoalSettings {
    /// Distance from the goal position that counts as there (m).
    pub distance_epsilon: f64,
    /// Heading error at the goal that counts as there (rad).
    pub angle_epsilon: f64,
    /// Forward speed while escaping a stall (m/s); 0 disables escaping.
    pub escape_speed: f64,
    /// How long one escape attempt lasts (s); 0 disables escaping.
    pub escape_time: f64,
    /// Largest turn rate while escaping (rad/s); 0 escapes straight.
    pub escape_max_turnrate: f64,
}

impl Default for GoalSettings {
    fn default() -> GoalSettings {
        GoalSettings {
            distance_epsilon: 0.5,
            angle_epsilon: 10f64.to_radians(),
            escape_speed: 0.0,
            escape_time: 0.0,
            escape_max_turnrate: 0.0,
        }
    }
}

/// What the underlying position2d reports, as the navigator uses it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Odometry {
    /// Odometric pose (m, m, rad).
    pub pose: Pose2d,
    /// Forward speed (m/s).
    pub speed: f64,
    /// The base reports a stall.
    pub stall: bool,
}

/// A goal as upstream keeps it: whole millimetres and whole degrees (so a goal that rounds to
/// the current one is not a new goal).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Goal {
    x: i32,
    y: i32,
    t: i32,
}

/// Signed smallest difference `a - b` between two headings in degrees.
fn angle_diff_deg(a: f64, b: f64) -> f64 {
    pose::angle::diff(a.to_radians(), b.to_radians()).to_degrees()
}

/// The goal-seeking state of one vfh device.
#[derive(Clone, Debug)]
pub struct Navigator {
    settings: GoalSettings,
    active_goal: bool,
    goal: Goal,
    /// Whether a position command equal to `goal` is a repeat to ignore: true from setup and
    /// from each new goal, false once a velocity command has cancelled the goal.
    remembers_goal: bool,
    /// Motor state of the latest position command: 0 holds the robot still.
    cmd_state: u8,
    turning_in_place: bool,
    /// Direction of the turn in place (+1 left, -1 right), kept until the goal is reached so
    /// the robot does not oscillate around the goal heading.
    rotatedir: i32,
    /// Direction of the next escape (+1 forward, -1 backward), flipped after a failed one.
    escapedir: i32,
    escaping: bool,
    escape_start: f64,
    rng: u64,
}

impl Navigator {
    /// A navigator without a goal.
    pub fn new(settings: GoalSettings) -> Navigator {
        Navigator {
            settings,
            active_goal: false,
            remembers_goal: true,
            goal: Goal::default(),
            cmd_state: 1,
            turning_in_place: false,
            rotatedir: 1,
            escapedir: 1,
            escaping: false,
            escape_start: 0.0,
            // Any fixed seed: runs are repeatable.
            rng: 0x5eed_5eed_5eed_5eed,
        }
    }

    /// The state after the driver's setup: no goal (the remembered goal is the origin), not
    /// turning, not escaping, motors enabled.
    pub fn reset(&mut self) {
        self.active_goal = false;
        self.goal = Goal::default();
        self.remembers_goal = true;
        self.cmd_state = 1;
        self.turning_in_place = false;
        self.rotatedir = 1;
        self.escapedir = 1;
        self.escaping = false;
    }

    /// Whether a goal is being pursued.
    pub fn active(&self) -> bool {
        self.active_goal
    }

    /// A position command. It becomes the goal if it differs from the last one (in whole
    /// millimetres and degrees): repeating the goal just reached, or sending the origin right
    /// after setup, does nothing, as upstream. Its motor state applies either way.
    ///
    /// Unlike upstream, a goal cancelled by a velocity command is forgotten, so the same goal
    /// sent again is pursued again. Upstream ignores it, which leaves a stack stuck after a
    /// pause: wavefront's planner ENABLE 0 stops the robot with a velocity command, and on
    /// ENABLE 1 re-sends the waypoint vfh was driving to.
    pub fn set_goal(&mut self, cmd: &Position2dCmdPos) {
        let goal = Goal {
            x: (cmd.pos.px * 1e3).round_ties_even() as i32,
            y: (cmd.pos.py * 1e3).round_ties_even() as i32,
            t: cmd.pos.pa.to_degrees().round_ties_even() as i32,
        };
        self.cmd_state = cmd.state;
        if goal != self.goal || !self.remembers_goal {
            self.active_goal = true;
            self.remembers_goal = true;
            self.turning_in_place = false;
            self.goal = goal;
        }
    }

    /// A velocity command went straight to the base: position control ends.
    pub fn cancel_goal(&mut self) {
        self.active_goal = false;
        self.remembers_goal = false;
    }

    /// The command that stops the robot (the driver's shutdown).
    pub fn stop(&self) -> Position2dCmdVel {
        self.command(0, 0, |_| 0)
    }

    /// A velocity command of `speed` mm/s and `turnrate` deg/s to the base. A turn faster than
    /// the top rate at that speed is dropped to 0 (upstream's "fast turn"), and a motor state
    /// of 0 sends zeros.
    fn command(
        &self,
        speed: i32,
        turnrate: i32,
        max_turnrate: impl Fn(i32) -> i32,
    ) -> Position2dCmdVel {
        let mut vel = Pose2d::default();
        if self.cmd_state != 0 {
            let mut turnrate = turnrate;
            if turnrate.abs() > max_turnrate(speed) {
                tracing::debug!("vfh: fast turn {turnrate} deg/s at {speed} mm/s; not turning");
                turnrate = 0;
            }
            vel = Pose2d {
                px: f64::from(speed) / 1e3,
                py: 0.0,
                pa: f64::from(turnrate).to_radians(),
            };
        }
        // Upstream sends a zeroed struct, motor state included; the bases it drives ignore it.
        Position2dCmdVel { vel, state: 0 }
    }

    fn uniform(&mut self) -> f64 {
        // splitmix64
        self.rng = self.rng.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.rng;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }

    /// One step towards the goal at time `now` (s): the velocity command for the base, or
    /// `None` without a goal.
    pub fn step(
        &mut self,
        vfh: &mut Vfh,
        odom: &Odometry,
        ranges: &HalfDegreeRanges,
        now: f64,
    ) -> Option<Position2dCmdVel> {
        if !self.active_goal {
            return None;
        }
        let s = self.settings.clone();
        let (ox, oy) = (odom.pose.px * 1e3, odom.pose.py * 1e3);
        let oa = odom.pose.pa.to_degrees();
        let dx = f64::from(self.goal.x) - ox;
        let dy = f64::from(self.goal.y) - oy;
        let dist = (dx * dx + dy * dy).sqrt() as f32;
        let angdiff = angle_diff_deg(f64::from(self.goal.t), oa);
        let eps_mm = s.distance_epsilon * 1e3;

        if self.escaping && now - self.escape_start > s.escape_time {
            // Still stalled after a whole attempt: try the other way.
            if odom.stall {
                self.escapedir = -self.escapedir;
            }
            self.escaping = false;
        }

        if self.escaping || (s.escape_speed != 0.0 && s.escape_time != 0.0 && odom.stall) {
            // A stall: drive blindly forward or back, turning at random, for escape_time.
            if !self.escaping {
                self.escape_start = now;
                self.escaping = true;
            }
            let speed = (s.escape_speed * f64::from(self.escapedir) * 1e3).round_ties_even() as i32;
            let turnrate = if s.escape_max_turnrate != 0.0 {
                let top = s.escape_max_turnrate.to_degrees().round_ties_even() as i32;
                let u = self.uniform();
                (2.0 * f64::from(top) * u) as i32 - top / 2 + 1
            } else {
                0
            };
            self.turning_in_place = false;
            return Some(self.command(speed, turnrate, |sp| vfh.max_turnrate(sp)));
        }

        if f64::from(dist) < eps_mm && angdiff.to_radians().abs() < s.angle_epsilon {
            // There.
            self.active_goal = false;
            self.turning_in_place = false;
            return Some(self.command(0, 0, |sp| vfh.max_turnrate(sp)));
        }

        if f64::from(dist) > eps_mm {
            let mut desired = (90.0 + dy.atan2(dx).to_degrees() - oa) as f32;
            while desired > 360.0 {
                desired -= 360.0;
            }
            while desired < 0.0 {
                desired += 360.0;
            }
            let m = vfh.update(
                ranges,
                (odom.speed * 1e3) as i32,
                desired,
                dist,
                eps_mm as f32,
                now,
            );
            let mut speed = m.speed;
            // Near the goal and still fast: halve the top speed.
            let half_top = f64::from(vfh.current_max_speed()) / 2.0;
            if f64::from(dist) < eps_mm * 2.0 && f64::from(speed) > half_top {
                speed = half_top.round_ties_even() as i32;
            }
            self.turning_in_place = false;
            return Some(self.command(speed, m.turnrate, |sp| vfh.max_turnrate(sp)));
        }

        // At the goal position but not its heading: turn in place, in proportion to the error,
        // the way chosen on arrival.
        let mut turnrate =
            ((angdiff / 180.0).abs() * f64::from(vfh.max_turnrate(0))).round_ties_even() as i32;
        if !self.turning_in_place {
            self.turning_in_place = true;
            self.rotatedir = if angdiff < 0.0 { -1 } else { 1 };
        }
        turnrate *= self.rotatedir;
        let min = vfh.min_turnrate();
        turnrate = if turnrate < 0 {
            turnrate.min(-min)
        } else {
            turnrate.max(min)
        };
        Some(self.command(0, turnrate, |sp| vfh.max_turnrate(sp)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::position::vfh::algorithm::Params;
    use crate::position::vfh::algorithm::tests::defaults;
    use crate::position::vfh::ranges::{FAR, RANGE_COUNT};

    /// Player's defaults with a faster robot that turns harder when still.
    fn params() -> Params {
        Params {
            max_speed: 300,
            max_speed_narrow_opening: 300,
            max_speed_wide_opening: 300,
            max_turnrate_0ms: 90,
            max_turnrate_1ms: 35,
            ..defaults()
        }
    }

    fn goal(x: f64, y: f64, a: f64) -> Position2dCmdPos {
        Position2dCmdPos {
            pos: Pose2d {
                px: x,
                py: y,
                pa: a,
            },
            vel: Pose2d::default(),
            state: 1,
        }
    }

    fn at(px: f64, py: f64, pa: f64) -> Odometry {
        Odometry {
            pose: Pose2d { px, py, pa },
            speed: 0.0,
            stall: false,
        }
    }

    const OPEN: HalfDegreeRanges = [FAR; RANGE_COUNT];

    /// Drives a point robot with the commands, in open space, for `secs` seconds at 10 Hz.
    fn drive(nav: &mut Navigator, vfh: &mut Vfh, mut odom: Odometry, secs: f64) -> Odometry {
        let mut t = 0.0;
        while t < secs {
            t += 0.1;
            let Some(cmd) = nav.step(vfh, &odom, &OPEN, t) else {
                break;
            };
            odom.pose.pa += cmd.vel.pa * 0.1;
            odom.pose.px += cmd.vel.px * 0.1 * odom.pose.pa.cos();
            odom.pose.py += cmd.vel.px * 0.1 * odom.pose.pa.sin();
            odom.speed = cmd.vel.px;
        }
        odom
    }

    #[test]
    fn no_goal_no_command() {
        let mut nav = Navigator::new(GoalSettings::default());
        let mut vfh = Vfh::new(params(), 250.0, 0.0);
        assert!(nav.step(&mut vfh, &at(0.0, 0.0, 0.0), &OPEN, 0.1).is_none());
    }

    #[test]
    fn drives_to_a_goal_in_open_space_and_stops_within_the_tolerances() {
        let mut nav = Navigator::new(GoalSettings::default());
        let mut vfh = Vfh::new(params(), 250.0, 0.0);
        nav.set_goal(&goal(3.0, 2.0, 0.0));
        let end = drive(&mut nav, &mut vfh, at(0.0, 0.0, 0.0), 60.0);
        assert!(!nav.active(), "arrived");
        let d = (end.pose.px - 3.0).hypot(end.pose.py - 2.0);
        assert!(d < 0.5, "{end:?}");
        assert!(angle_diff_deg(0.0, end.pose.pa.to_degrees()).abs() < 10.0);
        // Arrived: the last command stopped the robot, and the next step sends nothing.
        assert!(nav.step(&mut vfh, &end, &OPEN, 100.0).is_none());
    }

    #[test]
    fn at_the_goal_position_it_turns_in_place_to_the_goal_heading() {
        let mut nav = Navigator::new(GoalSettings::default());
        let mut vfh = Vfh::new(params(), 250.0, 0.0);
        nav.set_goal(&goal(0.1, 0.0, 90f64.to_radians()));
        let cmd = nav.step(&mut vfh, &at(0.0, 0.0, 0.0), &OPEN, 0.1).unwrap();
        assert_eq!(cmd.vel.px, 0.0);
        // 90° off: half of the 90 deg/s top rate, to the left.
        assert!((cmd.vel.pa - 45f64.to_radians()).abs() < 1e-9, "{cmd:?}");
        // 13° short: 6 deg/s, raised to the minimum turn rate.
        let cmd = nav.step(&mut vfh, &at(0.0, 0.0, 1.35), &OPEN, 0.2).unwrap();
        assert!((cmd.vel.pa - 10f64.to_radians()).abs() < 1e-9, "{cmd:?}");
        // 13° past: still to the left, the way it started (no oscillation).
        let cmd = nav.step(&mut vfh, &at(0.0, 0.0, 1.8), &OPEN, 0.25).unwrap();
        assert!((cmd.vel.pa - 10f64.to_radians()).abs() < 1e-9, "{cmd:?}");
        let cmd = nav.step(&mut vfh, &at(0.0, 0.0, 1.58), &OPEN, 0.3).unwrap();
        assert_eq!(cmd.vel, Pose2d::default(), "within 10°: stop");
        assert!(!nav.active());
    }

    #[test]
    fn a_repeated_goal_is_ignored_and_a_velocity_command_cancels() {
        let mut nav = Navigator::new(GoalSettings::default());
        nav.set_goal(&goal(0.0, 0.0, 0.0));
        assert!(
            !nav.active(),
            "the origin is the goal remembered after setup"
        );
        nav.set_goal(&goal(1.0, 0.0, 0.0));
        assert!(nav.active());
        // Arrived: the goal is done, and sending it again does nothing.
        let mut vfh = Vfh::new(params(), 250.0, 0.0);
        let _ = nav.step(&mut vfh, &at(1.0, 0.0, 0.0), &OPEN, 0.1);
        assert!(!nav.active(), "arrived");
        nav.set_goal(&goal(1.0004, 0.0, 0.0));
        assert!(!nav.active(), "same goal in whole millimetres");
        nav.set_goal(&goal(1.0, 0.0, 0.0));
        nav.cancel_goal();
        assert!(!nav.active());
        nav.set_goal(&goal(1.0004, 0.0, 0.0));
        assert!(nav.active(), "a cancelled goal sent again is pursued again");
        nav.set_goal(&goal(1.0, 0.0, 0.0));
        assert!(nav.active());
        nav.set_goal(&goal(1.0, 0.0, 0.02));
        assert!(nav.active(), "a new heading in whole degrees");
    }

    #[test]
    fn motor_state_zero_holds_the_robot() {
        let mut nav = Navigator::new(GoalSettings::default());
        let mut vfh = Vfh::new(params(), 250.0, 0.0);
        let mut g = goal(3.0, 0.0, 0.0);
        g.state = 0;
        nav.set_goal(&g);
        let cmd = nav.step(&mut vfh, &at(0.0, 0.0, 0.0), &OPEN, 0.1).unwrap();
        assert_eq!(cmd.vel, Pose2d::default());
    }

    #[test]
    fn turns_faster_than_the_speed_allows_are_dropped() {
        let nav = Navigator::new(GoalSettings::default());
        let top = |speed: i32| 90 - speed * 55 / 1000;
        let cmd = nav.command(300, 74, top);
        assert!((cmd.vel.pa - 74f64.to_radians()).abs() < 1e-12);
        let cmd = nav.command(320, 74, top);
        assert_eq!(cmd.vel.pa, 0.0);
        assert_eq!(cmd.vel.px, 0.32);
    }

    #[test]
    fn slows_to_half_speed_near_the_goal() {
        let mut nav = Navigator::new(GoalSettings::default());
        let mut vfh = Vfh::new(params(), 250.0, 0.0);
        nav.set_goal(&goal(10.0, 0.0, 0.0));
        let mut odom = at(0.0, 0.0, 0.0);
        let mut cmd = None;
        for k in 1..30 {
            cmd = nav.step(&mut vfh, &odom, &OPEN, 0.1 * k as f64);
        }
        assert_eq!(cmd.unwrap().vel.px, 0.3);
        odom.pose.px = 9.2; // 0.8 m away: within twice the tolerance
        odom.speed = 0.3;
        let cmd = nav.step(&mut vfh, &odom, &OPEN, 3.0).unwrap();
        assert_eq!(cmd.vel.px, 0.15);
    }

    #[test]
    fn a_stall_is_escaped_forwards_then_backwards() {
        let mut nav = Navigator::new(GoalSettings {
            escape_speed: 0.2,
            escape_time: 1.0,
            escape_max_turnrate: 20f64.to_radians(),
            ..GoalSettings::default()
        });
        let mut vfh = Vfh::new(params(), 250.0, 0.0);
        nav.set_goal(&goal(5.0, 0.0, 0.0));
        let mut stalled = at(0.0, 0.0, 0.0);
        stalled.stall = true;
        let cmd = nav.step(&mut vfh, &stalled, &OPEN, 1.0).unwrap();
        assert_eq!(cmd.vel.px, 0.2, "first escape forwards");
        let t = cmd.vel.pa.to_degrees().round() as i32;
        assert!((-9..=31).contains(&t), "{t}");
        // Still escaping half-way, whatever the stall flag says.
        let cmd = nav.step(&mut vfh, &at(0.0, 0.0, 0.0), &OPEN, 1.5).unwrap();
        assert_eq!(cmd.vel.px, 0.2);
        // After the attempt, still stalled: the other way.
        let cmd = nav.step(&mut vfh, &stalled, &OPEN, 2.1).unwrap();
        assert_eq!(cmd.vel.px, -0.2);
        // Once free and the attempt over, VFH drives again.
        let cmd = nav.step(&mut vfh, &at(0.0, 0.0, 0.0), &OPEN, 3.2).unwrap();
        assert!(cmd.vel.px >= 0.0);
    }

    #[test]
    fn without_escape_settings_a_stall_keeps_running_vfh() {
        let mut nav = Navigator::new(GoalSettings::default());
        let mut vfh = Vfh::new(params(), 250.0, 0.0);
        nav.set_goal(&goal(5.0, 0.0, 0.0));
        let mut stalled = at(0.0, 0.0, 0.0);
        stalled.stall = true;
        let cmd = nav.step(&mut vfh, &stalled, &OPEN, 0.1).unwrap();
        assert!(cmd.vel.px > 0.0);
    }

    #[test]
    fn heading_differences_take_the_short_way() {
        assert!((angle_diff_deg(10.0, 350.0) - 20.0).abs() < 1e-9);
        assert!((angle_diff_deg(350.0, 10.0) + 20.0).abs() < 1e-9);
        assert!((angle_diff_deg(-170.0, 170.0) - 20.0).abs() < 1e-9);
    }
}
