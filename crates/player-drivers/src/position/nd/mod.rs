//! `nd`: Nearness Diagram navigation, as Player 3.0.2's driver runs it.
//!
//! Provides a `position2d`; requires the base as two `position2d` devices, keyed `output`
//! (velocity commands go there; its geometry sizes the robot) and `input` (the pose: odometry
//! or a localizer; it may be the same device), and a `laser` and/or a `sonar`. A
//! `PLAYER_POSITION2D_CMD_POS` goal is driven to by [`alg::iterate`] every 20 ms of server
//! time until the robot is within `goal_tol` (distance and heading: it drives there, then
//! turns in place); a velocity command stops navigation and passes through to the base.
//! The provided device republishes the input's pose with the output's velocity, and reports
//! a stall when ND gave up (emergency stop, no way through, or no progress within the stuck
//! times). Requests are forwarded to the output device.
//!
//! Options (Player's, with its defaults; angles in degrees in the cfg): `goal_tol`
//! `[0.5 10]`, `max_speed` `[0.3 45]`, `min_speed` `[0.05 10]`, `avoid_dist` 0.5,
//! `safety_dist` 0.0, `rotate_stuck_time` 2.0, `translate_stuck_time` 2.0,
//! `translate_stuck_dist` 0.25, `translate_stuck_angle` 20, `wait_on_stall` 0,
//! `laser_buffer` 10, `sonar_buffer` 20 (upstream's documentation says 10, its code reads
//! 20), `sonar_bad_transducers` `[]`.

pub mod alg;

use std::collections::VecDeque;
use std::time::Duration;

use player_proto::{
    Body, DeviceAddr, InterfaceCode, LaserData, LaserMsg, LaserReq, Message, Pose2d, Pose3d,
    Position2dCmd, Position2dCmdVel, Position2dData, Position2dDataState, Position2dGeom,
    Position2dMsg, Position2dReq, SonarData, SonarMsg, SonarReq,
};
use player_server::{
    Context, Driver, DriverBlock, DriverError, PendingReply, Reply, RequestError, RequestTicket,
};

use crate::error::Error;
use crate::forward::{Waiting, passed_on, refuse_own_device};
use crate::options;
use pose::angle::{diff as angle_diff, normalize_atan2 as normalize};

use alg::{NdParams, Pose, Robot, Velocities};

/// The Player name of this driver.
pub const NAME: &str = "nd";

/// How often the navigation loop runs (upstream sleeps 20 ms between iterations).
const CYCLE: Duration = Duration::from_millis(20);

/// The driver's settings, from its cfg block (lengths in m, angles in rad, times in s).
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// Distance within which the goal counts as reached.
    pub dist_eps: f64,
    /// Heading error within which the goal counts as reached.
    pub ang_eps: f64,
    /// Largest forward speed commanded.
    pub vx_max: f64,
    /// Largest turn rate commanded.
    pub va_max: f64,
    /// Smallest non-zero forward speed commanded.
    pub vx_min: f64,
    /// Smallest non-zero turn rate commanded (when not moving forward).
    pub va_min: f64,
    /// Distance at which avoidance begins (ND's front security distance).
    pub avoid_dist: f64,
    /// Extra extent added to the robot on every side.
    pub safety_dist: f64,
    /// Time allowed to turn in place without getting nearer the goal heading.
    pub rotate_stuck_time: f64,
    /// Time allowed to translate without moving `translate_stuck_dist` or turning
    /// `translate_stuck_angle`.
    pub translate_stuck_time: f64,
    /// See `translate_stuck_time`.
    pub translate_stuck_dist: f64,
    /// See `translate_stuck_time`.
    pub translate_stuck_angle: f64,
    /// Pause (stop and wait) while the input device reports a stall.
    pub wait_on_stall: bool,
    /// Laser scans merged into the obstacle list.
    pub laser_buffer: usize,
    /// Sonar scans merged into the obstacle list.
    pub sonar_buffer: usize,
    /// Sonar transducers to ignore.
    pub sonar_bad_transducers: Vec<usize>,
}

impl Default for Settings {
    fn default() -> Settings {
        Settings {
            dist_eps: 0.5,
            ang_eps: 10f64.to_radians(),
            vx_max: 0.3,
            va_max: 45f64.to_radians(),
            vx_min: 0.05,
            va_min: 10f64.to_radians(),
            avoid_dist: 0.5,
            safety_dist: 0.0,
            rotate_stuck_time: 2.0,
            translate_stuck_time: 2.0,
            translate_stuck_dist: 0.25,
            translate_stuck_angle: 20f64.to_radians(),
            wait_on_stall: false,
            laser_buffer: 10,
            sonar_buffer: 20,
            sonar_bad_transducers: Vec::new(),
        }
    }
}

fn buffer(block: &DriverBlock, key: &'static str) -> Result<Option<usize>, Error> {
    match options::int(block, key)? {
        Some(n) if n < 1 => Err(Error::BadOption {
            option: key.into(),
            value: n.to_string(),
            why: "must be at least 1".into(),
        }),
        n => Ok(n.map(|n| n as usize)),
    }
}

impl Settings {
    /// Reads the options of a cfg block (absent ones keep Player's defaults).
    pub fn from_block(block: &DriverBlock) -> Result<Settings, Error> {
        let d = Settings::default();
        let len = |k: &'static str, i: usize, def: f64| -> Result<f64, Error> {
            Ok(options::tuple_length(block, k, i)?.unwrap_or(def))
        };
        let ang = |k: &'static str, i: usize, def: f64| -> Result<f64, Error> {
            Ok(options::tuple_angle(block, k, i)?.unwrap_or(def))
        };
        let bad = match block.options.get("sonar_bad_transducers") {
            None => Vec::new(),
            Some(v) => v
                .iter()
                .map(|t| {
                    t.parse::<usize>().map_err(|_| Error::BadOption {
                        option: "sonar_bad_transducers".into(),
                        value: t.clone(),
                        why: "not a transducer index".into(),
                    })
                })
                .collect::<Result<_, _>>()?,
        };
        Ok(Settings {
            dist_eps: len("goal_tol", 0, d.dist_eps)?,
            ang_eps: ang("goal_tol", 1, d.ang_eps)?,
            vx_max: len("max_speed", 0, d.vx_max)?,
            va_max: ang("max_speed", 1, d.va_max)?,
            vx_min: len("min_speed", 0, d.vx_min)?,
            va_min: ang("min_speed", 1, d.va_min)?,
            avoid_dist: len("avoid_dist", 0, d.avoid_dist)?,
            safety_dist: len("safety_dist", 0, d.safety_dist)?,
            rotate_stuck_time: len("rotate_stuck_time", 0, d.rotate_stuck_time)?,
            translate_stuck_time: len("translate_stuck_time", 0, d.translate_stuck_time)?,
            translate_stuck_dist: len("translate_stuck_dist", 0, d.translate_stuck_dist)?,
            translate_stuck_angle: ang("translate_stuck_angle", 0, d.translate_stuck_angle)?,
            wait_on_stall: options::flag(block, "wait_on_stall")?.unwrap_or(false),
            laser_buffer: buffer(block, "laser_buffer")?.unwrap_or(d.laser_buffer),
            sonar_buffer: buffer(block, "sonar_buffer")?.unwrap_or(d.sonar_buffer),
            sonar_bad_transducers: bad,
        })
    }

    /// ND's robot description for a base of `geom`, driving forwards (`dir > 0`) or
    /// backwards (front and back swapped), as the driver fills upstream's `TParametersND`.
    pub fn nd_params(&self, geom: &Position2dGeom, forwards: bool) -> NdParams {
        let half = geom.size.sl / 2.0;
        let (front, back) = if forwards {
            (half + geom.pose.px, half - geom.pose.px)
        } else {
            (half - geom.pose.px, half + geom.pose.px)
        };
        let left = geom.size.sw / 2.0 + self.safety_dist;
        let dsmax = self.avoid_dist;
        let dsmin = dsmax / 4.0;
        NdParams {
            front: front + self.safety_dist,
            back: back + self.safety_dist,
            left,
            vlmax: self.vx_max,
            vamax: self.va_max,
            almax: 0.75,
            aamax: 0.75,
            dsmax,
            dsmin,
            enlarge: dsmin * 0.2,
            discontinuity: 2.0 * left,
            period: 0.1,
        }
    }
}

/// `v` limited to `[min, max]` in magnitude, keeping its sign; zero stays zero.
pub fn threshold(v: f64, min: f64, max: f64) -> f64 {
    if v == 0.0 {
        v
    } else if v > 0.0 {
        v.min(max).max(min)
    } else {
        v.max(-max).min(-min)
    }
}

/// A sensor reading in the robot frame, carried into the odometric frame at `odom`.
fn to_world(sensor: &Pose3d, odom: Pose2d, x: f64, y: f64) -> (f64, f64) {
    let (ss, cs) = sensor.pyaw.sin_cos();
    let rx = sensor.px + x * cs - y * ss;
    let ry = sensor.py + x * ss + y * cs;
    let (so, co) = odom.pa.sin_cos();
    (odom.px + rx * co - ry * so, odom.py + rx * so + ry * co)
}

/// What the navigation step decided.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Decision {
    /// Nothing to do (no goal, waiting on a stall, or no geometry yet).
    Idle,
    /// Goal reached: stop.
    Arrived,
    /// ND or the stuck timers gave up: stop and report a stall.
    GaveUp,
    /// Send this velocity.
    Drive(f64, f64),
}

/// The navigation state: the goal, progress timers and obstacle buffers. Pure: time, poses
/// and scans come in, decisions go out.
#[derive(Debug)]
pub struct Navigator {
    settings: Settings,
    geom: Option<Position2dGeom>,
    robot: Option<(Robot, bool)>,
    goal: Option<Pose2d>,
    dir_backwards: bool,
    odom: Pose2d,
    last_odom: Pose2d,
    turning_in_place: bool,
    rotate_start: f64,
    rotate_min_error: f64,
    translate_start: f64,
    /// ND gave up on the last goal (reported as a stall).
    pub stalled: bool,
    laser_scans: VecDeque<Vec<(f64, f64)>>,
    sonar_scans: VecDeque<Vec<(f64, f64)>>,
}

impl Navigator {
    /// A navigator with no goal and no geometry yet.
    pub fn new(settings: Settings) -> Navigator {
        Navigator {
            settings,
            geom: None,
            robot: None,
            goal: None,
            dir_backwards: false,
            odom: Pose2d::default(),
            last_odom: Pose2d::default(),
            turning_in_place: false,
            rotate_start: 0.0,
            rotate_min_error: 0.0,
            translate_start: 0.0,
            stalled: false,
            laser_scans: VecDeque::new(),
            sonar_scans: VecDeque::new(),
        }
    }

    /// Forgets goal and scans (the driver was shut down).
    pub fn reset(&mut self) {
        self.goal = None;
        self.stalled = false;
        self.turning_in_place = false;
        self.laser_scans.clear();
        self.sonar_scans.clear();
        self.last_odom = Pose2d {
            px: f64::from(f32::MAX),
            py: f64::from(f32::MAX),
            pa: f64::from(f32::MAX),
        };
    }

    /// The base's geometry arrived.
    pub fn set_geometry(&mut self, geom: Position2dGeom) {
        self.geom = Some(geom);
        self.robot = None;
    }

    /// The robot's current pose.
    pub fn set_pose(&mut self, pose: Pose2d) {
        self.odom = pose;
    }

    /// Whether a goal is being driven to.
    pub fn active(&self) -> bool {
        self.goal.is_some()
    }

    /// A new goal at time `now`.
    pub fn set_goal(&mut self, goal: Pose2d, now: f64) {
        self.goal = Some(goal);
        self.turning_in_place = false;
        self.stalled = false;
        self.translate_start = now;
        self.last_odom = self.odom;
    }

    /// A velocity command: navigation stops; negative speeds make later goals be driven to
    /// backwards (upstream's `dir`).
    pub fn velocity_command(&mut self, vx: f64) {
        self.goal = None;
        self.dir_backwards = vx < 0.0;
    }

    fn push(buf: &mut VecDeque<Vec<(f64, f64)>>, cap: usize, points: Vec<(f64, f64)>) {
        if buf.len() >= cap {
            buf.pop_front();
        }
        buf.push_back(points);
    }

    /// A laser scan taken from `laser` (its pose on the robot).
    pub fn laser_scan(&mut self, laser: &Pose3d, min_angle: f64, resolution: f64, ranges: &[f32]) {
        let points = ranges
            .iter()
            .enumerate()
            .map(|(i, &r)| {
                let b = min_angle + i as f64 * resolution;
                let r = f64::from(r);
                to_world(laser, self.odom, r * b.cos(), r * b.sin())
            })
            .collect();
        Self::push(&mut self.laser_scans, self.settings.laser_buffer, points);
    }

    /// A sonar reading from transducers at `poses`.
    pub fn sonar_scan(&mut self, poses: &[Pose3d], ranges: &[f32]) {
        let points = ranges
            .iter()
            .zip(poses)
            .enumerate()
            .filter(|(i, _)| !self.settings.sonar_bad_transducers.contains(i))
            .map(|(_, (&r, p))| to_world(p, self.odom, f64::from(r), 0.0))
            .collect();
        Self::push(&mut self.sonar_scans, self.settings.sonar_buffer, points);
    }

    fn robot(&mut self, forwards: bool) -> Option<&Robot> {
        let geom = self.geom.as_ref()?;
        if self.robot.as_ref().is_none_or(|(_, f)| *f != forwards) {
            let r = Robot::new(&self.settings.nd_params(geom, forwards));
            self.robot = Some((r, forwards));
        }
        self.robot.as_ref().map(|(r, _)| r)
    }

    /// One ND iteration from `pose` towards `target` among the obstacle `points`, with the
    /// robot's geometry facing `forwards` (reversed when backing up); `Err` when ND halts.
    fn nd_step(
        &mut self,
        forwards: bool,
        target: (f64, f64),
        pose: Pose,
        points: &[(f64, f64)],
    ) -> Result<alg::Step, alg::Halt> {
        let goal_tol = self.settings.dist_eps;
        let robot = self.robot(forwards).expect("geometry known");
        // Upstream hands ND a velocity it never fills in (zero in practice); ND only reads
        // it to brake when the rear is about to graze something.
        alg::iterate(robot, target, goal_tol, pose, Velocities::default(), points)
    }

    fn give_up(&mut self) -> Decision {
        self.stalled = true;
        self.goal = None;
        Decision::GaveUp
    }

    /// One iteration of the navigation loop at time `now` (upstream's `Main` body).
    pub fn step(&mut self, now: f64) -> Decision {
        let Some(goal) = self.goal else {
            return Decision::Idle;
        };
        if self.geom.is_none() {
            return Decision::Idle;
        }
        let points: Vec<(f64, f64)> = self
            .laser_scans
            .iter()
            .chain(&self.sonar_scans)
            .flatten()
            .copied()
            .collect();
        let odom = self.odom;
        let g_dx = (goal.px - odom.px).hypot(goal.py - odom.py);
        let g_da = angle_diff(goal.pa, odom.pa);
        let s = self.settings.clone();
        if g_dx < s.dist_eps && g_da.abs() < s.ang_eps {
            self.goal = None;
            return Decision::Arrived;
        }
        let mut pose = Pose {
            x: odom.px,
            y: odom.py,
            a: odom.pa,
        };
        let (vx, va);
        if g_dx < s.dist_eps || self.turning_in_place {
            // Turn towards the goal heading by aiming ND at a point far along it.
            let fake = (
                odom.px + 10.0 * goal.pa.cos(),
                odom.py + 10.0 * goal.pa.sin(),
            );
            let Ok(step) = self.nd_step(true, fake, pose, &points) else {
                return self.give_up();
            };
            vx = 0.0;
            va = step.cmd.w;
            if !self.turning_in_place {
                self.rotate_start = now;
                self.rotate_min_error = g_da.abs();
                self.turning_in_place = true;
            } else if g_da.abs() < self.rotate_min_error {
                self.rotate_start = now;
                self.rotate_min_error = g_da.abs();
            } else if now - self.rotate_start > s.rotate_stuck_time {
                tracing::warn!("nd: ran out of time trying to attain goal heading");
                return self.give_up();
            }
        } else {
            let o_dx = (odom.px - self.last_odom.px).hypot(odom.py - self.last_odom.py);
            let o_da = angle_diff(odom.pa, self.last_odom.pa);
            if o_dx > s.translate_stuck_dist || o_da.abs() > s.translate_stuck_angle {
                self.last_odom = odom;
                self.translate_start = now;
            } else if now - self.translate_start > s.translate_stuck_time {
                tracing::warn!("nd: ran out of time trying to get to goal");
                return self.give_up();
            }
            let backwards = self.dir_backwards;
            if backwards {
                // ND thinks the robot faces the other way, with its geometry reversed.
                pose.a = normalize(pose.a + std::f64::consts::PI);
            }
            let Ok(step) = self.nd_step(!backwards, (goal.px, goal.py), pose, &points) else {
                return self.give_up();
            };
            vx = step.cmd.v;
            va = step.cmd.w;
        }
        if vx == 0.0 && va == 0.0 {
            // ND says done, yet the goal test above did not: give up as upstream does.
            return self.give_up();
        }
        let vx = threshold(vx, s.vx_min, s.vx_max);
        let va = if vx == 0.0 {
            threshold(va, s.va_min, s.va_max)
        } else {
            va
        };
        let vx = if self.dir_backwards { -vx } else { vx };
        Decision::Drive(vx, va)
    }
}

/// What a request this driver sent is for.
#[derive(Debug)]
enum Asked {
    RobotGeom,
    LaserGeom,
    SonarGeom,
    Forwarded(PendingReply),
}

/// The driver.
#[derive(Debug)]
pub struct Nd {
    addr: DeviceAddr,
    output: DeviceAddr,
    input: DeviceAddr,
    laser: Option<DeviceAddr>,
    sonar: Option<DeviceAddr>,
    nav: Navigator,
    laser_pose: Option<Pose3d>,
    sonar_poses: Option<Vec<Pose3d>>,
    odom_vel: Pose2d,
    waiting_on_stall: bool,
    asked: Waiting<Asked>,
}

impl Nd {
    /// Builds the driver from its cfg block.
    pub fn from_block(block: &DriverBlock) -> Result<Nd, DriverError> {
        let addr = block.provided(InterfaceCode::POSITION2D)?;
        let (output, input) = super::output_and_input(block)?;
        let (laser, sonar) = super::laser_and_sonar(block)?;
        if laser.is_none() && sonar.is_none() {
            return Err(DriverError::new(
                "ND needs at least one sonar or one laser (e.g. \"laser:0\")",
            ));
        }
        refuse_own_device(addr, &[output, input])?;
        Ok(Nd {
            addr,
            output,
            input,
            laser,
            sonar,
            nav: Navigator::new(Settings::from_block(block)?),
            laser_pose: None,
            sonar_poses: None,
            odom_vel: Pose2d::default(),
            waiting_on_stall: false,
            asked: Waiting::default(),
        })
    }

    fn put_vel(&self, ctx: &mut Context<'_>, vx: f64, va: f64) {
        ctx.command(
            self.output,
            Position2dCmd::Vel(Position2dCmdVel {
                vel: Pose2d {
                    px: vx,
                    py: 0.0,
                    pa: va,
                },
                state: 1,
            }),
        );
    }

    fn input_pose(&mut self, ctx: &mut Context<'_>, state: &Position2dDataState, time: f64) {
        self.nav.set_pose(state.pos);
        let mut stall = 0;
        if state.stall != 0 {
            if self.nav.settings.wait_on_stall {
                self.put_vel(ctx, 0.0, 0.0);
                self.waiting_on_stall = true;
            } else {
                stall = 1;
            }
        } else {
            self.waiting_on_stall = false;
        }
        if self.nav.stalled {
            stall = 1;
        }
        ctx.publish_at(
            self.addr,
            Position2dData::State(Position2dDataState {
                pos: state.pos,
                vel: self.odom_vel,
                stall,
            }),
            time,
        );
    }
}

impl Driver for Nd {
    fn setup(&mut self, ctx: &mut Context<'_>) -> Result<(), DriverError> {
        self.nav.reset();
        self.laser_pose = None;
        self.sonar_poses = None;
        self.waiting_on_stall = false;
        super::subscribe_both(ctx, self.output, self.input);
        let t = ctx.request(self.output, Position2dReq::GetGeom(None));
        self.asked.insert(t, Asked::RobotGeom);
        if let Some(laser) = self.laser {
            ctx.subscribe(laser);
            let t = ctx.request(laser, LaserReq::GetGeom(None));
            self.asked.insert(t, Asked::LaserGeom);
        }
        if let Some(sonar) = self.sonar {
            ctx.subscribe(sonar);
            let t = ctx.request(sonar, SonarReq::GetGeom(None));
            self.asked.insert(t, Asked::SonarGeom);
        }
        Ok(())
    }

    fn teardown(&mut self, ctx: &mut Context<'_>) {
        // Stop the robot before letting go of it.
        self.put_vel(ctx, 0.0, 0.0);
        self.nav.reset();
    }

    fn handle_data(&mut self, ctx: &mut Context<'_>, data: &Message) {
        let time = data.header.timestamp;
        let from = data.header.addr;
        match &data.body {
            Body::Position2d(Position2dMsg::Data(Position2dData::State(state))) => {
                if from.same_device(&self.output) {
                    self.odom_vel = state.vel;
                }
                if from.same_device(&self.input) {
                    self.input_pose(ctx, state, time);
                }
            }
            Body::Laser(LaserMsg::Data(LaserData::Scan(scan)))
                if self.laser.is_some_and(|l| from.same_device(&l)) =>
            {
                if let Some(pose) = self.laser_pose {
                    self.nav.laser_scan(
                        &pose,
                        f64::from(scan.min_angle),
                        f64::from(scan.resolution),
                        &scan.ranges,
                    );
                }
            }
            Body::Sonar(SonarMsg::Data(SonarData::Ranges(r)))
                if self.sonar.is_some_and(|s| from.same_device(&s)) =>
            {
                if let Some(poses) = &self.sonar_poses {
                    self.nav.sonar_scan(poses, &r.ranges);
                }
            }
            _ => {}
        }
    }

    fn handle_command(&mut self, ctx: &mut Context<'_>, command: &Message) {
        match &command.body {
            Body::Position2d(Position2dMsg::Cmd(Position2dCmd::Pos(cmd))) => {
                tracing::debug!(
                    "nd: new goal ({:.3} {:.3} {:.3})",
                    cmd.pos.px,
                    cmd.pos.py,
                    cmd.pos.pa.to_degrees()
                );
                self.nav.set_goal(cmd.pos, ctx.now());
            }
            Body::Position2d(Position2dMsg::Cmd(Position2dCmd::Vel(cmd))) => {
                if cmd.state == 0 {
                    self.put_vel(ctx, 0.0, 0.0);
                } else {
                    self.put_vel(ctx, cmd.vel.px, cmd.vel.pa);
                }
                self.nav.velocity_command(cmd.vel.px);
            }
            other => tracing::warn!("nd: ignoring command {}", other.constant()),
        }
    }

    fn handle_request(&mut self, ctx: &mut Context<'_>, request: &Message) -> Reply {
        self.asked
            .forward(ctx, self.output, request.body.clone(), Asked::Forwarded)
    }

    fn handle_reply(
        &mut self,
        ctx: &mut Context<'_>,
        ticket: RequestTicket,
        reply: Result<Message, RequestError>,
    ) {
        let Some(asked) = self.asked.take(ticket) else {
            return;
        };
        let body = reply.as_ref().ok().map(|m| &m.body);
        match asked {
            Asked::Forwarded(pending) => ctx.answer(pending, passed_on(reply)),
            Asked::RobotGeom => match body.and_then(Position2dReq::in_reply) {
                Some(Position2dReq::GetGeom(Some(g))) => {
                    tracing::info!(
                        "nd: robot geom: {:.3} {:.3} {:.3} {:.3} {:.3}",
                        g.size.sl,
                        g.size.sw,
                        g.pose.px,
                        g.pose.py,
                        g.pose.pyaw.to_degrees()
                    );
                    self.nav.set_geometry(g.clone());
                }
                _ => tracing::error!("nd: failed to get geometry of underlying position device"),
            },
            Asked::LaserGeom => match body.and_then(LaserReq::in_reply) {
                Some(LaserReq::GetGeom(Some(g))) => self.laser_pose = Some(g.pose),
                _ => tracing::error!("nd: failed to get laser geometry"),
            },
            Asked::SonarGeom => match body.and_then(SonarReq::in_reply) {
                Some(SonarReq::GetGeom(Some(g))) => self.sonar_poses = Some(g.poses.clone()),
                _ => tracing::error!("nd: failed to get sonar geometry"),
            },
        }
    }

    fn update(&mut self, ctx: &mut Context<'_>) {
        if self.waiting_on_stall {
            return;
        }
        match self.nav.step(ctx.now()) {
            Decision::Idle => {}
            Decision::Arrived => {
                tracing::debug!("nd: at goal");
                self.put_vel(ctx, 0.0, 0.0);
            }
            Decision::GaveUp => {
                tracing::debug!("nd: gave up");
                self.put_vel(ctx, 0.0, 0.0);
            }
            Decision::Drive(vx, va) => self.put_vel(ctx, vx, va),
        }
    }

    fn step(&self) -> Option<Duration> {
        Some(CYCLE)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::options::tests::block;
    use crate::testing::pose;
    use player_proto::Bbox3d;

    fn geom() -> Position2dGeom {
        Position2dGeom {
            pose: Pose3d::default(),
            size: Bbox3d {
                sw: 0.38,
                sl: 0.44,
                sh: 0.25,
            },
        }
    }

    #[test]
    fn options_default_as_upstream_and_angles_are_degrees() {
        let s = Settings::from_block(&block("nd", &[])).unwrap();
        assert_eq!(s, Settings::default());
        assert_eq!(s.sonar_buffer, 20);
        let s = Settings::from_block(&block(
            "nd",
            &[
                ("goal_tol", "0.3 15"),
                ("max_speed", "0.4 30"),
                ("translate_stuck_angle", "10"),
                ("sonar_bad_transducers", "0 3"),
                ("wait_on_stall", "1"),
            ],
        ))
        .unwrap();
        assert_eq!(s.dist_eps, 0.3);
        assert!((s.ang_eps - 15f64.to_radians()).abs() < 1e-12);
        assert!((s.va_max - 30f64.to_radians()).abs() < 1e-12);
        assert!((s.translate_stuck_angle - 10f64.to_radians()).abs() < 1e-12);
        assert_eq!(s.sonar_bad_transducers, [0, 3]);
        assert!(s.wait_on_stall);
        assert!(Settings::from_block(&block("nd", &[("laser_buffer", "0")])).is_err());
        assert!(Settings::from_block(&block("nd", &[("avoid_dist", "far")])).is_err());
    }

    #[test]
    fn thresholds_keep_the_sign_and_zero() {
        assert_eq!(threshold(0.0, 0.1, 0.3), 0.0);
        assert_eq!(threshold(0.01, 0.1, 0.3), 0.1);
        assert_eq!(threshold(0.5, 0.1, 0.3), 0.3);
        assert_eq!(threshold(-0.01, 0.1, 0.3), -0.1);
        assert_eq!(threshold(-0.5, 0.1, 0.3), -0.3);
    }

    #[test]
    fn the_robot_geometry_follows_the_driving_direction() {
        let s = Settings {
            safety_dist: 0.1,
            ..Settings::default()
        };
        let mut g = geom();
        g.pose.px = -0.04;
        let f = s.nd_params(&g, true);
        assert!((f.front - (0.22 - 0.04 + 0.1)).abs() < 1e-12);
        assert!((f.back - (0.22 + 0.04 + 0.1)).abs() < 1e-12);
        assert!((f.left - 0.29).abs() < 1e-12);
        assert!((f.discontinuity - 0.58).abs() < 1e-12);
        assert!((f.dsmin - 0.125).abs() < 1e-12 && (f.enlarge - 0.025).abs() < 1e-12);
        let b = s.nd_params(&g, false);
        assert_eq!((b.front, b.back), (f.back, f.front));
    }

    #[test]
    fn a_goal_is_driven_to_and_reached() {
        let mut nav = Navigator::new(Settings::default());
        nav.reset();
        nav.set_pose(pose(0.0, 0.0, 0.0));
        assert_eq!(nav.step(0.0), Decision::Idle, "no goal");
        nav.set_goal(pose(3.0, 0.0, 0.0), 0.0);
        assert_eq!(nav.step(0.0), Decision::Idle, "no geometry yet");
        nav.set_geometry(geom());
        // The laser sees a far wall.
        let ranges = vec![5.0f32; 181];
        nav.laser_scan(
            &Pose3d::default(),
            -std::f64::consts::FRAC_PI_2,
            1f64.to_radians(),
            &ranges,
        );
        let Decision::Drive(vx, va) = nav.step(0.02) else {
            panic!("should drive");
        };
        assert!((vx - 0.3).abs() < 1e-9 && va.abs() < 1e-6, "{vx} {va}");
        // Close enough in distance, heading off: turn in place.
        nav.set_pose(pose(2.8, 0.0, 1.0));
        let Decision::Drive(vx, va) = nav.step(0.04) else {
            panic!("should turn");
        };
        assert_eq!(vx, 0.0);
        assert!(va < 0.0 && va.abs() >= 10f64.to_radians() - 1e-9, "{va}");
        nav.set_pose(pose(2.8, 0.0, 0.05));
        assert_eq!(nav.step(0.06), Decision::Arrived);
        assert!(!nav.active() && !nav.stalled);
    }

    #[test]
    fn no_progress_gives_up_with_a_stall() {
        let mut nav = Navigator::new(Settings::default());
        nav.reset();
        nav.set_geometry(geom());
        nav.set_pose(pose(0.0, 0.0, 0.0));
        nav.set_goal(pose(3.0, 0.0, 0.0), 10.0);
        assert!(matches!(nav.step(10.0), Decision::Drive(..)));
        // The robot does not move for longer than translate_stuck_time.
        assert!(matches!(nav.step(11.9), Decision::Drive(..)));
        assert_eq!(nav.step(12.1), Decision::GaveUp);
        assert!(nav.stalled && !nav.active());
        // A new goal clears the stall.
        nav.set_goal(pose(3.0, 0.0, 0.0), 13.0);
        assert!(!nav.stalled);
    }

    #[test]
    fn a_velocity_command_cancels_the_goal_and_sets_the_direction() {
        let mut nav = Navigator::new(Settings::default());
        nav.reset();
        nav.set_geometry(geom());
        nav.set_goal(pose(-3.0, 0.0, 0.0), 0.0);
        nav.velocity_command(-0.1);
        assert!(!nav.active());
        nav.set_goal(pose(-3.0, 0.0, 0.0), 0.0);
        // Backwards: ND sees the robot facing the goal, the speed comes out negative.
        let Decision::Drive(vx, _) = nav.step(0.02) else {
            panic!("should drive");
        };
        assert!(vx < 0.0, "{vx}");
    }

    #[test]
    fn scans_are_buffered_in_the_odometric_frame() {
        let mut nav = Navigator::new(Settings {
            laser_buffer: 2,
            sonar_bad_transducers: vec![1],
            ..Settings::default()
        });
        nav.set_pose(pose(1.0, 2.0, std::f64::consts::FRAC_PI_2));
        let laser = Pose3d {
            px: 0.1,
            ..Pose3d::default()
        };
        nav.laser_scan(&laser, 0.0, 0.0, &[1.0]);
        let (x, y) = nav.laser_scans[0][0];
        assert!((x - 1.0).abs() < 1e-9 && (y - 3.1).abs() < 1e-9, "{x} {y}");
        nav.laser_scan(&laser, 0.0, 0.0, &[2.0]);
        nav.laser_scan(&laser, 0.0, 0.0, &[3.0]);
        assert_eq!(nav.laser_scans.len(), 2, "oldest dropped");
        assert!((nav.laser_scans[0][0].1 - 4.1).abs() < 1e-9);
        let ring = [Pose3d::default(), Pose3d::default(), Pose3d::default()];
        nav.sonar_scan(&ring, &[1.0, 1.0, 1.0]);
        assert_eq!(nav.sonar_scans[0].len(), 2, "transducer 1 ignored");
    }

    mod driver {
        use super::*;
        use crate::testing::{Harness, addr, block as test_block};
        use player_proto::{LaserDataScan, LaserGeom};

        fn nav() -> DeviceAddr {
            addr(InterfaceCode::POSITION2D, 1)
        }
        fn base() -> DeviceAddr {
            addr(InterfaceCode::POSITION2D, 0)
        }
        fn laser() -> DeviceAddr {
            addr(InterfaceCode::LASER, 0)
        }

        fn nd_block(options: &[(&str, &str)]) -> DriverBlock {
            let mut b = test_block(NAME, &[nav()], &[base(), base(), laser()], options);
            b.requires[0].key = Some("output".into());
            b.requires[1].key = Some("input".into());
            b
        }

        fn state(px: f64, stall: u8) -> Position2dData {
            Position2dData::State(Position2dDataState {
                pos: pose(px, 0.0, 0.0),
                vel: pose(0.1, 0.0, 0.0),
                stall,
            })
        }

        /// A position goal 4 m straight ahead of the origin.
        fn goal_ahead() -> Position2dCmd {
            Position2dCmd::Pos(player_proto::Position2dCmdPos {
                pos: pose(4.0, 0.0, 0.0),
                ..Default::default()
            })
        }

        /// The velocity commands sent to the base.
        fn commands(out: &crate::testing::Outcome) -> Vec<(f64, f64)> {
            out.actions
                .iter()
                .filter_map(|a| match a {
                    player_server::Action::Command(
                        to,
                        Body::Position2d(Position2dMsg::Cmd(Position2dCmd::Vel(v))),
                    ) if *to == base() => Some((v.vel.px, v.vel.pa)),
                    _ => None,
                })
                .collect()
        }

        /// A driver set up, with the base's and the laser's geometry answered.
        fn ready(options: &[(&str, &str)]) -> Harness<Nd> {
            let mut h = Harness::new(Nd::from_block(&nd_block(options)).unwrap());
            let out = h.setup();
            assert_eq!(out.subscriptions(), [base(), laser()], "the base once");
            let reqs = out.requests();
            assert_eq!(reqs.len(), 2);
            h.ack(reqs[0].0, base(), Position2dReq::GetGeom(Some(geom())));
            h.ack(
                reqs[1].0,
                laser(),
                LaserReq::GetGeom(Some(LaserGeom::default())),
            );
            h
        }

        #[test]
        fn blocks_need_keyed_position_devices_and_a_range_sensor() {
            let unkeyed = test_block(NAME, &[nav()], &[base(), laser()], &[]);
            assert!(
                Nd::from_block(&unkeyed)
                    .unwrap_err()
                    .to_string()
                    .contains("output")
            );
            let mut no_sensor = nd_block(&[]);
            no_sensor.requires.pop();
            assert!(
                Nd::from_block(&no_sensor)
                    .unwrap_err()
                    .to_string()
                    .contains("sonar or one laser")
            );
        }

        #[test]
        fn odometry_is_republished_with_the_stall_of_giving_up() {
            let mut h = ready(&[]);
            let out = h.data(base(), state(1.0, 0), 2.0);
            assert_eq!(out.published.len(), 1);
            assert_eq!(out.published[0].addr, nav());
            assert_eq!(out.published[0].timestamp, Some(2.0));
            assert_eq!(out.bodies()[0], state(1.0, 0).into());
            // A goal the robot never moves towards: nd gives up after translate_stuck_time,
            // stops the robot and reports a stall.
            h.command(nav(), goal_ahead());
            let out = h.update();
            assert_eq!(commands(&out), [(0.3, 0.0)]);
            h.now += 2.5;
            let out = h.update();
            assert_eq!(commands(&out), [(0.0, 0.0)]);
            let out = h.data(base(), state(1.0, 0), 4.5);
            let Body::Position2d(Position2dMsg::Data(Position2dData::State(s))) = &out.bodies()[0]
            else {
                panic!("state expected");
            };
            assert_eq!(s.stall, 1);
        }

        #[test]
        fn laser_scans_become_obstacles() {
            let mut h = ready(&[]);
            h.data(base(), state(0.0, 0), 1.0);
            // A wall 0.3 m ahead, across the whole view: ND cannot go forward.
            let scan = LaserDataScan {
                min_angle: -std::f32::consts::FRAC_PI_2,
                max_angle: std::f32::consts::FRAC_PI_2,
                resolution: 1f32.to_radians(),
                max_range: 8.0,
                ranges: (0..=180)
                    .map(|i| {
                        let b = (i as f32 - 90.0).to_radians();
                        (0.3 / b.cos()).min(8.0)
                    })
                    .collect(),
                ..LaserDataScan::default()
            };
            h.data(laser(), LaserData::Scan(scan), 1.0);
            h.command(nav(), goal_ahead());
            let out = h.update();
            let cmds = commands(&out);
            assert_eq!(cmds.len(), 1);
            assert!(
                cmds[0] != (0.3, 0.0),
                "the wall changes the command: {cmds:?}"
            );
        }

        #[test]
        fn sonar_readings_become_obstacles_without_the_bad_transducers() {
            let sonar = addr(InterfaceCode::SONAR, 0);
            let mut b = test_block(NAME, &[nav()], &[base(), base(), sonar], &[]);
            b.requires[0].key = Some("output".into());
            b.requires[1].key = Some("input".into());
            b.options
                .insert("sonar_bad_transducers".into(), vec!["1".into()]);
            let mut h = Harness::new(Nd::from_block(&b).unwrap());
            let reqs = h.setup().requests();
            assert_eq!(
                (reqs[1].1, &reqs[1].2),
                (sonar, &SonarReq::GetGeom(None).into())
            );
            h.ack(reqs[0].0, base(), Position2dReq::GetGeom(Some(geom())));
            // Transducer 0 looks ahead, 1 (ignored) too, 2 behind.
            let ahead = Pose3d::default();
            let behind = Pose3d {
                pyaw: std::f64::consts::PI,
                ..Pose3d::default()
            };
            h.ack(
                reqs[1].0,
                sonar,
                SonarReq::GetGeom(Some(player_proto::SonarGeom {
                    poses: vec![ahead, ahead, behind],
                })),
            );
            h.data(base(), state(0.0, 0), 1.0);
            // Only the ignored transducer sees something close: free driving.
            let readings = |r: [f32; 3]| {
                SonarData::Ranges(player_proto::SonarDataRanges { ranges: r.to_vec() })
            };
            h.data(sonar, readings([5.0, 0.1, 5.0]), 1.0);
            h.command(nav(), goal_ahead());
            assert_eq!(commands(&h.update()), [(0.3, 0.0)]);
            // Transducer 0 sees an obstacle at the robot's nose: emergency stop.
            h.data(sonar, readings([0.1, 5.0, 5.0]), 1.1);
            assert_eq!(commands(&h.update()), [(0.0, 0.0)]);
            assert!(h.driver.nav.stalled);
        }

        #[test]
        fn wait_on_stall_stops_and_hides_the_stall() {
            let mut h = ready(&[("wait_on_stall", "1")]);
            h.command(nav(), goal_ahead());
            let out = h.data(base(), state(0.0, 1), 1.0);
            assert_eq!(commands(&out), [(0.0, 0.0)]);
            let Body::Position2d(Position2dMsg::Data(Position2dData::State(s))) = &out.bodies()[0]
            else {
                panic!("state expected");
            };
            assert_eq!(s.stall, 0);
            assert!(commands(&h.update()).is_empty(), "paused while stalled");
            h.data(base(), state(0.0, 0), 1.1);
            assert_eq!(commands(&h.update()).len(), 1, "resumes");
        }

        #[test]
        fn velocity_commands_pass_through_and_requests_go_to_the_output() {
            let mut h = ready(&[]);
            let out = h.command(
                nav(),
                Position2dCmd::Vel(Position2dCmdVel {
                    vel: pose(0.2, 0.0, 0.1),
                    state: 1,
                }),
            );
            assert_eq!(commands(&out), [(0.2, 0.1)]);
            let out = h.command(
                nav(),
                Position2dCmd::Vel(Position2dCmdVel {
                    vel: pose(0.2, 0.0, 0.1),
                    state: 0,
                }),
            );
            assert_eq!(commands(&out), [(0.0, 0.0)], "motors off: stop");
            let (reply, token, out) = h.request(nav(), Position2dReq::GetGeom(None));
            assert_eq!(reply, Reply::Deferred);
            let reqs = out.requests();
            assert_eq!(
                (reqs[0].1, &reqs[0].2),
                (base(), &Position2dReq::GetGeom(None).into())
            );
            let out = h.ack(reqs[0].0, base(), Position2dReq::GetGeom(Some(geom())));
            assert_eq!(
                out.answers(),
                [(token, Reply::ack(Position2dReq::GetGeom(Some(geom()))))]
            );
        }
    }
}
