//! `amcl`: adaptive Monte-Carlo localisation, as Player 3.0.2's driver.
//!
//! The robot's pose is tracked by a particle filter ([`pf`]) whose particle count adapts by
//! KLD-sampling: many particles while the pose is uncertain, few once it is known. Odometry
//! moves the particles ([`models::OdometryModel`]); laser scans and sonar ranges, compared
//! with a map by ray casting, weigh them ([`models::LaserModel`], [`models::SonarModel`]).
//! Clusters of particles are published as hypotheses on `localize`, and the heaviest one, kept
//! up to date with odometry between filter updates, as `position2d` data.
//!
//! Requires `odometry:::position2d:N` (the action sensor), and optionally a `laser` with its
//! map (`laser:::map:N`) and/or a `sonar` with its map (`sonar:::map:N`), as Player names
//! them. Provides `localize` (DATA HYPOTHS; SET_POSE, GET_PARTICLES) and/or `position2d`
//! (DATA STATE; GET_GEOM answers a 1 cm point, as upstream, so viewers draw something).
//!
//! Maps are fetched when the driver starts (GET_INFO, then GET_DATA in tiles of at most
//! 640 x 640) along with the laser's or the sonar's geometry; data arriving meanwhile is
//! kept and fed to the filter once everything is there. Filter updates can take tens of
//! milliseconds with thousands of particles, so the filter runs on a thread of its own and
//! hands its results back through the driver's waker; the server never waits for it.
//! The filter's inputs are handled strictly in arrival order with a seeded generator
//! ([`engine`]), so a simulation run repeats exactly. Hypotheses are stamped with the time of
//! the odometry reading that triggered the update (upstream stamps them with the time they
//! are sent, which differs from run to run); `position2d` data with the odometry's time, as
//! upstream.
//!
//! Options: see [`settings::Settings`]. `odom_init` and `enable_gui` are accepted and
//! ignored (3.0.2 never uses the first; there is no GUI). The sonar options (`scount`,
//! `spose[i]`, `sonar_range_*`) are Player 2.0's: 3.0.2 had dropped its sonar sensor.

pub mod engine;
pub mod histogram;
pub mod map;
pub mod models;
pub mod pdf;
pub mod pf;
pub mod pose;
pub mod settings;

use std::collections::HashMap;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc::{self, Receiver, Sender, TryRecvError};
use std::sync::{Arc, Mutex};

use player_proto::{
    Bbox3d, Body, DeviceAddr, InterfaceCode, LaserMsg, LaserReq, LocalizeData, LocalizeMsg,
    LocalizeReq, MapMsg, MapReq, MapTile, Message, Pose2d, Position2dData, Position2dDataState,
    Position2dGeom, Position2dMsg, Position2dReq, SonarData, SonarMsg, SonarReq,
};
use player_server::map::OccupancyGrid;
use player_server::{
    Context, Driver, DriverBlock, DriverError, DriverWaker, Reply, RequestError, RequestTicket,
    WorkerThread,
};

use crate::forward::refuse_own_device;
use engine::{Engine, EngineConfig, Input, Output};
use map::OccupancyMap;
use models::{LaserModel, LaserScan, OdometryModel, SonarModel};
use pf::Population;
use pose::Pose;
use settings::Settings;

/// The Player name of this driver.
pub const NAME: &str = "amcl";

/// Inputs allowed to wait for the filter before new data is dropped (upstream's queue size).
pub const QUEUE_LIMIT: usize = 20_000;

/// A range sensor the filter uses, and the map it is compared with.
#[derive(Clone, Copy, Debug, PartialEq)]
struct SensorDevices {
    device: DeviceAddr,
    map: DeviceAddr,
}

/// Which range sensor something belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Which {
    Laser,
    Sonar,
}

/// What a request the driver sent was for.
#[derive(Clone, Debug, PartialEq)]
enum Asked {
    MapInfo(Which),
    /// A tile (as asked: its place and size, no cells).
    MapTile(Which, MapTile),
    Geometry(Which),
}

/// A map being fetched: the grid filled tile by tile, then amcl's map of it.
#[derive(Debug, Default)]
struct MapLoad {
    grid: Option<OccupancyGrid>,
    tiles_left: usize,
    map: Option<OccupancyMap>,
}

/// The filter thread's side of the driver.
#[derive(Debug)]
struct Worker {
    tx: Sender<Input>,
    shared: Arc<Shared>,
    /// The filter thread: its panic is raised in `wake`/`update` (the core reports it).
    thread: WorkerThread,
}

/// What the driver and its filter thread share.
#[derive(Debug, Default)]
struct Shared {
    outputs: Mutex<Vec<Output>>,
    /// Inputs sent and not yet handled.
    queued: AtomicUsize,
}

/// One run of the driver, from setup to teardown.
#[derive(Debug, Default)]
struct Run {
    asked: HashMap<RequestTicket, Asked>,
    laser_map: MapLoad,
    sonar_map: MapLoad,
    laser_pose: Option<Pose>,
    sonar_poses: Option<Vec<Pose>>,
    /// Inputs that arrived before the filter could start.
    backlog: Vec<Input>,
    worker: Option<Worker>,
    failed: bool,
    overflow_reported: bool,
}

/// The driver.
#[derive(Debug)]
pub struct Amcl {
    settings: Settings,
    localize: Option<DeviceAddr>,
    position: Option<DeviceAddr>,
    odometry: DeviceAddr,
    laser: Option<SensorDevices>,
    sonar: Option<SensorDevices>,
    /// The last SET_POSE, which a restarted filter starts from (as upstream's does).
    set_pose: Option<(Pose, nalgebra::Matrix3<f64>)>,
    run: Option<Run>,
}

impl Amcl {
    /// Builds the driver from its cfg block: what it provides and requires, and its options.
    pub fn from_block(block: &DriverBlock) -> Result<Amcl, DriverError> {
        let provided = |code| {
            block
                .provides
                .iter()
                .find(|p| p.addr.interf == code)
                .map(|p| p.addr)
        };
        let localize = provided(InterfaceCode::LOCALIZE);
        let position = provided(InterfaceCode::POSITION2D);
        if localize.is_none() && position.is_none() {
            return Err(DriverError::new(
                "must provide a localize and/or a position2d device",
            ));
        }
        // The action sensor (upstream: "No action sensor" otherwise).
        let odometry = block
            .required(InterfaceCode::POSITION2D, Some("odometry"))?
            .addr;
        // Upstream looks the range sensors up by interface, whatever their key; their maps by
        // the key naming the sensor.
        let sensor = |code: InterfaceCode, key: &str| -> Result<_, DriverError> {
            let Some(device) = block.requires.iter().find(|r| r.addr.interf == code) else {
                return Ok(None);
            };
            let map = block
                .optional_required(InterfaceCode::MAP, Some(key))?
                .ok_or_else(|| {
                    DriverError::new(format!(
                        "the {code} needs a map to compare its ranges with: add \"{key}:::map:0\" \
                         to requires"
                    ))
                })?;
            Ok(Some(SensorDevices {
                device: device.addr,
                map: map.addr,
            }))
        };
        let laser = sensor(InterfaceCode::LASER, "laser")?;
        let sonar = sensor(InterfaceCode::SONAR, "sonar")?;
        let inputs: Vec<DeviceAddr> = std::iter::once(odometry)
            .chain(laser.map(|l| l.device))
            .collect();
        for p in &block.provides {
            refuse_own_device(p.addr, &inputs)?;
        }
        Ok(Amcl {
            settings: Settings::from_block(block)?,
            localize,
            position,
            odometry,
            laser,
            sonar,
            set_pose: None,
            run: None,
        })
    }

    fn engine_config(&self) -> EngineConfig {
        let s = &self.settings;
        EngineConfig {
            population: Population {
                min_samples: s.pf_min_samples,
                max_samples: s.pf_max_samples,
                err: s.pf_err,
                z: s.pf_z,
            },
            seed: s.seed,
            init_mean: self.set_pose.map_or(s.init_pose, |(mean, _)| mean),
            init_cov: self.set_pose.map_or_else(|| s.init_cov(), |(_, cov)| cov),
            update_dist: s.update_dist,
            update_angle: s.update_angle,
            odometry: OdometryModel {
                drift: s.odom_drift,
            },
        }
    }

    /// Hands an input to the filter (or keeps it until the filter starts). Data beyond the
    /// queue limit is dropped with an error, as upstream does; requests never are.
    fn feed(&mut self, input: Input) {
        let Some(run) = self.run.as_mut() else {
            return;
        };
        let is_data = matches!(
            input,
            Input::Odometry { .. } | Input::Laser(_) | Input::Sonar(_)
        );
        if run.failed {
            return;
        }
        let queued = match &run.worker {
            Some(w) => w.shared.queued.load(Ordering::Acquire),
            None => run.backlog.len(),
        };
        if is_data && queued >= QUEUE_LIMIT {
            if !run.overflow_reported {
                tracing::error!("amcl: queue overflow: the filter is {queued} inputs behind");
                run.overflow_reported = true;
            }
            return;
        }
        run.overflow_reported = false;
        match &run.worker {
            Some(w) => {
                w.shared.queued.fetch_add(1, Ordering::AcqRel);
                if w.tx.send(input).is_err() {
                    tracing::error!("amcl: the filter thread stopped");
                }
            }
            None => run.backlog.push(input),
        }
    }

    /// Starts the filter once every map and geometry has arrived.
    fn start_if_ready(&mut self, ctx: &mut Context<'_>) {
        let config = self.engine_config();
        let Some(run) = self.run.as_mut() else {
            return;
        };
        if run.worker.is_some() || run.failed {
            return;
        }
        let laser_ready =
            self.laser.is_none() || (run.laser_map.map.is_some() && run.laser_pose.is_some());
        let sonar_ready =
            self.sonar.is_none() || (run.sonar_map.map.is_some() && run.sonar_poses.is_some());
        if !(laser_ready && sonar_ready) {
            return;
        }
        let s = &self.settings;
        let laser = match (&self.laser, run.laser_map.map.take(), run.laser_pose) {
            (Some(_), Some(map), Some(laser_pose)) => Some(LaserModel {
                map: Arc::new(map),
                laser_pose,
                max_beams: s.laser_max_beams,
                range_sigma: s.laser_range_var,
                range_bad: s.laser_range_bad,
            }),
            _ => None,
        };
        let sonar = match (
            &self.sonar,
            run.sonar_map.map.take(),
            run.sonar_poses.take(),
        ) {
            (Some(_), Some(map), Some(poses)) if !poses.is_empty() => Some(SonarModel {
                map: Arc::new(map),
                poses,
                range_max: s.sonar_range_max,
                range_sigma: s.sonar_range_var,
                range_bad: s.sonar_range_bad,
            }),
            _ => None,
        };
        // Unsubscribe from the maps: they are copied (upstream does the same).
        for d in self.laser.iter().chain(self.sonar.iter()) {
            ctx.unsubscribe(d.map);
        }
        let engine = Engine::new(config, laser, sonar);
        let (tx, rx) = mpsc::channel();
        let shared = Arc::new(Shared::default());
        let backlog = std::mem::take(&mut run.backlog);
        shared.queued.store(backlog.len(), Ordering::Release);
        for input in backlog {
            // The receiver is alive: it is moved into the thread below.
            let _ = tx.send(input);
        }
        let thread_shared = shared.clone();
        let waker = ctx.waker();
        let thread = match WorkerThread::spawn("amcl", waker.clone(), move || {
            filter_thread(engine, rx, thread_shared, waker)
        }) {
            Ok(t) => t,
            Err(e) => {
                tracing::error!("amcl: cannot start the filter thread: {e}");
                run.failed = true;
                return;
            }
        };
        tracing::debug!("amcl: map and geometry loaded, filter running");
        run.worker = Some(Worker { tx, shared, thread });
    }

    /// Gives up on this run: logs why, and refuses the requests that were waiting.
    fn fail(&mut self, ctx: &mut Context<'_>, error: impl std::fmt::Display) {
        tracing::error!("amcl: {error}; the driver publishes nothing until restarted");
        let Some(run) = self.run.as_mut() else {
            return;
        };
        run.failed = true;
        for input in run.backlog.drain(..) {
            if let Input::GetParticles(pending) = input {
                ctx.answer(pending, Reply::Nack);
            }
        }
    }

    fn sensor(&self, which: Which) -> Option<SensorDevices> {
        match which {
            Which::Laser => self.laser,
            Which::Sonar => self.sonar,
        }
    }

    fn map_load(&mut self, which: Which) -> Option<&mut MapLoad> {
        let run = self.run.as_mut()?;
        Some(match which {
            Which::Laser => &mut run.laser_map,
            Which::Sonar => &mut run.sonar_map,
        })
    }

    /// A map's GET_INFO answer: an unknown grid of that shape, and a GET_DATA per tile.
    fn map_info(
        &mut self,
        ctx: &mut Context<'_>,
        which: Which,
        device: DeviceAddr,
        reply: Message,
    ) -> Result<(), String> {
        let info = match reply.body {
            Body::Map(MapMsg::Ack(MapReq::GetInfo(Some(info)))) => info,
            other => {
                return Err(format!(
                    "{device} answered GET_INFO with {}",
                    other.constant()
                ));
            }
        };
        let grid = OccupancyGrid::new(
            info.width,
            info.height,
            info.scale,
            info.origin,
            OccupancyGrid::UNKNOWN,
        )
        .ok_or_else(|| {
            format!(
                "the map of {device} is {} x {} cells, more than can be held",
                info.width, info.height
            )
        })?;
        tracing::debug!(
            "amcl: loading a {} x {} map of {} m cells from {device}",
            info.width,
            info.height,
            info.scale
        );
        let mut tiles = 0;
        for tile in info.tile_requests() {
            let ticket = ctx.request(device, MapReq::GetData(Some(tile.clone())));
            if let Some(run) = self.run.as_mut() {
                run.asked.insert(ticket, Asked::MapTile(which, tile));
            }
            tiles += 1;
        }
        if let Some(load) = self.map_load(which) {
            load.tiles_left = tiles;
            load.grid = Some(grid);
            if tiles == 0 {
                Self::finish_map(load)?;
            }
        }
        Ok(())
    }

    /// A GET_DATA answer for the tile `asked`: its cells into the grid (exactly the cells of
    /// the tile asked for: raw, as drivers in one server exchange them).
    fn map_tile(
        &mut self,
        which: Which,
        device: DeviceAddr,
        asked: &MapTile,
        reply: Message,
    ) -> Result<(), String> {
        let tile = match reply.body {
            Body::Map(MapMsg::Ack(MapReq::GetData(Some(tile)))) => tile,
            other => {
                return Err(format!(
                    "{device} answered GET_DATA with {}",
                    other.constant()
                ));
            }
        };
        let Some(load) = self.map_load(which) else {
            return Ok(());
        };
        let Some(grid) = load.grid.as_mut() else {
            return Ok(());
        };
        let expected = asked.width as usize * asked.height as usize;
        if tile.data.len() != expected
            || !grid.put_tile(asked.col, asked.row, asked.width, asked.height, &tile.data)
        {
            return Err(format!(
                "{device} sent {} cells for the {} x {} tile at column {}, row {}",
                tile.data.len(),
                asked.width,
                asked.height,
                asked.col,
                asked.row
            ));
        }
        load.tiles_left = load.tiles_left.saturating_sub(1);
        if load.tiles_left == 0 {
            Self::finish_map(load)?;
        }
        Ok(())
    }

    /// Every tile is in: amcl's map of the grid.
    fn finish_map(load: &mut MapLoad) -> Result<(), String> {
        if let Some(grid) = load.grid.take() {
            load.map = Some(OccupancyMap::new(grid).map_err(|e| e.to_string())?);
        }
        Ok(())
    }

    fn geometry(&mut self, which: Which, device: DeviceAddr, reply: Result<Message, RequestError>) {
        let Some(run) = self.run.as_mut() else {
            return;
        };
        let body = reply.as_ref().map(|msg| &msg.body);
        match which {
            Which::Laser => match body {
                Ok(Body::Laser(LaserMsg::Ack(LaserReq::GetGeom(Some(g))))) => {
                    tracing::debug!(
                        "amcl: laser geometry {:.3} {:.3} {:.1} deg",
                        g.pose.px,
                        g.pose.py,
                        g.pose.pyaw.to_degrees()
                    );
                    run.laser_pose = Some(Pose::new(g.pose.px, g.pose.py, g.pose.pyaw));
                }
                answer => {
                    let why = match answer {
                        Ok(other) => format!("({})", other.constant()),
                        Err(e) => format!("from {device} ({e})"),
                    };
                    tracing::warn!(
                        "amcl: failed to get laser geometry {why}; assuming the laser sits at the robot's origin"
                    );
                    run.laser_pose = Some(Pose::zeros());
                }
            },
            Which::Sonar => match body {
                Ok(Body::Sonar(SonarMsg::Ack(SonarReq::GetGeom(Some(g))))) => {
                    run.sonar_poses = Some(
                        g.poses
                            .iter()
                            .map(|p| Pose::new(p.px, p.py, p.pyaw))
                            .collect(),
                    );
                }
                answer => {
                    let why = match answer {
                        Ok(other) => format!(
                            "unexpected sonar geometry answer {} from {device}",
                            other.constant()
                        ),
                        Err(e) => format!("failed to get sonar geometry from {device} ({e})"),
                    };
                    tracing::error!(
                        "amcl: {why}: the sonar is not used (give `scount` and `spose[i]`)"
                    );
                    run.sonar_poses = Some(Vec::new());
                }
            },
        }
    }

    /// Raises a panic of the filter thread here, in a driver callback, where the core
    /// reports it and takes the driver out of service.
    fn check_worker(&mut self) {
        if let Some(w) = self.run.as_mut().and_then(|r| r.worker.as_mut()) {
            w.thread.check();
        }
    }

    /// Publishes what the filter thread produced and answers the requests it served.
    fn collect(&mut self, ctx: &mut Context<'_>) {
        let Some(worker) = self.run.as_ref().and_then(|r| r.worker.as_ref()) else {
            return;
        };
        let outputs = std::mem::take(
            &mut *worker
                .shared
                .outputs
                .lock()
                .unwrap_or_else(|e| e.into_inner()),
        );
        for output in outputs {
            match output {
                Output::Hypotheses { data, time } => {
                    if let Some(addr) = self.localize {
                        ctx.publish_at(addr, LocalizeData::Hypoths(data), time);
                    }
                }
                Output::Position { pose, time } => {
                    if let Some(addr) = self.position {
                        let state = Position2dDataState {
                            pos: Pose2d {
                                px: pose.x,
                                py: pose.y,
                                pa: pose.z,
                            },
                            vel: Pose2d::default(),
                            stall: 0,
                        };
                        ctx.publish_at(addr, Position2dData::State(state), time);
                    }
                }
                Output::Particles { reply, data } => {
                    ctx.answer(reply, Reply::ack(LocalizeReq::GetParticles(Some(data))));
                }
            }
        }
    }
}

/// The filter thread: takes inputs in order, runs them through the engine, and hands the
/// results to the driver (waking it) after every input that produced some. It ends when the
/// driver drops its sender (teardown), without finishing the queue.
fn filter_thread(
    mut engine: Engine,
    rx: Receiver<Input>,
    shared: Arc<Shared>,
    waker: Option<DriverWaker>,
) {
    let mut out = Vec::new();
    loop {
        loop {
            match rx.try_recv() {
                Ok(input) => engine.push(input),
                Err(TryRecvError::Empty) => break,
                Err(TryRecvError::Disconnected) => return,
            }
        }
        if !engine.step(&mut out) {
            match rx.recv() {
                Ok(input) => engine.push(input),
                Err(_) => return,
            }
            continue;
        }
        shared.queued.fetch_sub(1, Ordering::AcqRel);
        if !out.is_empty() {
            shared
                .outputs
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .append(&mut out);
            if let Some(w) = &waker {
                w.wake();
            }
        }
    }
}

impl Driver for Amcl {
    fn setup(&mut self, ctx: &mut Context<'_>) -> Result<(), DriverError> {
        let mut run = Run::default();
        ctx.subscribe(self.odometry);
        for (which, sensor) in [(Which::Laser, self.laser), (Which::Sonar, self.sonar)] {
            let Some(s) = sensor else { continue };
            ctx.subscribe(s.device);
            ctx.subscribe(s.map);
            let t = ctx.request(s.map, MapReq::GetInfo(None));
            run.asked.insert(t, Asked::MapInfo(which));
            match which {
                Which::Laser => {
                    let t = ctx.request(s.device, LaserReq::GetGeom(None));
                    run.asked.insert(t, Asked::Geometry(which));
                }
                Which::Sonar => match &self.settings.sonar_poses {
                    Some(poses) => run.sonar_poses = Some(poses.clone()),
                    None => {
                        let t = ctx.request(s.device, SonarReq::GetGeom(None));
                        run.asked.insert(t, Asked::Geometry(which));
                    }
                },
            }
        }
        self.run = Some(run);
        self.start_if_ready(ctx);
        Ok(())
    }

    fn teardown(&mut self, _ctx: &mut Context<'_>) {
        // Dropping the sender ends the filter thread after its current input.
        self.run = None;
    }

    fn shutdown(&mut self) {
        self.run = None;
    }

    fn handle_data(&mut self, ctx: &mut Context<'_>, data: &Message) {
        let from = data.header.addr;
        let input = match &data.body {
            Body::Position2d(Position2dMsg::Data(Position2dData::State(s)))
                if from.same_device(&self.odometry) =>
            {
                Input::Odometry {
                    pose: Pose::new(s.pos.px, s.pos.py, s.pos.pa),
                    time: data.header.timestamp,
                }
            }
            Body::Laser(LaserMsg::Data(player_proto::LaserData::Scan(scan)))
                if self.laser.is_some_and(|l| from.same_device(&l.device)) =>
            {
                Input::Laser(LaserScan::from_data(scan))
            }
            Body::Sonar(SonarMsg::Data(SonarData::Ranges(r)))
                if self.sonar.is_some_and(|s| from.same_device(&s.device)) =>
            {
                Input::Sonar(r.ranges.iter().map(|&v| f64::from(v)).collect())
            }
            _ => return,
        };
        self.feed(input);
        self.collect(ctx);
    }

    fn handle_request(&mut self, ctx: &mut Context<'_>, request: &Message) -> Reply {
        let to = request.header.addr;
        match &request.body {
            Body::Localize(LocalizeMsg::Req(LocalizeReq::SetPose(Some(p))))
                if self.localize.is_some_and(|a| a.same_device(&to)) =>
            {
                let mean = Pose::new(p.mean.px, p.mean.py, p.mean.pa);
                // The covariance's diagonal, as given (variances, not standard deviations).
                let cov =
                    nalgebra::Matrix3::from_diagonal(&Pose::new(p.cov[0], p.cov[1], p.cov[2]));
                self.set_pose = Some((mean, cov));
                self.feed(Input::SetPose { mean, cov });
                Reply::empty_ack()
            }
            Body::Localize(LocalizeMsg::Req(LocalizeReq::GetParticles(_)))
                if self.localize.is_some_and(|a| a.same_device(&to)) =>
            {
                if self.run.as_ref().is_none_or(|r| r.failed) {
                    return Reply::Nack;
                }
                let Some(pending) = ctx.defer() else {
                    return Reply::NotHandled;
                };
                self.feed(Input::GetParticles(pending));
                Reply::Deferred
            }
            Body::Position2d(Position2dMsg::Req(Position2dReq::GetGeom(None)))
                if self.position.is_some_and(|a| a.same_device(&to)) =>
            {
                Reply::ack(Position2dReq::GetGeom(Some(Position2dGeom {
                    size: Bbox3d {
                        sw: 0.01,
                        sl: 0.01,
                        sh: 0.0,
                    },
                    ..Position2dGeom::default()
                })))
            }
            _ => Reply::NotHandled,
        }
    }

    fn handle_reply(
        &mut self,
        ctx: &mut Context<'_>,
        ticket: RequestTicket,
        reply: Result<Message, RequestError>,
    ) {
        let Some(asked) = self.run.as_mut().and_then(|r| r.asked.remove(&ticket)) else {
            return;
        };
        let which = match asked {
            Asked::MapInfo(w) | Asked::MapTile(w, _) | Asked::Geometry(w) => w,
        };
        let Some(devices) = self.sensor(which) else {
            return;
        };
        let result = match (asked, reply) {
            (Asked::Geometry(_), reply) => {
                self.geometry(which, devices.device, reply);
                Ok(())
            }
            (Asked::MapInfo(_), Ok(msg)) => self.map_info(ctx, which, devices.map, msg),
            (Asked::MapInfo(_), Err(e)) => {
                Err(format!("GET_INFO from {} failed: {e}", devices.map))
            }
            (Asked::MapTile(_, tile), Ok(msg)) => self.map_tile(which, devices.map, &tile, msg),
            (Asked::MapTile(..), Err(e)) => {
                Err(format!("GET_DATA from {} failed: {e}", devices.map))
            }
        };
        match result {
            Ok(()) => self.start_if_ready(ctx),
            Err(e) => {
                if !self.run.as_ref().is_some_and(|r| r.failed) {
                    self.fail(ctx, e);
                }
            }
        }
    }

    fn wake(&mut self, ctx: &mut Context<'_>) {
        self.check_worker();
        self.collect(ctx);
    }

    fn update(&mut self, ctx: &mut Context<'_>) {
        self.check_worker();
        self.collect(ctx);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn addr(interf: InterfaceCode, index: u16) -> DeviceAddr {
        DeviceAddr::new(0, 6665, interf, index)
    }

    fn block(provides: &[DeviceAddr], requires: &[(Option<&str>, DeviceAddr)]) -> DriverBlock {
        DriverBlock::new(NAME, "")
            .providing(provides.iter().copied(), "t.cfg:1")
            .requiring(requires.iter().copied(), "t.cfg:1")
    }

    #[test]
    fn requires_are_found_as_player_finds_them() {
        let loc = addr(InterfaceCode::LOCALIZE, 0);
        let odom = addr(InterfaceCode::POSITION2D, 0);
        let laser = addr(InterfaceCode::LASER, 0);
        let map = addr(InterfaceCode::MAP, 0);
        // The laser matches with or without a key; its map by the key "laser".
        for laser_key in [None, Some("laser")] {
            let a = Amcl::from_block(&block(
                &[loc],
                &[
                    (Some("odometry"), odom),
                    (laser_key, laser),
                    (Some("laser"), map),
                ],
            ))
            .unwrap();
            assert_eq!(a.odometry, odom);
            assert_eq!(a.laser, Some(SensorDevices { device: laser, map }));
            assert_eq!(a.sonar, None);
        }
        // Odometry alone is enough.
        assert!(Amcl::from_block(&block(&[loc], &[(Some("odometry"), odom)])).is_ok());
    }

    #[test]
    fn missing_pieces_are_clear_errors() {
        let loc = addr(InterfaceCode::LOCALIZE, 0);
        let odom = addr(InterfaceCode::POSITION2D, 0);
        let laser = addr(InterfaceCode::LASER, 0);
        let err = |b: DriverBlock| Amcl::from_block(&b).unwrap_err().to_string();
        assert!(err(block(&[loc], &[(None, odom)])).contains("odometry"));
        assert!(
            err(block(&[loc], &[(Some("odometry"), odom), (None, laser)]))
                .contains("laser:::map:0")
        );
        assert!(err(block(&[], &[(Some("odometry"), odom)])).contains("provide"));
        let sonar = addr(InterfaceCode::SONAR, 0);
        assert!(
            err(block(&[loc], &[(Some("odometry"), odom), (None, sonar)]))
                .contains("sonar:::map:0")
        );
        let pos = addr(InterfaceCode::POSITION2D, 1);
        assert!(err(block(&[loc, pos], &[(Some("odometry"), pos)])).contains("self"));
    }
}

#[cfg(test)]
mod driver_tests {
    use super::tests_support::*;
    use super::*;
    use crate::testing::Harness;
    use player_proto::{LaserGeom, Pose3d};
    use player_server::Action;
    use std::time::{Duration, Instant};

    /// What the filter published, once it has: waits (calling `wake`, as the server does when
    /// the filter thread signals) until `done` says enough arrived.
    fn collect_until(
        h: &mut Harness<Amcl>,
        mut done: impl FnMut(&[Body], &[(player_server::PendingReply, Reply)]) -> bool,
    ) -> (Vec<Body>, Vec<(player_server::PendingReply, Reply)>) {
        let (mut bodies, mut answers) = (Vec::new(), Vec::new());
        let deadline = Instant::now() + Duration::from_secs(10);
        while !done(&bodies, &answers) {
            assert!(Instant::now() < deadline, "the filter produced {bodies:?}");
            std::thread::sleep(Duration::from_millis(5));
            let out = h.wake();
            bodies.extend(out.bodies());
            answers.extend(out.answers());
        }
        (bodies, answers)
    }

    #[test]
    fn the_map_and_geometry_are_fetched_then_data_kept_meanwhile_reaches_the_filter() {
        let mut b = laser_block();
        for (k, v) in [
            ("pf_min_samples", "50"),
            ("pf_max_samples", "500"),
            ("init_pose", "0.5 -0.3 10"),
            ("init_pose_var", "0.1 0.1 5"),
        ] {
            b.options
                .insert(k.into(), v.split(' ').map(str::to_string).collect());
        }
        let mut h = Harness::new(Amcl::from_block(&b).unwrap());
        let out = h.setup();
        assert_eq!(out.subscriptions(), [ODOM, LASER, MAP]);
        let asked = out.requests();
        assert_eq!(asked.len(), 2);
        assert_eq!(asked[0].1, MAP);
        assert_eq!(asked[1].1, LASER);

        // Before the map is in, a GET_PARTICLES and data wait.
        let (reply, token, _) = h.request(LOCALIZE, LocalizeReq::GetParticles(None));
        assert_eq!(reply, Reply::Deferred);
        let truth = Pose::new(0.5, -0.3, 10f64.to_radians());
        let laser_pose = Pose::new(0.1, 0.0, 0.0);
        let grid = room_grid();
        let map = OccupancyMap::new(grid.clone()).unwrap();
        h.data(ODOM, odometry(Pose::zeros()), 1.0);
        h.data(LASER, scan(&map, &truth, &laser_pose), 1.0);

        h.ack(
            asked[1].0,
            LASER,
            Body::Laser(LaserMsg::Ack(LaserReq::GetGeom(Some(LaserGeom {
                pose: Pose3d {
                    px: laser_pose.x,
                    ..Pose3d::default()
                },
                ..LaserGeom::default()
            })))),
        );
        let out = h.ack(
            asked[0].0,
            MAP,
            Body::Map(MapMsg::Ack(MapReq::GetInfo(Some(grid.info())))),
        );
        // One GET_DATA per tile, as libplayerc would fetch the map.
        let tiles = out.requests();
        assert_eq!(tiles.len(), grid.info().tile_requests().count());
        let mut last = None;
        for (ticket, to, body) in tiles {
            assert_eq!(to, MAP);
            let Body::Map(MapMsg::Req(MapReq::GetData(Some(t)))) = body else {
                panic!("{body:?}");
            };
            let data = grid.tile(t.col, t.row, t.width, t.height).unwrap();
            last = Some(h.ack(
                ticket,
                MAP,
                Body::Map(MapMsg::Ack(MapReq::GetData(Some(MapTile { data, ..t })))),
            ));
        }
        // The map is copied: amcl lets go of the map device.
        assert!(last.unwrap().actions.contains(&Action::Unsubscribe(MAP)));

        // The request that waited is answered with the initial particle set, then the kept
        // odometry and scan make the first update.
        let (bodies, answers) = collect_until(&mut h, |bodies, answers| {
            !answers.is_empty()
                && bodies
                    .iter()
                    .any(|b| matches!(b, Body::Localize(LocalizeMsg::Data(_))))
        });
        assert_eq!(answers[0].0, token);
        let Reply::Ack(Some(Body::Localize(LocalizeMsg::Req(LocalizeReq::GetParticles(Some(p)))))) =
            &answers[0].1
        else {
            panic!("{:?}", answers[0].1);
        };
        assert_eq!(p.particles.len(), 500);
        let hyp = bodies
            .iter()
            .find_map(|b| match b {
                Body::Localize(LocalizeMsg::Data(LocalizeData::Hypoths(h))) => Some(h),
                _ => None,
            })
            .unwrap();
        let best = &hyp.hypoths[0];
        assert!(
            (best.mean.px - truth.x).hypot(best.mean.py - truth.y) < 0.1,
            "{best:?}"
        );
        // The position2d estimate comes with it, then follows odometry.
        let out = h.data(ODOM, odometry(Pose::new(0.05, 0.0, 0.0)), 1.1);
        let (bodies, _) = if out.bodies().is_empty() {
            collect_until(&mut h, |b, _| {
                b.iter()
                    .any(|b| matches!(b, Body::Position2d(Position2dMsg::Data(_))))
            })
        } else {
            (out.bodies(), Vec::new())
        };
        assert!(
            bodies
                .iter()
                .any(|b| matches!(b, Body::Position2d(Position2dMsg::Data(_))))
        );
    }

    #[test]
    fn a_refused_map_refuses_the_waiting_requests() {
        let mut h = Harness::new(Amcl::from_block(&laser_block()).unwrap());
        let asked = h.setup().requests();
        let (reply, token, _) = h.request(LOCALIZE, LocalizeReq::GetParticles(None));
        assert_eq!(reply, Reply::Deferred);
        let out = h.nack(asked[0].0);
        assert_eq!(out.answers(), [(token, Reply::Nack)]);
        let (reply, _, _) = h.request(LOCALIZE, LocalizeReq::GetParticles(None));
        assert_eq!(reply, Reply::Nack);
    }

    #[test]
    fn position_geometry_is_a_point_and_set_pose_is_acknowledged() {
        let mut h = Harness::new(Amcl::from_block(&laser_block()).unwrap());
        h.setup();
        let (reply, _, _) = h.request(POSITION, Position2dReq::GetGeom(None));
        let Reply::Ack(Some(Body::Position2d(Position2dMsg::Req(Position2dReq::GetGeom(Some(g)))))) =
            reply
        else {
            panic!("{reply:?}");
        };
        assert_eq!((g.size.sl, g.size.sw), (0.01, 0.01));
        let (reply, _, _) = h.request(
            LOCALIZE,
            LocalizeReq::SetPose(Some(player_proto::LocalizeSetPose::default())),
        );
        assert_eq!(reply, Reply::Ack(None));
    }
}

/// Devices and data for the driver's unit tests.
#[cfg(test)]
mod tests_support {
    use super::*;
    use crate::testing;
    use player_proto::{LaserData, LaserDataScan};

    pub const LOCALIZE: DeviceAddr = dev(InterfaceCode::LOCALIZE, 0);
    pub const POSITION: DeviceAddr = dev(InterfaceCode::POSITION2D, 1);
    pub const ODOM: DeviceAddr = dev(InterfaceCode::POSITION2D, 0);
    pub const LASER: DeviceAddr = dev(InterfaceCode::LASER, 0);
    pub const MAP: DeviceAddr = dev(InterfaceCode::MAP, 0);

    const fn dev(interf: InterfaceCode, index: u16) -> DeviceAddr {
        DeviceAddr {
            host: player_proto::constants::LOCALHOST_ADDR,
            robot: 6665,
            interf,
            index,
        }
    }

    /// amcl providing localize:0 and position2d:1, on odometry position2d:0, laser:0, map:0.
    pub fn laser_block() -> DriverBlock {
        testing::block(NAME, &[LOCALIZE, POSITION], &[], &[]).requiring(
            [
                (Some("odometry"), ODOM),
                (None, LASER),
                (Some("laser"), MAP),
            ],
            "test.cfg:3",
        )
    }

    /// A 3 x 4 m room of 5 cm cells around the origin with a pillar (asymmetric).
    pub fn room_grid() -> OccupancyGrid {
        let origin = Pose2d {
            px: -1.5,
            py: -2.0,
            pa: 0.0,
        };
        let mut g = OccupancyGrid::new(60, 80, 0.05, origin, OccupancyGrid::FREE).unwrap();
        for j in 0..80 {
            for i in 0..60 {
                let rim = i == 0 || j == 0 || i == 59 || j == 79;
                let pillar = (40..46).contains(&i) && (50..56).contains(&j);
                if rim || pillar {
                    g.set(i, j, OccupancyGrid::OCCUPIED);
                }
            }
        }
        g
    }

    /// Odometry DATA at `p`.
    pub fn odometry(p: Pose) -> Body {
        Position2dData::State(Position2dDataState {
            pos: Pose2d {
                px: p.x,
                py: p.y,
                pa: p.z,
            },
            ..Position2dDataState::default()
        })
        .into()
    }

    /// A perfect 181-beam scan of `map` from a robot at `robot` with its laser at `laser`.
    pub fn scan(map: &OccupancyMap, robot: &Pose, laser: &Pose) -> Body {
        let l = pose::compose(robot, laser);
        let res = std::f64::consts::PI / 180.0;
        let ranges = (0..181)
            .map(|k| {
                let b = -std::f64::consts::FRAC_PI_2 + k as f64 * res;
                map.calc_range(l.x, l.y, l.z + b, 8.0) as f32
            })
            .collect();
        LaserData::Scan(LaserDataScan {
            min_angle: -std::f32::consts::FRAC_PI_2,
            max_angle: std::f32::consts::FRAC_PI_2,
            resolution: res as f32,
            max_range: 8.0,
            ranges,
            ..LaserDataScan::default()
        })
        .into()
    }
}
