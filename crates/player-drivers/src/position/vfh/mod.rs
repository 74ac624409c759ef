//! `vfh`: Vector Field Histogram Plus local navigation (Player 3.0.2's
//! `server/drivers/position/vfh`).
//!
//! Provides a `position2d` that drives the required `position2d` to goal poses while avoiding
//! what the required `laser` (or `sonar`: exactly one of the two) sees. A position command
//! (`PLAYER_POSITION2D_CMD_POS`, libplayerc's `GoTo`) sets the goal, in the odometric frame of
//! the base below; the driver then sends that base velocity commands until it is within
//! `distance_epsilon` of the goal and `angle_epsilon` of its heading, and stops. A velocity
//! command is passed straight to the base and ends position control. The base's odometry is
//! republished unchanged (with its timestamp) on the provided device, and every request to the
//! provided device is answered by the base.
//!
//! The work is done on each message, as upstream's thread does after each batch it wakes to:
//! each odometry state, scan, sonar reading and position command runs one navigation step
//! (nothing is sent without a goal). Steps wait for the base's geometry (its larger side gives
//! the robot radius VFH keeps clear), a first odometry state and a first scan.
//!
//! Options, with Player 3.0.2's defaults (lengths in metres, angles in degrees, as Player reads
//! cfg files): see [`Settings::from_block`]. The `synchronous` option is accepted; both of
//! upstream's modes (own thread, or the server's thread) come to the same here.
//!
//! Differences from 3.0.2, all where upstream's behaviour is undefined:
//! * upstream computes its obstacle-enlargement tables in the driver's constructor, before it
//!   has asked the base for its size, from a robot radius that is still uninitialised memory
//!   (so obstacles are widened by the safety distance plus whatever that memory held, or by
//!   nothing when it makes the arcsine NaN). The tables here are built from the base's real
//!   radius, as the algorithm intends and as Player's earlier vfh did (building them in setup);
//! * the robot's own window cell is never an obstacle (upstream reads outside its range table
//!   for it); speeds beyond the turning-radius table use its last entry (upstream reads past
//!   it); sonar readings beyond the transducers in the geometry are left out;
//! * the random turn rate of a stall escape comes from a seeded generator (repeatable runs);
//! * the `planner` interface upstream can also provide is not supported (the block is refused).

pub mod algorithm;
pub mod navigator;
pub mod ranges;

use std::f64::consts::PI;

use player_proto::{
    Body, DeviceAddr, InterfaceCode, LaserData, LaserMsg, Message, Pose3d, Position2dCmd,
    Position2dData, Position2dMsg, Position2dReq, SonarData, SonarMsg, SonarReq,
};
use player_server::{
    Context, Driver, DriverBlock, DriverError, PendingReply, Reply, RequestError, RequestTicket,
};

use crate::forward::{Waiting, refuse_own_device};
use crate::options;
use algorithm::{Params, Vfh};
use navigator::{GoalSettings, Navigator, Odometry};
use ranges::HalfDegreeRanges;

/// The Player name of this driver.
pub const NAME: &str = "vfh";

/// Largest `window_diameter` accepted: the window's tables grow with its square (upstream's
/// default is 61 cells).
pub const MAX_WINDOW_DIAMETER: i64 = 201;

/// Largest `max_speed` accepted (m/s): VFH tabulates the turning radius per mm/s up to it.
pub const MAX_SPEED_LIMIT: f64 = 100.0;

/// The driver's settings, from its cfg block.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// VFH's parameters, converted to its units as upstream converts them.
    pub algorithm: Params,
    /// Goal tolerances and stall escape.
    pub goal: GoalSettings,
    /// Upstream's `synchronous` flag (run in the server thread); no effect here.
    pub synchronous: bool,
}

impl Default for Settings {
    fn default() -> Settings {
        Settings::from_block(&DriverBlock::default()).expect("the defaults are valid")
    }
}

/// `round()` the way C's `rint` does (half to even), to whole mm or degrees.
fn whole(v: f64) -> i32 {
    v.round_ties_even() as i32
}

impl Settings {
    /// Reads the options of a cfg block; absent ones take Player 3.0.2's defaults:
    ///
    /// | option | default | unit |
    /// |---|---|---|
    /// | `cell_size` | 0.1 | m |
    /// | `window_diameter` | 61 | cells |
    /// | `sector_angle` | 5 | degrees (whole) |
    /// | `safety_dist_0ms` | 0.1 | m |
    /// | `safety_dist_1ms` | `safety_dist_0ms` | m |
    /// | `max_speed` | 0.2 | m/s |
    /// | `max_speed_narrow_opening` | `max_speed` | m/s |
    /// | `max_speed_wide_opening` | `max_speed` | m/s |
    /// | `max_acceleration` | 0.2 | m/s² |
    /// | `min_turnrate` | 10 | deg/s |
    /// | `max_turnrate_0ms` | 40 | deg/s |
    /// | `max_turnrate_1ms` | `max_turnrate_0ms` | deg/s |
    /// | `min_turn_radius_safety_factor` | 1.0 | |
    /// | `free_space_cutoff_0ms` | 2000000.0 | |
    /// | `obs_cutoff_0ms` | `free_space_cutoff_0ms` | |
    /// | `free_space_cutoff_1ms` | `free_space_cutoff_0ms` | |
    /// | `obs_cutoff_1ms` | `free_space_cutoff_1ms` | |
    /// | `weight_desired_dir` | 5.0 | |
    /// | `weight_current_dir` | 3.0 | |
    /// | `distance_epsilon` | 0.5 | m |
    /// | `angle_epsilon` | 10 | degrees |
    /// | `escape_speed` | 0.0 | m/s |
    /// | `escape_time` | 0.0 | s |
    /// | `escape_max_turnrate` | 0.0 | deg/s |
    /// | `synchronous` | 0 | |
    ///
    /// As upstream, speeds are kept in whole mm/s and turn rates in whole deg/s.
    pub fn from_block(block: &DriverBlock) -> Result<Settings, DriverError> {
        // Turn rates are kept in whole deg/s: upstream's rint(RTOD(ReadAngle(key, DTOR(d)))).
        let deg = |key: &str, default: f64| -> Result<f64, DriverError> {
            Ok(options::angle(block, key)?.unwrap_or(default * PI / 180.0) * 180.0 / PI)
        };

        let cell_size = options::length(block, "cell_size")?.unwrap_or(0.1);
        if !(cell_size > 0.0 && cell_size.is_finite()) {
            return Err(DriverError::new(format!(
                "option `cell_size` must be a positive length, not {cell_size}"
            )));
        }
        let window_diameter = options::int(block, "window_diameter")?.unwrap_or(61);
        if !(1..=MAX_WINDOW_DIAMETER).contains(&window_diameter) {
            return Err(DriverError::new(format!(
                "option `window_diameter` must be between 1 and {MAX_WINDOW_DIAMETER} cells, \
                 not {window_diameter}"
            )));
        }
        let sector_angle = options::int(block, "sector_angle")?.unwrap_or(5);
        if !(1..=360).contains(&sector_angle) {
            return Err(DriverError::new(format!(
                "option `sector_angle` must be between 1 and 360 degrees, not {sector_angle}"
            )));
        }
        let safety_dist_0ms = options::length(block, "safety_dist_0ms")?.unwrap_or(0.1) * 1e3;
        let safety_dist_1ms =
            options::length(block, "safety_dist_1ms")?.unwrap_or(safety_dist_0ms / 1e3) * 1e3;
        let max_speed_m = options::length(block, "max_speed")?.unwrap_or(0.2);
        if !(0.0..=MAX_SPEED_LIMIT).contains(&max_speed_m) {
            return Err(DriverError::new(format!(
                "option `max_speed` must be between 0 and {MAX_SPEED_LIMIT} m/s, not {max_speed_m}"
            )));
        }
        let max_speed = whole(1e3 * max_speed_m);
        let max_speed_narrow_opening = whole(
            1e3 * options::length(block, "max_speed_narrow_opening")?
                .unwrap_or(f64::from(max_speed) / 1e3),
        );
        let max_speed_wide_opening = whole(
            1e3 * options::length(block, "max_speed_wide_opening")?
                .unwrap_or(f64::from(max_speed) / 1e3),
        );
        let max_acceleration =
            whole(1e3 * options::length(block, "max_acceleration")?.unwrap_or(0.2));
        let min_turnrate = whole(deg("min_turnrate", 10.0)?);
        let max_turnrate_0ms = whole(deg("max_turnrate_0ms", 40.0)?);
        let max_turnrate_1ms = whole(deg("max_turnrate_1ms", f64::from(max_turnrate_0ms))?);
        let free_space_cutoff_0ms =
            options::float(block, "free_space_cutoff_0ms")?.unwrap_or(2_000_000.0);
        let obs_cutoff_0ms =
            options::float(block, "obs_cutoff_0ms")?.unwrap_or(free_space_cutoff_0ms);
        let free_space_cutoff_1ms =
            options::float(block, "free_space_cutoff_1ms")?.unwrap_or(free_space_cutoff_0ms);
        // Upstream's default for the 1 m/s obstacle cutoff is the 1 m/s free-space one.
        let obs_cutoff_1ms =
            options::float(block, "obs_cutoff_1ms")?.unwrap_or(free_space_cutoff_1ms);
        Ok(Settings {
            algorithm: Params {
                cell_width: (cell_size * 1e3) as f32,
                window_diameter: window_diameter as usize,
                sector_angle: sector_angle as i32,
                safety_dist_0ms: safety_dist_0ms as f32,
                safety_dist_1ms: safety_dist_1ms as f32,
                max_speed,
                max_speed_narrow_opening,
                max_speed_wide_opening,
                max_acceleration,
                min_turnrate,
                max_turnrate_0ms,
                max_turnrate_1ms,
                min_turn_radius_safety_factor: options::float(
                    block,
                    "min_turn_radius_safety_factor",
                )?
                .unwrap_or(1.0),
                free_space_cutoff_0ms: free_space_cutoff_0ms as f32,
                obs_cutoff_0ms: obs_cutoff_0ms as f32,
                free_space_cutoff_1ms: free_space_cutoff_1ms as f32,
                obs_cutoff_1ms: obs_cutoff_1ms as f32,
                weight_desired_dir: options::float(block, "weight_desired_dir")?.unwrap_or(5.0)
                    as f32,
                weight_current_dir: options::float(block, "weight_current_dir")?.unwrap_or(3.0)
                    as f32,
            },
            goal: GoalSettings {
                distance_epsilon: options::length(block, "distance_epsilon")?.unwrap_or(0.5),
                angle_epsilon: options::angle(block, "angle_epsilon")?
                    .unwrap_or(10f64.to_radians()),
                escape_speed: options::length(block, "escape_speed")?.unwrap_or(0.0),
                escape_time: options::float(block, "escape_time")?.unwrap_or(0.0),
                escape_max_turnrate: options::angle(block, "escape_max_turnrate")?.unwrap_or(0.0),
            },
            synchronous: options::flag(block, "synchronous")?.unwrap_or(false),
        })
    }
}

/// The range sensor VFH avoids obstacles with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RangeSensor {
    /// A laser: its SCAN data.
    Laser(DeviceAddr),
    /// A sonar ring: its RANGES data, placed by its geometry.
    Sonar(DeviceAddr),
}

impl RangeSensor {
    fn addr(&self) -> DeviceAddr {
        match self {
            RangeSensor::Laser(a) | RangeSensor::Sonar(a) => *a,
        }
    }
}

/// The driver.
#[derive(Debug)]
pub struct VfhDriver {
    addr: DeviceAddr,
    odom: DeviceAddr,
    sensor: RangeSensor,
    settings: Settings,
    navigator: Navigator,
    vfh: Option<Vfh>,
    waiting: Waiting<PendingReply>,
    geom_request: Option<RequestTicket>,
    sonar_geom_request: Option<RequestTicket>,
    sonar_poses: Option<Vec<Pose3d>>,
    odometry: Option<Odometry>,
    ranges: Option<Box<HalfDegreeRanges>>,
}

impl VfhDriver {
    /// Builds the driver from its cfg block.
    pub fn from_block(block: &DriverBlock) -> Result<VfhDriver, DriverError> {
        if let Some(p) = block
            .provides
            .iter()
            .find(|p| p.addr.interf == InterfaceCode::PLANNER)
        {
            return Err(DriverError::new(format!(
                "{}: vfh's planner interface is not supported; provide only a position2d",
                p.origin
            )));
        }
        let addr = block.provided(InterfaceCode::POSITION2D)?;
        // An absent key matches entries of any key, as Player's ReadDeviceAddr with NULL.
        let odom = block.required(InterfaceCode::POSITION2D, None)?.addr;
        refuse_own_device(addr, &[odom])?;
        let (laser, sonar) = super::laser_and_sonar(block)?;
        let sensor = match (laser, sonar) {
            (Some(l), None) => RangeSensor::Laser(l),
            (None, Some(s)) => RangeSensor::Sonar(s),
            _ => {
                return Err(DriverError::new(
                    "vfh needs exactly one sonar or one laser in `requires`",
                ));
            }
        };
        let settings = Settings::from_block(block)?;
        Ok(VfhDriver {
            addr,
            odom,
            sensor,
            navigator: Navigator::new(settings.goal.clone()),
            settings,
            vfh: None,
            waiting: Waiting::default(),
            geom_request: None,
            sonar_geom_request: None,
            sonar_poses: None,
            odometry: None,
            ranges: None,
        })
    }

    /// The settings in force.
    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    /// The base's geometry arrived: (re)build VFH's window for its radius, unless it is the
    /// one already built (VFH's history then carries over, as upstream's does).
    fn set_robot_size(&mut self, geom: &player_proto::Position2dGeom, now: f64) {
        let radius_mm = (geom.size.sl.max(geom.size.sw) as f32 / 2.0) * 1000.0;
        if self.vfh.as_ref().map(Vfh::robot_radius) != Some(radius_mm) {
            tracing::debug!("vfh: robot radius {radius_mm} mm");
            self.vfh = Some(Vfh::new(self.settings.algorithm.clone(), radius_mm, now));
        }
    }

    /// One navigation step, once everything it needs has arrived.
    fn step(&mut self, ctx: &mut Context<'_>) {
        if self.geom_request.is_some() {
            return;
        }
        let (Some(vfh), Some(odom), Some(ranges)) = (
            self.vfh.as_mut(),
            self.odometry.as_ref(),
            self.ranges.as_deref(),
        ) else {
            return;
        };
        if let Some(cmd) = self.navigator.step(vfh, odom, ranges, ctx.now()) {
            ctx.command(self.odom, Position2dCmd::Vel(cmd));
        }
    }
}

impl Driver for VfhDriver {
    fn setup(&mut self, ctx: &mut Context<'_>) -> Result<(), DriverError> {
        self.navigator.reset();
        self.odometry = None;
        self.ranges = None;
        ctx.subscribe(self.odom);
        ctx.subscribe(self.sensor.addr());
        self.geom_request = Some(ctx.request(self.odom, Position2dReq::GetGeom(None)));
        if let RangeSensor::Sonar(sonar) = self.sensor {
            self.sonar_poses = None;
            self.sonar_geom_request = Some(ctx.request(sonar, SonarReq::GetGeom(None)));
        }
        Ok(())
    }

    fn teardown(&mut self, ctx: &mut Context<'_>) {
        // Stop the robot before letting go of it.
        ctx.command(self.odom, Position2dCmd::Vel(self.navigator.stop()));
        self.geom_request = None;
        self.sonar_geom_request = None;
    }

    fn handle_data(&mut self, ctx: &mut Context<'_>, data: &Message) {
        let from = data.header.addr;
        match &data.body {
            Body::Position2d(Position2dMsg::Data(Position2dData::State(state)))
                if from.same_device(&self.odom) =>
            {
                self.odometry = Some(Odometry {
                    pose: state.pos,
                    speed: state.vel.px,
                    stall: state.stall != 0,
                });
                ctx.publish_at(
                    self.addr,
                    Position2dData::State(state.clone()),
                    data.header.timestamp,
                );
            }
            Body::Laser(LaserMsg::Data(LaserData::Scan(scan)))
                if matches!(self.sensor, RangeSensor::Laser(_))
                    && from.same_device(&self.sensor.addr()) =>
            {
                self.ranges = Some(Box::new(ranges::from_laser(&scan.ranges, scan.resolution)));
            }
            Body::Sonar(SonarMsg::Data(SonarData::Ranges(r)))
                if matches!(self.sensor, RangeSensor::Sonar(_))
                    && from.same_device(&self.sensor.addr()) =>
            {
                let Some(poses) = &self.sonar_poses else {
                    return;
                };
                self.ranges = Some(Box::new(ranges::from_sonar(&r.ranges, poses)));
            }
            _ => return,
        }
        self.step(ctx);
    }

    fn handle_command(&mut self, ctx: &mut Context<'_>, command: &Message) {
        match &command.body {
            Body::Position2d(Position2dMsg::Cmd(Position2dCmd::Pos(goal))) => {
                self.navigator.set_goal(goal);
                self.step(ctx);
            }
            Body::Position2d(Position2dMsg::Cmd(Position2dCmd::Vel(_))) => {
                ctx.command(self.odom, command.body.clone());
                self.navigator.cancel_goal();
            }
            other => tracing::warn!(
                "vfh: ignoring command {} (it takes position and velocity commands)",
                other.constant()
            ),
        }
    }

    fn handle_request(&mut self, ctx: &mut Context<'_>, request: &Message) -> Reply {
        self.waiting
            .forward(ctx, self.odom, request.body.clone(), |p| p)
    }

    fn handle_reply(
        &mut self,
        ctx: &mut Context<'_>,
        ticket: RequestTicket,
        reply: Result<Message, RequestError>,
    ) {
        let Some(reply) = self.waiting.pass_back(ctx, ticket, reply) else {
            return;
        };
        if self.geom_request == Some(ticket) {
            self.geom_request = None;
            match reply.as_ref().map(|m| &m.body) {
                Ok(Body::Position2d(Position2dMsg::Ack(Position2dReq::GetGeom(Some(g))))) => {
                    self.set_robot_size(g, ctx.now());
                }
                Ok(other) => tracing::error!(
                    "vfh: failed to get geometry of underlying position device {} (got {}); \
                     not navigating",
                    self.odom,
                    other.constant()
                ),
                Err(e) => tracing::error!(
                    "vfh: failed to get geometry of underlying position device {}: {e}; \
                     not navigating",
                    self.odom
                ),
            }
        } else if self.sonar_geom_request == Some(ticket) {
            self.sonar_geom_request = None;
            match reply.as_ref().map(|m| &m.body) {
                Ok(Body::Sonar(SonarMsg::Ack(SonarReq::GetGeom(Some(g))))) => {
                    self.sonar_poses = Some(g.poses.clone());
                }
                _ => tracing::error!(
                    "vfh: failed to get sonar geometry from {}; not navigating",
                    self.sensor.addr()
                ),
            }
        }
    }
}

#[cfg(test)]
mod tests;
