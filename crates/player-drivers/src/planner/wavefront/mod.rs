//! `wavefront`: Player 3.0.2's global path planner. It provides a `planner` device; given a
//! goal it plans over the map with a wavefront (Dijkstra from the goal, penalising nearness to
//! obstacles), reduces the path to waypoints, and drives the robot there one waypoint at a
//! time by sending position commands to the position2d device it requires as `output`, while
//! tracking the robot's pose from the position2d device it requires as `input` (a localiser
//! such as amcl, or odometry).
//!
//! cfg: `provides ["planner:0"]`, `requires ["output:::position2d:1" "input:::position2d:2"
//! "map:0"]`. Setup, as upstream, turns the output device's motors on, asks its geometry
//! (the robot's radius is half its width) and fetches the whole map; the c-space and every
//! plan are computed on a worker thread so that a large map never stalls the server (upstream
//! plans inside its own driver thread, which is the same thing).
//!
//! With a `laser` in its requires it reads pose-stamped scans (DATA SCANPOSE, in the map
//! frame: e.g. `laserposeinterpolator` on amcl's pose), keeps the last `laser_buffer_size`,
//! and counts every hit nearer than `laser_maxrange` as an obstacle on top of the map; each
//! replan is then first tried as a local plan within `laser_maxrange` of the robot along the
//! global path, and made over the whole map only when that fails. With `velocity_control 1`
//! it replans every cycle and steers the robot itself with velocity commands towards a
//! "carrot" up to 2 m ahead on the plan (`control_tv`, `control_av`, `control_a`). Player
//! 3.0.2 reads no `cspace_file` (its c-space cache is compiled out), and neither do we.
//!
//! Without a laser, upstream still tries its local plan, with an uninitialised window size;
//! here every replan is global then.
//!
//! Where this differs from upstream, on purpose: a new goal with no path clears the plan and
//! stops the robot (upstream can keep stepping through the old plan's waypoints while it
//! retries); `request_map 0` fetches the map when the map device publishes its DATA INFO
//! (3.0.2 only notes the announcement, and then never loads a map).

mod cells;
pub mod control;
pub mod plan;
mod queue;

use std::sync::mpsc;
use std::time::Duration;

use player_proto::{
    Body, DeviceAddr, InterfaceCode, LaserData, LaserDataScanpose, LaserMsg, MapData, MapMsg,
    Message, PlannerCmd, PlannerCmdMsg, PlannerDataMsg, PlannerEnableReq, PlannerMsg, PlannerReq,
    PlannerWaypointsReq, Pose2d, Position2dCmd, Position2dCmdPos, Position2dCmdVel, Position2dData,
    Position2dMsg, Position2dPowerConfig, Position2dReq,
};
use player_server::map::OccupancyGrid;
use player_server::{
    Context, Driver, DriverBlock, DriverError, DriverWaker, Reply, RequestError, RequestTicket,
    WorkerThread,
};

use crate::error::Error;
use crate::map::fetch::{Fetched, MapFetch};
use crate::options;
use control::{Control, ControlSettings, Motion, VelocityGains};
use plan::{Plan, PlanParams};

/// The driver's cfg name.
pub const NAME: &str = "wavefront";

/// How often upstream publishes the planner's state (s).
const PUBLISH_INTERVAL: f64 = 0.25;

/// The cfg options, with Player 3.0.2's defaults (`Wavefront::Wavefront` in wavefront.cc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WavefrontOptions {
    /// Clearance kept beyond the robot's radius (m); default 0.25.
    pub safety_dist: f64,
    /// Distance beyond which obstacles no longer add cost (m); default 1.0.
    pub max_radius: f64,
    /// Cost per metre of intrusion within `max_radius` of an obstacle; default 1.0.
    pub dist_penalty: f64,
    /// Waypoint/goal reached within this distance (m); default 0.5.
    pub distance_epsilon: f64,
    /// Goal heading reached within this angle (rad; written in degrees); default 10 deg.
    pub angle_epsilon: f64,
    /// Replan after moving this far (m), negative never; default 2.0.
    pub replan_dist_thresh: f64,
    /// ...and this long (s) since the last plan, negative never; default 2.0.
    pub replan_min_time: f64,
    /// Fetch the map at setup; 0 waits for the map device's DATA INFO instead. Default 1.
    pub request_map: bool,
    /// Turn on the spot before any waypoint far off the heading (else only the first);
    /// default 1.
    pub add_rotational_waypoints: bool,
    /// Fetch the map again with every new goal (for maps that change); default 0.
    pub force_map_refresh: bool,
    /// Control cycles per second; default 10.
    pub update_rate: f64,
    /// Steer with velocity commands (`velocity_control 1` and its gains), or `None` to send
    /// waypoints as position goals (default).
    pub velocity_control: Option<VelocityGains>,
    /// Scans kept for obstacles (`laser_buffer_size`); default 10.
    pub laser_buffer_size: usize,
    /// Hits at or beyond this range are not obstacles, and local plans reach this far (m;
    /// `laser_maxrange`); default 6.
    pub laser_maxrange: f64,
}

impl Default for WavefrontOptions {
    fn default() -> WavefrontOptions {
        WavefrontOptions {
            safety_dist: 0.25,
            max_radius: 1.0,
            dist_penalty: 1.0,
            distance_epsilon: 0.5,
            angle_epsilon: 10f64.to_radians(),
            replan_dist_thresh: 2.0,
            replan_min_time: 2.0,
            request_map: true,
            add_rotational_waypoints: true,
            force_map_refresh: false,
            update_rate: 10.0,
            velocity_control: None,
            laser_buffer_size: 10,
            laser_maxrange: 6.0,
        }
    }
}

impl WavefrontOptions {
    /// Reads the options of a `wavefront` block.
    pub fn from_block(block: &DriverBlock) -> Result<WavefrontOptions, Error> {
        let d = WavefrontOptions::default();
        let flag = |key: &str, default: bool| -> Result<bool, Error> {
            Ok(options::flag(block, key)?.unwrap_or(default))
        };
        let o = WavefrontOptions {
            safety_dist: options::length(block, "safety_dist")?.unwrap_or(d.safety_dist),
            max_radius: options::length(block, "max_radius")?.unwrap_or(d.max_radius),
            dist_penalty: options::float(block, "dist_penalty")?.unwrap_or(d.dist_penalty),
            distance_epsilon: options::length(block, "distance_epsilon")?
                .unwrap_or(d.distance_epsilon),
            angle_epsilon: options::angle(block, "angle_epsilon")?.unwrap_or(d.angle_epsilon),
            replan_dist_thresh: options::length(block, "replan_dist_thresh")?
                .unwrap_or(d.replan_dist_thresh),
            replan_min_time: options::float(block, "replan_min_time")?.unwrap_or(d.replan_min_time),
            request_map: flag("request_map", d.request_map)?,
            add_rotational_waypoints: flag("add_rotational_waypoints", d.add_rotational_waypoints)?,
            force_map_refresh: flag("force_map_refresh", d.force_map_refresh)?,
            update_rate: options::float(block, "update_rate")?.unwrap_or(d.update_rate),
            ..d
        };
        if !(o.update_rate > 0.0 && o.update_rate.is_finite()) {
            return Err(Error::BadOption {
                option: "update_rate".into(),
                value: o.update_rate.to_string(),
                why: "must be a positive rate in Hz".into(),
            });
        }
        if !(o.max_radius.is_finite() && o.max_radius > 0.0) {
            return Err(Error::BadOption {
                option: "max_radius".into(),
                value: o.max_radius.to_string(),
                why: "must be positive".into(),
            });
        }
        let mut o = o;
        if flag("velocity_control", false)? {
            let g = VelocityGains::default();
            let pair =
                |key: &'static str,
                 read: fn(&DriverBlock, &'static str, usize) -> Result<Option<f64>, Error>,
                 default: (f64, f64)|
                 -> Result<(f64, f64), Error> {
                    Ok((
                        read(block, key, 0)?.unwrap_or(default.0),
                        read(block, key, 1)?.unwrap_or(default.1),
                    ))
                };
            o.velocity_control = Some(VelocityGains {
                tv: pair("control_tv", options::tuple_length, g.tv)?,
                av: pair("control_av", options::tuple_angle, g.av)?,
                a: pair("control_a", options::tuple_angle, g.a)?,
            });
        }
        if let Some(n) = options::int(block, "laser_buffer_size")? {
            // Upstream warns and keeps one scan.
            if n < 1 {
                tracing::warn!("{}: must buffer at least one laser scan", block.origin);
            }
            o.laser_buffer_size = n.clamp(1, 1000) as usize;
        }
        o.laser_maxrange = options::length(block, "laser_maxrange")?.unwrap_or(d.laser_maxrange);
        Ok(o)
    }

    fn control(&self) -> ControlSettings {
        ControlSettings {
            dist_eps: self.distance_epsilon,
            ang_eps: self.angle_epsilon,
            replan_dist_thresh: self.replan_dist_thresh,
            replan_min_time: self.replan_min_time,
            always_rotate: self.add_rotational_waypoints,
            velocity: self.velocity_control,
        }
    }
}

/// Work for the planning thread.
enum Job {
    /// Build the c-space of this map.
    Map(OccupancyGrid, PlanParams),
    /// A fault injected by the tests: the planning thread panics on it.
    #[cfg(test)]
    Fault,
    /// Plan between two map-frame points with the current c-space.
    Plan {
        start: (f64, f64),
        goal: (f64, f64),
        started: f64,
        seq: u64,
        /// Try a local plan of this half width first (not for a new goal).
        local: Option<f64>,
        /// The laser's obstacles, when they changed since the last job.
        obstacles: Option<Vec<(f64, f64)>>,
        /// Find the carrot to steer for (velocity control).
        carrot: bool,
    },
}

/// What the planning thread hands back.
enum Done {
    /// The c-space is built (or the map was unusable).
    Map(Result<(), String>),
    /// Waypoints (empty: no path), for the plan started at `started` from `start`.
    Plan {
        start: (f64, f64),
        started: f64,
        seq: u64,
        waypoints: Vec<(f64, f64)>,
        /// A global plan was made and found a path.
        global_ok: bool,
        /// A global path exists (made now or earlier).
        has_path: bool,
        /// The carrot, when asked for and found.
        carrot: Option<(f64, f64)>,
    },
}

/// The planning thread and its two channels. Dropping it ends the thread after its current
/// job.
struct Worker {
    jobs: mpsc::Sender<Job>,
    done: mpsc::Receiver<Done>,
    /// The planning thread: its panic is raised in `wake`/`update` (the core reports it).
    thread: WorkerThread,
}

impl Worker {
    fn spawn(waker: Option<DriverWaker>) -> Result<Worker, DriverError> {
        let (jobs, job_rx) = mpsc::channel::<Job>();
        let (done_tx, done) = mpsc::channel();
        let thread = WorkerThread::spawn("wavefront", waker.clone(), move || {
            let mut current: Option<Plan> = None;
            for job in job_rx {
                let out = match job {
                    #[cfg(test)]
                    Job::Fault => panic!("injected fault in the planning thread"),
                    Job::Map(grid, params) => {
                        let o = grid.origin();
                        current = Plan::new(
                            grid.width() as usize,
                            grid.height() as usize,
                            f64::from(grid.scale()),
                            (o.px, o.py),
                            grid.cells(),
                            params,
                        );
                        Done::Map(current.as_ref().map(|_| ()).ok_or_else(|| {
                            format!(
                                "unusable map ({} x {} at {} m)",
                                grid.width(),
                                grid.height(),
                                grid.scale()
                            )
                        }))
                    }
                    Job::Plan {
                        start,
                        goal,
                        started,
                        seq,
                        local,
                        obstacles,
                        carrot,
                    } => match current.as_mut() {
                        Some(plan) => {
                            if let Some(points) = obstacles {
                                plan.set_obstacles(&points);
                            }
                            let local_plan = match local {
                                Some(half) if plan.has_global_path() => {
                                    plan.plan_local(start, half)
                                }
                                _ => None,
                            };
                            let (waypoints, global_ok) = match local_plan {
                                Some(r) => (r.waypoints, false),
                                None => {
                                    let r = plan.plan(start, goal);
                                    let ok = !r.waypoints.is_empty();
                                    (r.waypoints, ok)
                                }
                            };
                            Done::Plan {
                                start,
                                started,
                                seq,
                                waypoints,
                                global_ok,
                                has_path: plan.has_global_path(),
                                carrot: carrot
                                    .then(|| {
                                        plan.carrot(
                                            start,
                                            control::CARROT_MAX_DIST,
                                            control::CARROT_DIST_WEIGHT,
                                        )
                                    })
                                    .flatten(),
                            }
                        }
                        None => Done::Plan {
                            start,
                            started,
                            seq,
                            waypoints: Vec::new(),
                            global_ok: false,
                            has_path: false,
                            carrot: None,
                        },
                    },
                };
                if done_tx.send(out).is_err() {
                    break;
                }
                if let Some(w) = &waker {
                    w.wake();
                }
            }
        })
        .map_err(|e| DriverError::new(format!("cannot start the planning thread: {e}")))?;
        Ok(Worker { jobs, done, thread })
    }
}

/// The driver.
pub struct Wavefront {
    addr: DeviceAddr,
    output: DeviceAddr,
    input: DeviceAddr,
    map: DeviceAddr,
    /// Pose-stamped scans for obstacles, when required.
    laser: Option<DeviceAddr>,
    /// The last `laser_buffer_size` scans, oldest first.
    scans: std::collections::VecDeque<LaserDataScanpose>,
    /// Scans came in since the obstacles were last handed to the planner.
    scans_changed: bool,
    /// A plain scan (no pose) was seen and warned about.
    warned_plain_scan: bool,
    opts: WavefrontOptions,
    control: Control,
    worker: Option<Worker>,
    geom_ticket: Option<RequestTicket>,
    robot_radius: Option<f64>,
    fetch: Option<MapFetch>,
    /// A fetched map waiting for the robot's radius before its c-space can be built.
    pending_map: Option<OccupancyGrid>,
    /// The worker holds a c-space.
    have_map: bool,
    /// A job is with the worker; no other is sent meanwhile.
    busy: bool,
    /// A goal that arrived while the map was being fetched again (force_map_refresh).
    deferred_goal: Option<Pose2d>,
    last_publish: Option<f64>,
}

impl std::fmt::Debug for Wavefront {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Wavefront")
            .field("addr", &self.addr)
            .field("output", &self.output)
            .field("input", &self.input)
            .field("map", &self.map)
            .field("have_map", &self.have_map)
            .field("busy", &self.busy)
            .finish_non_exhaustive()
    }
}

impl Wavefront {
    /// Builds the driver from its cfg block.
    pub fn from_block(block: &DriverBlock) -> Result<Wavefront, DriverError> {
        let addr = block.provided(InterfaceCode::PLANNER)?;
        let (output, input) = crate::position::output_and_input(block)?;
        let map = block.required(InterfaceCode::MAP, None)?.addr;
        let laser = block
            .optional_required(InterfaceCode::LASER, None)?
            .map(|r| r.addr);
        let opts = WavefrontOptions::from_block(block)?;
        if laser.is_none() && opts.velocity_control.is_some() {
            tracing::warn!(
                "{}: wavefront doing direct velocity control, but without a laser for obstacle \
                 detection; this is not safe!",
                block.origin
            );
        }
        Ok(Wavefront {
            addr,
            output,
            input,
            map,
            laser,
            scans: std::collections::VecDeque::new(),
            scans_changed: false,
            warned_plain_scan: false,
            opts,
            control: Control::new(opts.control()),
            worker: None,
            geom_ticket: None,
            robot_radius: None,
            fetch: None,
            pending_map: None,
            have_map: false,
            busy: false,
            deferred_goal: None,
            last_publish: None,
        })
    }

    fn fetch_map(&mut self, ctx: &mut Context<'_>) {
        self.fetch = Some(MapFetch::start(ctx, self.map));
    }

    fn map_failed(&mut self, why: impl std::fmt::Display) {
        tracing::error!(
            "wavefront {}: cannot read map {}: {why}",
            self.addr,
            self.map
        );
        self.fetch = None;
    }

    /// Hands a fetched map to the worker once the robot's radius is known.
    fn send_map(&mut self) {
        let (Some(radius), Some(worker)) = (self.robot_radius, &self.worker) else {
            return;
        };
        if self.busy {
            return;
        }
        let Some(grid) = self.pending_map.take() else {
            return;
        };
        let min = radius + self.opts.safety_dist;
        let params = PlanParams {
            abs_min_radius: min,
            max_radius: self.opts.max_radius,
            dist_penalty: self.opts.dist_penalty,
        };
        tracing::debug!(
            "wavefront {}: building c-space of a {} x {} map, robot radius {radius:.3} m",
            self.addr,
            grid.width(),
            grid.height()
        );
        if worker.jobs.send(Job::Map(grid, params)).is_ok() {
            self.busy = true;
        }
    }

    /// Raises a panic of the planning thread here, in a driver callback, where the core
    /// reports it and takes the driver out of service.
    fn check_worker(&mut self) {
        if let Some(w) = &mut self.worker {
            w.thread.check();
        }
    }

    /// Takes what the worker finished (under velocity control, steering by it at once).
    fn collect(&mut self, ctx: &mut Context<'_>) {
        let Some(worker) = &self.worker else { return };
        let done: Vec<Done> = worker.done.try_iter().collect();
        for d in done {
            self.busy = false;
            match d {
                Done::Map(Ok(())) => {
                    self.have_map = true;
                    if let Some(goal) = self.deferred_goal.take() {
                        self.control.set_goal(goal);
                    }
                }
                Done::Map(Err(why)) => self.map_failed(why),
                Done::Plan {
                    start,
                    started,
                    seq,
                    waypoints,
                    global_ok,
                    has_path,
                    carrot,
                } => {
                    if self.opts.velocity_control.is_some() {
                        if !self.control.enabled {
                            continue;
                        }
                        if let Some(m) = self.control.steer(seq, global_ok, has_path, carrot) {
                            self.send_motion(ctx, m);
                        }
                    } else {
                        self.control.plan_ready(seq, started, start, waypoints);
                    }
                }
            }
        }
        // A map that came in while the worker was busy.
        self.send_map();
    }

    fn send_motion(&self, ctx: &mut Context<'_>, motion: Motion) {
        let cmd = match motion {
            Motion::Stop => Position2dCmd::Vel(Position2dCmdVel {
                vel: Pose2d::default(),
                state: 1,
            }),
            Motion::GoTo(pos) => Position2dCmd::Pos(Position2dCmdPos {
                pos,
                vel: Pose2d::default(),
                state: 1,
            }),
            Motion::Velocity { tv, av } => Position2dCmd::Vel(Position2dCmdVel {
                vel: Pose2d {
                    px: tv,
                    py: 0.0,
                    pa: av,
                },
                state: 1,
            }),
        };
        ctx.command(self.output, cmd);
    }

    /// A pose-stamped scan: kept, the oldest dropped beyond `laser_buffer_size`.
    fn take_scan(&mut self, scan: &LaserDataScanpose) {
        if self.scans.len() >= self.opts.laser_buffer_size {
            self.scans.pop_front();
        }
        self.scans.push_back(scan.clone());
        self.scans_changed = true;
    }

    /// The obstacles the kept scans show, when they changed since last asked (upstream's
    /// `ProcessLaserScan`): every hit nearer than `laser_maxrange` and the scan's own maximum,
    /// placed by the scan's pose. The bearing is accumulated in single precision, as upstream
    /// steps it.
    fn fresh_obstacles(&mut self) -> Option<Vec<(f64, f64)>> {
        if !std::mem::take(&mut self.scans_changed) {
            return None;
        }
        let mut points = Vec::new();
        for s in &self.scans {
            let mut bearing = s.scan.min_angle;
            for &r in &s.scan.ranges {
                if f64::from(r) < self.opts.laser_maxrange && r < s.scan.max_range {
                    let a = s.pose.pa + f64::from(bearing);
                    points.push((
                        s.pose.px + f64::from(r) * a.cos(),
                        s.pose.py + f64::from(r) * a.sin(),
                    ));
                }
                bearing += s.scan.resolution;
            }
        }
        Some(points)
    }

    fn publish_state(&mut self, ctx: &mut Context<'_>) {
        let now = ctx.now();
        if self
            .last_publish
            .is_some_and(|t| now - t <= PUBLISH_INTERVAL)
        {
            return;
        }
        self.last_publish = Some(now);
        ctx.publish(self.addr, PlannerDataMsg::State(self.control.data()));
    }
}

impl Driver for Wavefront {
    fn setup(&mut self, ctx: &mut Context<'_>) -> Result<(), DriverError> {
        self.control = Control::new(self.opts.control());
        self.worker = Some(Worker::spawn(ctx.waker())?);
        self.have_map = false;
        self.busy = false;
        self.pending_map = None;
        self.deferred_goal = None;
        self.last_publish = None;
        self.robot_radius = None;
        crate::position::subscribe_both(ctx, self.output, self.input);
        ctx.subscribe(self.map);
        self.scans.clear();
        self.scans_changed = false;
        if let Some(laser) = self.laser {
            ctx.subscribe(laser);
        }
        // Upstream turns the motors on (a failure is only a warning) and needs the geometry.
        ctx.request(
            self.output,
            Position2dReq::MotorPower(Some(Position2dPowerConfig { state: 1 })),
        );
        self.geom_ticket = Some(ctx.request(self.output, Position2dReq::GetGeom(None)));
        if self.opts.request_map {
            self.fetch_map(ctx);
        }
        // Upstream's first act is a stop.
        self.control.assume_moving();
        if let Some(m) = self.control.stop() {
            self.send_motion(ctx, m);
        }
        Ok(())
    }

    fn teardown(&mut self, _ctx: &mut Context<'_>) {
        // The thread ends when its channel closes.
        self.worker = None;
        self.fetch = None;
        self.geom_ticket = None;
    }

    fn handle_request(&mut self, _ctx: &mut Context<'_>, request: &Message) -> Reply {
        match &request.body {
            Body::Planner(PlannerMsg::Req(PlannerReq::GetWaypoints(_))) => {
                let waypoints = self
                    .control
                    .waypoints()
                    .iter()
                    .map(|&(px, py)| Pose2d { px, py, pa: 0.0 })
                    .collect();
                Reply::ack(PlannerReq::GetWaypoints(Some(PlannerWaypointsReq {
                    waypoints,
                })))
            }
            Body::Planner(PlannerMsg::Req(PlannerReq::Enable(Some(PlannerEnableReq {
                state,
            })))) => {
                self.control.enabled = *state != 0;
                tracing::debug!(
                    "wavefront {}: robot {}",
                    self.addr,
                    if *state != 0 { "enabled" } else { "disabled" }
                );
                Reply::empty_ack()
            }
            // Upstream refuses an ENABLE of the wrong size.
            Body::Planner(PlannerMsg::Req(PlannerReq::Enable(None))) => Reply::Nack,
            _ => Reply::NotHandled,
        }
    }

    fn handle_command(&mut self, ctx: &mut Context<'_>, command: &Message) {
        let Body::Planner(PlannerMsg::Cmd(PlannerCmdMsg::Goal(PlannerCmd { goal }))) =
            &command.body
        else {
            tracing::warn!(
                "wavefront {}: ignoring {}",
                self.addr,
                command.body.constant()
            );
            return;
        };
        tracing::info!(
            "wavefront {}: new goal ({:.3}, {:.3}, {:.1} deg)",
            self.addr,
            goal.px,
            goal.py,
            goal.pa.to_degrees()
        );
        if self.opts.force_map_refresh {
            // The goal is taken once the fresh map's c-space is built.
            self.have_map = false;
            self.deferred_goal = Some(*goal);
            self.fetch_map(ctx);
        } else {
            self.control.set_goal(*goal);
        }
    }

    fn handle_data(&mut self, ctx: &mut Context<'_>, data: &Message) {
        match &data.body {
            Body::Position2d(Position2dMsg::Data(Position2dData::State(state))) => {
                let from = data.header.addr;
                if from.same_device(&self.output) {
                    self.control.set_position(state.pos);
                }
                if from.same_device(&self.input) {
                    self.control.set_localize(state.pos);
                }
            }
            Body::Laser(LaserMsg::Data(LaserData::ScanPose(scan)))
                if self.laser.is_some_and(|l| data.header.addr.same_device(&l)) =>
            {
                self.take_scan(scan);
            }
            Body::Laser(LaserMsg::Data(LaserData::Scan(_)))
                if self.laser.is_some_and(|l| data.header.addr.same_device(&l))
                    && !std::mem::replace(&mut self.warned_plain_scan, true) =>
            {
                tracing::warn!(
                    "wavefront {}: {} sends scans without poses; wavefront takes pose-stamped \
                     scans (DATA SCANPOSE, e.g. from laserposeinterpolator) and ignores these",
                    self.addr,
                    data.header.addr
                );
            }
            // With request_map 0 the map is read when its device announces it.
            Body::Map(MapMsg::Data(MapData::Info(_)))
                if data.header.addr.same_device(&self.map)
                    && !self.opts.request_map
                    && self.fetch.is_none() =>
            {
                self.fetch_map(ctx);
            }
            _ => {}
        }
    }

    fn handle_reply(
        &mut self,
        ctx: &mut Context<'_>,
        ticket: RequestTicket,
        reply: Result<Message, RequestError>,
    ) {
        if self.geom_ticket == Some(ticket) {
            self.geom_ticket = None;
            let answer = reply.as_ref().ok().map(|m| &m.body);
            match answer.and_then(Position2dReq::in_reply) {
                Some(Position2dReq::GetGeom(Some(g))) => {
                    self.robot_radius = Some(g.size.sw / 2.0);
                    tracing::debug!(
                        "wavefront {}: robot radius {:.3} m",
                        self.addr,
                        g.size.sw / 2.0
                    );
                    self.send_map();
                }
                _ => tracing::error!(
                    "wavefront {}: failed to get the geometry of {}: {:?}; cannot plan",
                    self.addr,
                    self.output,
                    reply.as_ref().map(|m| m.body.constant())
                ),
            }
            return;
        }
        let reply = match self.fetch.as_mut() {
            Some(fetch) => match fetch.on_reply(ctx, ticket, reply) {
                Fetched::NotMine(reply) => reply,
                Fetched::Pending => return,
                Fetched::Done(grid) => {
                    self.fetch = None;
                    self.pending_map = Some(grid);
                    return self.send_map();
                }
                Fetched::Failed(why) => return self.map_failed(why),
            },
            None => reply,
        };
        // MOTOR_POWER's answer (upstream only warns on failure), or a stale one.
        if let Err(e) = reply {
            tracing::warn!("wavefront {}: request failed: {e}", self.addr);
        }
    }

    fn wake(&mut self, ctx: &mut Context<'_>) {
        self.check_worker();
        self.collect(ctx);
    }

    fn update(&mut self, ctx: &mut Context<'_>) {
        self.check_worker();
        self.collect(ctx);
        if !self.have_map {
            return;
        }
        self.publish_state(ctx);
        if !self.control.enabled {
            if let Some(m) = self.control.stop() {
                self.send_motion(ctx, m);
            }
            return;
        }
        if self.busy {
            // Upstream plans within its cycle: drive on once the plan is in.
            return;
        }
        let now = ctx.now();
        if self.control.wants_plan(now) && self.worker.is_some() {
            let l = self.control.localize();
            let g = self.control.target();
            let local = (self.laser.is_some() && !self.control.new_goal())
                .then_some(self.opts.laser_maxrange);
            let job = Job::Plan {
                start: (l.px, l.py),
                goal: (g.px, g.py),
                started: now,
                seq: self.control.goal_seq(),
                local,
                obstacles: self.fresh_obstacles(),
                carrot: self.opts.velocity_control.is_some(),
            };
            if let Some(worker) = &self.worker {
                if worker.jobs.send(job).is_ok() {
                    self.busy = true;
                    return;
                }
            }
        }
        if self.opts.velocity_control.is_some() {
            // Steering happens as each plan comes in; between goals the robot is held.
            if let Some(m) = self.control.steer_idle() {
                self.send_motion(ctx, m);
            }
        } else if let Some(m) = self.control.drive() {
            self.send_motion(ctx, m);
        }
    }

    fn step(&self) -> Option<Duration> {
        Some(Duration::from_secs_f64(1.0 / self.opts.update_rate))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{Harness, addr, block};
    use player_proto::{Bbox3d, MapInfo, MapReq, MapTile, Position2dDataState, Position2dGeom};
    use player_server::{Action, RequiredDevice};

    fn keyed(b: &mut DriverBlock, key: &str, index: usize) {
        b.requires[index].key = Some(key.into());
    }

    fn wavefront_block(options: &[(&str, &str)]) -> DriverBlock {
        let mut b = block(
            NAME,
            &[addr(InterfaceCode::PLANNER, 0)],
            &[
                addr(InterfaceCode::POSITION2D, 1),
                addr(InterfaceCode::POSITION2D, 2),
                addr(InterfaceCode::MAP, 0),
            ],
            options,
        );
        keyed(&mut b, "output", 0);
        keyed(&mut b, "input", 1);
        b
    }

    #[test]
    fn options_have_upstream_defaults_and_are_checked() {
        let o = WavefrontOptions::from_block(&wavefront_block(&[])).unwrap();
        assert_eq!(o, WavefrontOptions::default());
        assert_eq!(
            (o.safety_dist, o.max_radius, o.distance_epsilon),
            (0.25, 1.0, 0.5)
        );
        let o = WavefrontOptions::from_block(&wavefront_block(&[
            ("angle_epsilon", "20"),
            ("add_rotational_waypoints", "0"),
            ("replan_dist_thresh", "-1"),
        ]))
        .unwrap();
        assert!((o.angle_epsilon - 20f64.to_radians()).abs() < 1e-12);
        assert!(!o.add_rotational_waypoints);
        assert_eq!(o.replan_dist_thresh, -1.0);
        assert_eq!(o.velocity_control, None);
        assert_eq!((o.laser_buffer_size, o.laser_maxrange), (10, 6.0));
        let o = WavefrontOptions::from_block(&wavefront_block(&[
            ("velocity_control", "1"),
            ("control_tv", "0.2 0.6"),
            ("control_a", "3"),
            ("laser_buffer_size", "0"),
            ("laser_maxrange", "4"),
        ]))
        .unwrap();
        let g = o.velocity_control.unwrap();
        assert_eq!(g.tv, (0.2, 0.6));
        assert_eq!(g.av, VelocityGains::default().av);
        assert!(
            (g.a.0 - 3f64.to_radians()).abs() < 1e-12 && (g.a.1 - 20f64.to_radians()).abs() < 1e-12
        );
        // Upstream keeps at least one scan.
        assert_eq!((o.laser_buffer_size, o.laser_maxrange), (1, 4.0));
        for bad in [
            ("laser_buffer_size", "many"),
            ("update_rate", "0"),
            ("safety_dist", "x"),
        ] {
            assert!(
                WavefrontOptions::from_block(&wavefront_block(&[bad])).is_err(),
                "{bad:?}"
            );
        }
    }

    #[test]
    fn requires_output_input_and_map() {
        let mut b = wavefront_block(&[]);
        assert!(Wavefront::from_block(&b).is_ok());
        b.requires
            .retain(|r: &RequiredDevice| r.key.as_deref() != Some("input"));
        assert!(Wavefront::from_block(&b).unwrap_err().0.contains("input"));
        let mut b = wavefront_block(&[]);
        b.provides.clear();
        assert!(Wavefront::from_block(&b).is_err());
    }

    /// Runs update cycles (advancing time) until one sends a command to `to`.
    fn cycle_until_command(h: &mut Harness<Wavefront>, to: DeviceAddr) -> Body {
        for _ in 0..500 {
            h.now += 0.1;
            let out = h.update();
            for a in out.actions {
                if let Action::Command(dest, body) = a {
                    if dest == to {
                        return body;
                    }
                }
            }
            std::thread::sleep(Duration::from_millis(2));
        }
        panic!("no command to {to}");
    }

    #[test]
    fn fetches_the_map_plans_on_a_worker_and_sends_waypoints() {
        let (out_dev, in_dev, map_dev, me) = (
            addr(InterfaceCode::POSITION2D, 1),
            addr(InterfaceCode::POSITION2D, 2),
            addr(InterfaceCode::MAP, 0),
            addr(InterfaceCode::PLANNER, 0),
        );
        let mut h = Harness::new(Wavefront::from_block(&wavefront_block(&[])).unwrap());
        let out = h.setup();
        assert_eq!(out.subscriptions(), vec![out_dev, in_dev, map_dev]);
        let reqs = out.requests();
        assert_eq!(reqs.len(), 3);
        // Motor power, geometry, map info.
        let geom = Position2dGeom {
            size: Bbox3d {
                sw: 0.4,
                sl: 0.4,
                sh: 0.3,
            },
            ..Default::default()
        };
        h.ack(reqs[1].0, out_dev, Position2dReq::GetGeom(Some(geom)));
        // A 6 m x 4 m room at 0.2 m, walls round the edge.
        let (w, ht) = (30u32, 20u32);
        let info = MapInfo {
            scale: 0.2,
            width: w,
            height: ht,
            origin: Pose2d {
                px: -3.0,
                py: -2.0,
                pa: 0.0,
            },
        };
        let tiles = h
            .ack(reqs[2].0, map_dev, MapReq::GetInfo(Some(info)))
            .requests();
        assert_eq!(tiles.len(), 1);
        let data: Vec<i8> = (0..w * ht)
            .map(|k| {
                let (i, j) = (k % w, k / w);
                if i == 0 || j == 0 || i == w - 1 || j == ht - 1 {
                    1
                } else {
                    -1
                }
            })
            .collect();
        h.ack(
            tiles[0].0,
            map_dev,
            MapReq::GetData(Some(MapTile {
                col: 0,
                row: 0,
                width: w,
                height: ht,
                data,
            })),
        );
        let at = |x: f64, y: f64| {
            Position2dData::State(Position2dDataState {
                pos: Pose2d {
                    px: x,
                    py: y,
                    pa: 0.0,
                },
                ..Default::default()
            })
        };
        h.data(out_dev, at(-1.0, 0.0), h.now);
        h.data(in_dev, at(-1.0, 0.0), h.now);
        h.command(
            me,
            PlannerCmdMsg::Goal(PlannerCmd {
                goal: Pose2d {
                    px: 1.0,
                    py: 0.0,
                    pa: 0.0,
                },
            }),
        );
        // The first command is the robot's own cell, then the goal.
        let first = cycle_until_command(&mut h, out_dev);
        assert!(
            matches!(
                &first,
                Body::Position2d(Position2dMsg::Cmd(Position2dCmd::Pos(p))) if (p.pos.px + 1.0).abs() < 0.11
            ),
            "{first:?}"
        );
        let (reply, _, _) = h.request(me, PlannerReq::GetWaypoints(None));
        let Reply::Ack(Some(answer)) = &reply else {
            panic!("{reply:?}")
        };
        let Some(PlannerReq::GetWaypoints(Some(w))) = PlannerReq::in_reply(answer) else {
            panic!("{reply:?}")
        };
        assert_eq!(w.waypoints.len(), 2);
        let second = cycle_until_command(&mut h, out_dev);
        assert!(
            matches!(
                &second,
                Body::Position2d(Position2dMsg::Cmd(Position2dCmd::Pos(p))) if (p.pos.px - 1.0).abs() < 0.11
            ),
            "{second:?}"
        );
        // Disabling stops the robot.
        let (reply, _, _) = h.request(me, PlannerReq::Enable(Some(PlannerEnableReq { state: 0 })));
        assert!(matches!(reply, Reply::Ack(None)));
        let stop = cycle_until_command(&mut h, out_dev);
        assert!(matches!(
            stop,
            Body::Position2d(Position2dMsg::Cmd(Position2dCmd::Vel(v))) if v.vel == Pose2d::default()
        ));
    }

    /// A panic in the planning thread is raised in the driver's next `update` (where the core
    /// catches it and takes the driver out of service), naming the thread and its message.
    #[test]
    fn a_panic_in_the_planning_thread_is_raised_in_update() {
        let mut h = Harness::new(Wavefront::from_block(&wavefront_block(&[])).unwrap());
        h.setup();
        let worker = h.driver.worker.as_ref().expect("the planning thread");
        worker.jobs.send(Job::Fault).unwrap();
        let start = std::time::Instant::now();
        while !worker.thread.is_finished() {
            assert!(start.elapsed() < std::time::Duration::from_secs(5));
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
        let caught = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| h.update()))
            .expect_err("update raises the thread's panic");
        assert_eq!(
            caught.downcast_ref::<String>().map(String::as_str),
            Some("its worker thread \"wavefront\" panicked: injected fault in the planning thread")
        );
    }
}
