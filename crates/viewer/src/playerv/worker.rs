//! The client thread: connects with `player-client`, lists the devices, keeps one proxy per
//! subscribed device, reads at the chosen rate in PULL or PUSH mode and publishes a
//! [`PlayervState`] snapshot after each read. The UI talks to it with [`Request`]s, so a slow or
//! vanished server never blocks the window.

use std::collections::BTreeMap;
use std::sync::mpsc::{self, Receiver, Sender, TryRecvError};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use player_client::{
    BlobfinderProxy, CameraProxy, ClientError, ClientProxy, DataMode, FiducialProxy, GripperProxy,
    LaserProxy, LocalizeProxy, LogProxy, LogState, MapProxy, PlannerProxy, PlayerClient,
    Position2dProxy, RangerProxy, SonarProxy,
};
use player_proto::{
    FiducialGeom, GripperGeom, InterfaceCode, LaserGeom, Pose3d, RangerConfig, RangerGeom,
    SonarGeom,
};

use super::state::{
    CommandMode, DeviceData, DeviceKey, Hypothesis, MapGrid, PlannerView, PlayervState, Pose2,
    Scan, Subscribed, camera_rgba,
};

/// What the UI asks the client thread to do.
#[derive(Clone, Debug, PartialEq)]
pub enum Request {
    /// Subscribe to a device.
    Subscribe(DeviceKey),
    /// Unsubscribe from a device.
    Unsubscribe(DeviceKey),
    /// Switch PUSH/PULL.
    SetMode(DataMode),
    /// Data rounds per second.
    SetRate(f64),
    /// Drive a position2d towards a target given in the robot's frame.
    Drive {
        /// The position2d device.
        device: DeviceKey,
        /// Velocity or position control.
        mode: CommandMode,
        /// Target in the robot's frame.
        target: Pose2,
    },
    /// Stop a position2d (zero velocity).
    Stop(DeviceKey),
    /// Motor power on or off.
    MotorPower(DeviceKey, bool),
    /// A goal for a planner (map frame), as playernav's left-drag sends it.
    SetGoal(DeviceKey, Pose2),
    /// A pose for a localiser (map frame) with the variances of x, y and heading, as
    /// playernav's right-drag sends it.
    SetPose(DeviceKey, Pose2, [f64; 3]),
    /// Allow or stop a planner's motion (playernav's Go and Stop).
    PlannerEnable(DeviceKey, bool),
    /// Fetch localize devices' particles (or stop fetching them).
    ShowParticles(bool),
    /// Start (`true`) or stop a log device: recording for writelog, replay for readlog
    /// (playervcr's buttons).
    LogActive(DeviceKey, bool),
    /// Rewind a readlog to the start of its file.
    LogRewind(DeviceKey),
    /// End the thread.
    Quit,
}

/// Fastest forward speed the bull's-eye commands (m/s).
pub const MAX_SPEED: f64 = 0.5;
/// Fastest turn rate the bull's-eye commands (rad/s).
pub const MAX_TURN: f64 = 1.0;

/// Velocity for a target in the robot's frame (playerv's bull's-eye in velocity mode): forward
/// speed grows with the target's distance ahead, the turn rate with its bearing.
pub fn velocity_for(target: Pose2) -> (f64, f64) {
    let vx = target.x.clamp(-MAX_SPEED, MAX_SPEED);
    let va = target.y.atan2(target.x.abs()).clamp(-MAX_TURN, MAX_TURN);
    (vx, va)
}

/// The odometry-frame goal for a target in the robot's frame, facing along the way there.
pub fn goal_for(odom: Pose2, target: Pose2) -> Pose2 {
    let (x, y) = odom.frame().transform_xy(target.x, target.y);
    Pose2 {
        x,
        y,
        a: odom.a + target.y.atan2(target.x),
    }
}

enum Proxy {
    Position(Position2dProxy, [f64; 2]),
    Ranger(RangerProxy, Option<RangerGeom>, Option<RangerConfig>),
    Laser(LaserProxy, Option<LaserGeom>),
    Sonar(SonarProxy, Option<SonarGeom>),
    Blobfinder(BlobfinderProxy),
    Fiducial(FiducialProxy, Option<FiducialGeom>),
    Gripper(GripperProxy, Option<GripperGeom>),
    Camera(CameraProxy),
    Map(MapProxy, Option<Arc<MapGrid>>),
    /// The planner, its last fetched waypoints and the state they were fetched for.
    Planner(PlannerProxy, Vec<[f64; 2]>, Option<PlanKey>),
    /// The localiser and its last fetched particles, and when.
    Localize(LocalizeProxy, Vec<(Pose2, f64)>, Option<Instant>),
    /// A log device, its last state and when it was asked.
    Log(LogProxy, Option<LogState>, Option<Instant>),
    Other(ClientProxy),
}

/// What identifies a plan: the goal and the number of waypoints (a new plan for the same goal
/// usually differs in them too), and whether it is valid.
type PlanKey = (bool, u32, [u64; 3]);

/// How often what has no DATA of its own is asked for again: particles (while shown) and log
/// devices' state.
const REFRESH_PERIOD: Duration = Duration::from_secs(1);

impl Proxy {
    fn driver(&self) -> &str {
        match self {
            Proxy::Position(p, _) => p.driver_name(),
            Proxy::Ranger(p, ..) => p.driver_name(),
            Proxy::Laser(p, _) => p.driver_name(),
            Proxy::Sonar(p, _) => p.driver_name(),
            Proxy::Blobfinder(p) => p.driver_name(),
            Proxy::Fiducial(p, _) => p.driver_name(),
            Proxy::Gripper(p, _) => p.driver_name(),
            Proxy::Camera(p) => p.driver_name(),
            Proxy::Map(p, _) => p.driver_name(),
            Proxy::Planner(p, ..) => p.driver_name(),
            Proxy::Localize(p, ..) => p.driver_name(),
            Proxy::Log(p, ..) => p.driver_name(),
            Proxy::Other(p) => p.driver_name(),
        }
    }

    fn datatime(&self) -> f64 {
        match self {
            Proxy::Position(p, _) => p.datatime(),
            Proxy::Ranger(p, ..) => p.datatime(),
            Proxy::Laser(p, _) => p.datatime(),
            Proxy::Sonar(p, _) => p.datatime(),
            Proxy::Blobfinder(p) => p.datatime(),
            Proxy::Fiducial(p, _) => p.datatime(),
            Proxy::Gripper(p, _) => p.datatime(),
            Proxy::Camera(p) => p.datatime(),
            Proxy::Map(p, _) => p.datatime(),
            Proxy::Planner(p, ..) => p.datatime(),
            Proxy::Localize(p, ..) => p.datatime(),
            Proxy::Log(p, ..) => p.datatime(),
            Proxy::Other(p) => p.datatime(),
        }
    }
}

/// Subscribes and asks for the geometry each kind of device needs to be drawn (devices that
/// do not answer geometry requests are drawn with defaults).
fn subscribe(client: &PlayerClient, key: DeviceKey) -> Result<Proxy, ClientError> {
    let i = key.index;
    Ok(match key.interf {
        InterfaceCode::POSITION2D => {
            let p = Position2dProxy::new(client, i)?;
            let size = p
                .request_geom()
                .map(|g| [g.size.sl, g.size.sw])
                .unwrap_or([0.5, 0.5]);
            Proxy::Position(p, size)
        }
        InterfaceCode::RANGER => {
            let p = RangerProxy::new(client, i)?;
            let g = p.request_geom().ok();
            let c = p.request_config().ok();
            Proxy::Ranger(p, g, c)
        }
        InterfaceCode::LASER => {
            let p = LaserProxy::new(client, i)?;
            let g = p.request_geom().ok();
            Proxy::Laser(p, g)
        }
        InterfaceCode::SONAR => {
            let p = SonarProxy::new(client, i)?;
            let g = p.request_geom().ok();
            Proxy::Sonar(p, g)
        }
        InterfaceCode::BLOBFINDER => Proxy::Blobfinder(BlobfinderProxy::new(client, i)?),
        InterfaceCode::FIDUCIAL => {
            let p = FiducialProxy::new(client, i)?;
            let g = p.request_geometry().ok();
            Proxy::Fiducial(p, g)
        }
        InterfaceCode::GRIPPER => {
            let p = GripperProxy::new(client, i)?;
            let g = p.request_geometry().ok();
            Proxy::Gripper(p, g)
        }
        InterfaceCode::CAMERA => Proxy::Camera(CameraProxy::new(client, i)?),
        InterfaceCode::MAP => {
            // The grid is fetched once, as playerv does; a map that cannot be read is drawn
            // as nothing, the subscription kept.
            let p = MapProxy::new(client, i)?;
            let grid = p.get_map().ok().and_then(|m| {
                MapGrid::new(
                    m.info.width,
                    m.info.height,
                    f64::from(m.info.scale),
                    [m.info.origin.px, m.info.origin.py],
                    &m.cells,
                )
            });
            Proxy::Map(p, grid.map(Arc::new))
        }
        InterfaceCode::PLANNER => Proxy::Planner(PlannerProxy::new(client, i)?, Vec::new(), None),
        InterfaceCode::LOCALIZE => {
            Proxy::Localize(LocalizeProxy::new(client, i)?, Vec::new(), None)
        }
        InterfaceCode::LOG => Proxy::Log(LogProxy::new(client, i)?, None, None),
        other => Proxy::Other(ClientProxy::subscribe(client, other, i)?),
    })
}

fn pose2(p: &Pose3d) -> Pose2 {
    Pose2 {
        x: p.px,
        y: p.py,
        a: p.pyaw,
    }
}

/// Scans of a ranger from its ranges, geometry and configuration: one sensor sweeping
/// `min_angle..max_angle` (a laser), or one range per element (a sonar ring), as Stage's
/// ranger driver reports them (element poses relative to the device pose).
pub fn ranger_scans(
    ranges: &[f64],
    geom: Option<&RangerGeom>,
    config: Option<&RangerConfig>,
) -> Vec<Scan> {
    let device = geom.map(|g| pose2(&g.pose)).unwrap_or_default();
    let elems: Vec<Pose2> = geom
        .map(|g| g.element_poses.iter().map(pose2).collect())
        .unwrap_or_default();
    let max_range = config
        .map(|c| c.max_range)
        .filter(|r| r.is_finite() && *r > 0.0)
        .unwrap_or_else(|| ranges.iter().copied().fold(0.0, f64::max));
    let span = config
        .map(|c| c.max_angle - c.min_angle)
        .filter(|s| s.is_finite() && *s >= 0.0 && *s <= std::f64::consts::TAU)
        .unwrap_or(0.0);
    if elems.len() > 1 && ranges.len() == elems.len() {
        return elems
            .iter()
            .zip(ranges)
            .map(|(e, &r)| Scan {
                origin: super::scene::compose(device, *e),
                bearings: vec![0.0],
                ranges: vec![r],
                max_range,
                cone: span,
            })
            .collect();
    }
    let origin = super::scene::compose(device, elems.first().copied().unwrap_or_default());
    let n = ranges.len();
    let (min, res) = match config {
        Some(c) if c.angular_res.is_finite() && c.angular_res > 0.0 => (c.min_angle, c.angular_res),
        Some(c) if n > 1 && c.min_angle.is_finite() => (c.min_angle, span / (n - 1) as f64),
        Some(c) if c.min_angle.is_finite() => (c.min_angle, 0.0),
        _ if n > 1 => (
            -std::f64::consts::FRAC_PI_2,
            std::f64::consts::PI / (n - 1) as f64,
        ),
        _ => (0.0, 0.0),
    };
    vec![Scan {
        origin,
        bearings: (0..n).map(|i| min + i as f64 * res).collect(),
        ranges: ranges.to_vec(),
        max_range,
        cone: 0.0,
    }]
}

fn pose_of(p: &player_proto::Pose2d) -> Pose2 {
    Pose2 {
        x: p.px,
        y: p.py,
        a: p.pa,
    }
}

/// Requests what a device's data alone does not carry, when it changed: a planner's waypoints
/// once per new plan, a localiser's particles about once a second while they are shown.
fn refresh(p: &mut Proxy, particles: bool) -> Result<(), ClientError> {
    match p {
        Proxy::Planner(p, waypoints, fetched) => {
            let Some(d) = p.data() else { return Ok(()) };
            let key = (
                d.valid != 0,
                d.waypoints_count,
                [
                    d.goal.px.to_bits(),
                    d.goal.py.to_bits(),
                    d.goal.pa.to_bits(),
                ],
            );
            if *fetched != Some(key) {
                *waypoints = if d.valid != 0 {
                    p.request_waypoints()?
                        .iter()
                        .map(|w| [w.px, w.py])
                        .collect()
                } else {
                    Vec::new()
                };
                *fetched = Some(key);
            }
        }
        Proxy::Localize(p, shown, fetched) => {
            if !particles {
                shown.clear();
                *fetched = None;
            } else if fetched.is_none_or(|t| t.elapsed() >= REFRESH_PERIOD) {
                *shown = p
                    .request_particles()?
                    .particles
                    .iter()
                    .map(|q| (pose_of(&q.pose), q.alpha))
                    .collect();
                *fetched = Some(Instant::now());
            }
        }
        Proxy::Log(p, state, asked) if asked.is_none_or(|t| t.elapsed() >= REFRESH_PERIOD) => {
            *asked = Some(Instant::now());
            *state = Some(p.get_state()?);
        }
        _ => {}
    }
    Ok(())
}

fn snapshot(p: &Proxy) -> DeviceData {
    match p {
        Proxy::Position(p, size) => match p.state() {
            Some(s) => DeviceData::Position2d {
                pose: Pose2 {
                    x: s.pos.px,
                    y: s.pos.py,
                    a: s.pos.pa,
                },
                velocity: Pose2 {
                    x: s.vel.px,
                    y: s.vel.py,
                    a: s.vel.pa,
                },
                stall: s.stall != 0,
                size: *size,
            },
            None => DeviceData::Position2d {
                pose: Pose2::default(),
                velocity: Pose2::default(),
                stall: false,
                size: *size,
            },
        },
        Proxy::Ranger(p, g, c) => DeviceData::Ranges {
            scans: ranger_scans(&p.ranges(), g.as_ref(), c.as_ref()),
        },
        Proxy::Laser(p, g) => match p.scan() {
            Some(s) => {
                let origin = g.as_ref().map(|g| pose2(&g.pose)).unwrap_or_default();
                let n = s.ranges.len();
                DeviceData::Ranges {
                    scans: vec![Scan {
                        origin,
                        bearings: (0..n)
                            .map(|i| s.min_angle as f64 + i as f64 * s.resolution as f64)
                            .collect(),
                        ranges: s.ranges.iter().map(|&r| r as f64).collect(),
                        max_range: s.max_range as f64,
                        cone: 0.0,
                    }],
                }
            }
            None => DeviceData::Other,
        },
        Proxy::Sonar(p, g) => {
            let ranges = p.ranges();
            let poses: Vec<Pose2> = g
                .as_ref()
                .map(|g| g.poses.iter().map(pose2).collect())
                .unwrap_or_default();
            let max = ranges.iter().fold(0f32, |a, &b| a.max(b)) as f64;
            DeviceData::Ranges {
                scans: ranges
                    .iter()
                    .enumerate()
                    .map(|(i, &r)| Scan {
                        origin: poses.get(i).copied().unwrap_or_default(),
                        bearings: vec![0.0],
                        ranges: vec![r as f64],
                        max_range: max,
                        cone: 15f64.to_radians(),
                    })
                    .collect(),
            }
        }
        Proxy::Blobfinder(p) => match p.data() {
            Some(d) => DeviceData::Blobs {
                size: [d.width, d.height],
                blobs: d
                    .blobs
                    .iter()
                    .map(|b| (b.color, [b.left, b.top, b.right, b.bottom]))
                    .collect(),
            },
            None => DeviceData::Other,
        },
        Proxy::Fiducial(p, g) => DeviceData::Fiducials {
            origin: g.as_ref().map(|g| pose2(&g.pose)).unwrap_or_default(),
            items: p
                .fiducials()
                .iter()
                .map(|f| (f.id, pose2(&f.pose)))
                .collect(),
        },
        Proxy::Gripper(p, g) => match p.data() {
            Some(d) => DeviceData::Gripper {
                state: d.state,
                beams: d.beams,
                pose: g.as_ref().map(|g| pose2(&g.pose)).unwrap_or_default(),
                size: g
                    .as_ref()
                    .map(|g| [g.outer_size.sl, g.outer_size.sw])
                    .unwrap_or([0.2, 0.3]),
                num_beams: g.as_ref().map(|g| g.num_beams).unwrap_or(2),
            },
            None => DeviceData::Other,
        },
        Proxy::Camera(p) => match p.image().as_ref().and_then(camera_rgba) {
            Some((width, height, rgba)) => DeviceData::Camera {
                width,
                height,
                rgba,
            },
            None => DeviceData::Other,
        },
        Proxy::Map(_, grid) => match grid {
            Some(g) => DeviceData::Map(g.clone()),
            None => DeviceData::Other,
        },
        Proxy::Planner(p, waypoints, _) => match p.data() {
            Some(d) => DeviceData::Planner(PlannerView {
                valid: d.valid != 0,
                done: d.done != 0,
                pos: pose_of(&d.pos),
                goal: pose_of(&d.goal),
                waypoint: pose_of(&d.waypoint),
                waypoint_idx: d.waypoint_idx,
                waypoints: waypoints.clone(),
            }),
            None => DeviceData::Other,
        },
        Proxy::Localize(p, particles, _) => {
            let mut hypotheses: Vec<Hypothesis> = p
                .hypotheses()
                .iter()
                .map(|h| Hypothesis {
                    mean: pose_of(&h.mean),
                    cov: h.cov,
                    weight: h.alpha,
                })
                .collect();
            hypotheses.sort_by(|a, b| b.weight.total_cmp(&a.weight));
            DeviceData::Localize {
                hypotheses,
                particles: particles.clone(),
            }
        }
        Proxy::Log(_, state, _) => match state {
            Some(s) => DeviceData::Log {
                reading: s.log_type == player_proto::PLAYER_LOG_TYPE_READ,
                active: s.state,
            },
            None => DeviceData::Other,
        },
        Proxy::Other(_) => DeviceData::Other,
    }
}

/// The running client thread and the state it publishes.
pub struct Worker {
    tx: Sender<Request>,
    state: Arc<Mutex<PlayervState>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Worker {
    /// Starts the client thread for `host:port`, subscribing `initial` once connected.
    /// `repaint` is called after every published snapshot (to wake the UI).
    pub fn spawn(
        host: &str,
        port: u16,
        mode: DataMode,
        rate_hz: f64,
        initial: Vec<DeviceKey>,
        repaint: impl Fn() + Send + 'static,
    ) -> Worker {
        let (tx, rx) = mpsc::channel();
        let state = Arc::new(Mutex::new(PlayervState::new(
            &format!("{host}:{port}"),
            mode,
            rate_hz,
        )));
        let st = state.clone();
        let host = host.to_string();
        let thread = std::thread::Builder::new()
            .name("playerv client".into())
            .spawn(move || run(&host, port, initial, rx, st, repaint))
            .expect("spawning the client thread");
        Worker {
            tx,
            state,
            thread: Some(thread),
        }
    }

    /// Sends a request to the client thread.
    pub fn send(&self, r: Request) {
        let _ = self.tx.send(r);
    }

    /// The latest snapshot.
    pub fn state(&self) -> PlayervState {
        self.state.lock().unwrap_or_else(|p| p.into_inner()).clone()
    }
}

impl Drop for Worker {
    fn drop(&mut self) {
        let _ = self.tx.send(Request::Quit);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

struct Session {
    client: PlayerClient,
    proxies: BTreeMap<DeviceKey, Proxy>,
}

fn lock(s: &Mutex<PlayervState>) -> std::sync::MutexGuard<'_, PlayervState> {
    s.lock().unwrap_or_else(|p| p.into_inner())
}

fn connect(
    host: &str,
    port: u16,
    mode: DataMode,
    wanted: &[DeviceKey],
    st: &Mutex<PlayervState>,
) -> Result<Session, ClientError> {
    let client = PlayerClient::connect(host, port)?;
    client.set_read_timeout(Some(Duration::from_secs(2)));
    if mode == DataMode::Push {
        client.set_datamode(DataMode::Push)?;
    }
    let devices = client.device_list()?;
    {
        let mut s = lock(st);
        s.banner = client.banner();
        s.connected = true;
        s.devices = devices
            .iter()
            .map(|d| {
                (
                    DeviceKey {
                        interf: d.addr.interf,
                        index: d.addr.index,
                    },
                    d.driver_name.clone(),
                )
            })
            .collect();
        s.note(format!(
            "connected to {host}:{port}: {} device(s)",
            devices.len()
        ));
    }
    let mut session = Session {
        client,
        proxies: BTreeMap::new(),
    };
    for &k in wanted {
        add(&mut session, k, st);
    }
    Ok(session)
}

fn add(session: &mut Session, key: DeviceKey, st: &Mutex<PlayervState>) {
    if session.proxies.contains_key(&key) {
        return;
    }
    match subscribe(&session.client, key) {
        Ok(p) => {
            lock(st).note(format!("subscribed to {key} ({})", p.driver()));
            session.proxies.insert(key, p);
        }
        Err(e) => lock(st).note(format!("cannot subscribe to {key}: {e}")),
    }
}

fn publish(session: &Session, st: &Mutex<PlayervState>) {
    let subscribed = session
        .proxies
        .iter()
        .map(|(k, p)| {
            (
                *k,
                Subscribed {
                    driver: p.driver().to_string(),
                    data: snapshot(p),
                    datatime: p.datatime(),
                },
            )
        })
        .collect();
    let mut s = lock(st);
    s.subscribed = subscribed;
    s.datatime = session.client.datatime();
}

fn handle(
    r: Request,
    session: &mut Option<Session>,
    wanted: &mut Vec<DeviceKey>,
    st: &Mutex<PlayervState>,
) -> Result<(), ClientError> {
    match r {
        Request::Subscribe(k) => {
            if !wanted.contains(&k) {
                wanted.push(k);
            }
            if let Some(s) = session {
                add(s, k, st);
            }
        }
        Request::Unsubscribe(k) => {
            wanted.retain(|w| *w != k);
            if let Some(s) = session {
                // the proxy unsubscribes when dropped
                if s.proxies.remove(&k).is_some() {
                    lock(st).note(format!("unsubscribed from {k}"));
                }
            }
        }
        Request::SetMode(m) => {
            lock(st).mode = m;
            if let Some(s) = session {
                s.client.set_datamode(m)?;
            }
        }
        Request::SetRate(r) => {
            if r.is_finite() && r > 0.0 {
                lock(st).rate_hz = r.clamp(0.1, 100.0);
            }
        }
        Request::Drive {
            device,
            mode,
            target,
        } => {
            if let Some(Proxy::Position(p, _)) =
                session.as_ref().and_then(|s| s.proxies.get(&device))
            {
                match mode {
                    CommandMode::Off => {}
                    CommandMode::Velocity => {
                        let (vx, va) = velocity_for(target);
                        p.set_speed(vx, 0.0, va)?;
                    }
                    CommandMode::Position => {
                        let odom = p.pose();
                        let g = goal_for(
                            Pose2 {
                                x: odom.px,
                                y: odom.py,
                                a: odom.pa,
                            },
                            target,
                        );
                        p.go_to(g.x, g.y, g.a)?;
                    }
                }
            }
        }
        Request::Stop(device) => {
            if let Some(Proxy::Position(p, _)) =
                session.as_ref().and_then(|s| s.proxies.get(&device))
            {
                p.set_speed(0.0, 0.0, 0.0)?;
            }
        }
        Request::MotorPower(device, on) => {
            if let Some(Proxy::Position(p, _)) =
                session.as_ref().and_then(|s| s.proxies.get(&device))
            {
                p.set_motor_enable(on)?;
            }
        }
        Request::SetGoal(device, goal) => {
            if let Some(Proxy::Planner(p, ..)) =
                session.as_ref().and_then(|s| s.proxies.get(&device))
            {
                p.set_goal(goal.x, goal.y, goal.a)?;
                lock(st).note(format!(
                    "goal ({:.2}, {:.2}, {:.0}°) sent to {device}",
                    goal.x,
                    goal.y,
                    goal.a.to_degrees()
                ));
            }
        }
        Request::SetPose(device, mean, cov) => {
            if let Some(Proxy::Localize(p, ..)) =
                session.as_ref().and_then(|s| s.proxies.get(&device))
            {
                p.set_pose(
                    player_proto::Pose2d {
                        px: mean.x,
                        py: mean.y,
                        pa: mean.a,
                    },
                    cov,
                )?;
                lock(st).note(format!(
                    "pose ({:.2}, {:.2}, {:.0}°) given to {device}",
                    mean.x,
                    mean.y,
                    mean.a.to_degrees()
                ));
            }
        }
        Request::PlannerEnable(device, on) => {
            if let Some(Proxy::Planner(p, ..)) =
                session.as_ref().and_then(|s| s.proxies.get(&device))
            {
                p.enable(on)?;
            }
        }
        Request::ShowParticles(on) => lock(st).particles = on,
        Request::LogActive(device, on) => {
            if let Some(Proxy::Log(p, state, asked)) =
                session.as_mut().and_then(|s| s.proxies.get_mut(&device))
            {
                match state {
                    Some(s) if s.log_type == player_proto::PLAYER_LOG_TYPE_READ => {
                        p.set_read_state(on)?
                    }
                    _ => p.set_write_state(on)?,
                }
                // ask again at once, so the buttons show what the device now does
                *asked = None;
            }
        }
        Request::LogRewind(device) => {
            if let Some(Proxy::Log(p, _, asked)) =
                session.as_mut().and_then(|s| s.proxies.get_mut(&device))
            {
                p.rewind()?;
                *asked = None;
            }
        }
        Request::Quit => {}
    }
    Ok(())
}

fn fatal(e: &ClientError) -> bool {
    matches!(
        e,
        ClientError::Closed
            | ClientError::Io(_)
            | ClientError::Connect { .. }
            | ClientError::Banner { .. }
    )
}

fn run(
    host: &str,
    port: u16,
    initial: Vec<DeviceKey>,
    rx: Receiver<Request>,
    st: Arc<Mutex<PlayervState>>,
    repaint: impl Fn(),
) {
    let mut wanted = initial;
    let mut session: Option<Session> = None;
    let mut next_connect = Instant::now();
    loop {
        // requests first
        loop {
            match rx.try_recv() {
                Ok(Request::Quit) | Err(TryRecvError::Disconnected) => return,
                Ok(r) => {
                    if let Err(e) = handle(r, &mut session, &mut wanted, &st) {
                        lock(&st).note(format!("request failed: {e}"));
                        if fatal(&e) {
                            session = None;
                            lock(&st).connected = false;
                        }
                    }
                }
                Err(TryRecvError::Empty) => break,
            }
        }
        let (mode, rate) = {
            let s = lock(&st);
            (s.mode, s.rate_hz)
        };
        let period = Duration::from_secs_f64(1.0 / rate.clamp(0.1, 100.0));
        let tick = Instant::now();
        if session.is_none() && Instant::now() >= next_connect {
            match connect(host, port, mode, &wanted, &st) {
                Ok(s) => session = Some(s),
                Err(e) => {
                    let mut s = lock(&st);
                    s.connected = false;
                    s.note(format!("cannot connect to {host}:{port}: {e}; retrying"));
                    next_connect = Instant::now() + Duration::from_secs(2);
                }
            }
            repaint();
        }
        if let Some(s) = &session {
            let mut failure = None;
            if !s.proxies.is_empty() {
                match mode {
                    DataMode::Pull => {
                        if let Err(e) = s.client.read() {
                            failure = Some(e);
                        }
                    }
                    DataMode::Push => {
                        // take what arrives during one period
                        s.client.set_read_timeout(Some(Duration::from_millis(20)));
                        while tick.elapsed() < period {
                            match s.client.read() {
                                Ok(()) => {}
                                Err(ClientError::Timeout { .. }) => {}
                                Err(e) => {
                                    failure = Some(e);
                                    break;
                                }
                            }
                        }
                        s.client.set_read_timeout(Some(Duration::from_secs(2)));
                    }
                }
            }
            match failure {
                None | Some(ClientError::NoData) => {}
                Some(e) if fatal(&e) => {
                    let mut g = lock(&st);
                    g.connected = false;
                    g.note(format!("connection lost: {e}; reconnecting"));
                    drop(g);
                    session = None;
                    next_connect = Instant::now() + Duration::from_secs(1);
                }
                Some(e) => lock(&st).note(format!("read: {e}")),
            }
            if let Some(s) = &mut session {
                let particles = lock(&st).particles;
                for (k, p) in s.proxies.iter_mut() {
                    if let Err(e) = refresh(p, particles) {
                        lock(&st).note(format!("{k}: {e}"));
                    }
                }
                publish(s, &st);
            }
            repaint();
        }
        let spent = tick.elapsed();
        if spent < period {
            // wake early for UI requests
            if let Ok(r) = rx.recv_timeout(period - spent) {
                if r == Request::Quit {
                    return;
                }
                if let Err(e) = handle(r, &mut session, &mut wanted, &st) {
                    lock(&st).note(format!("request failed: {e}"));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn velocity_follows_the_target() {
        let (vx, va) = velocity_for(Pose2 {
            x: 0.2,
            y: 0.0,
            a: 0.0,
        });
        assert!((vx - 0.2).abs() < 1e-12 && va == 0.0);
        let (vx, va) = velocity_for(Pose2 {
            x: 5.0,
            y: 5.0,
            a: 0.0,
        });
        assert_eq!(vx, MAX_SPEED);
        assert!((va - std::f64::consts::FRAC_PI_4).abs() < 1e-12);
        let (vx, va) = velocity_for(Pose2 {
            x: -1.0,
            y: -0.01,
            a: 0.0,
        });
        assert_eq!(vx, -MAX_SPEED);
        assert!(va < 0.0);
    }

    #[test]
    fn position_goal_is_in_the_odometry_frame() {
        let g = goal_for(
            Pose2 {
                x: 1.0,
                y: 1.0,
                a: std::f64::consts::FRAC_PI_2,
            },
            Pose2 {
                x: 2.0,
                y: 0.0,
                a: 0.0,
            },
        );
        assert!((g.x - 1.0).abs() < 1e-12 && (g.y - 3.0).abs() < 1e-12);
        assert!((g.a - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    }

    #[test]
    fn ranger_scans_sweep_a_laser_and_split_a_ring() {
        let cfg = RangerConfig {
            min_angle: -1.0,
            max_angle: 1.0,
            angular_res: 0.5,
            min_range: 0.0,
            max_range: 8.0,
            range_res: 0.0,
            frequency: 10.0,
        };
        let geom = RangerGeom {
            pose: Pose3d {
                px: 0.1,
                ..Pose3d::default()
            },
            element_poses: vec![Pose3d::default()],
            ..RangerGeom::default()
        };
        let s = ranger_scans(&[1.0, 2.0, 3.0, 4.0, 5.0], Some(&geom), Some(&cfg));
        assert_eq!(s.len(), 1);
        assert_eq!(s[0].bearings, vec![-1.0, -0.5, 0.0, 0.5, 1.0]);
        assert_eq!(s[0].origin.x, 0.1);
        assert_eq!(s[0].max_range, 8.0);
        let ring = RangerGeom {
            element_poses: (0..4)
                .map(|i| Pose3d {
                    pyaw: i as f64,
                    ..Pose3d::default()
                })
                .collect(),
            ..RangerGeom::default()
        };
        let s = ranger_scans(&[1.0, 2.0, 3.0, 4.0], Some(&ring), Some(&cfg));
        assert_eq!(s.len(), 4);
        assert_eq!(s[3].origin.a, 3.0);
        assert_eq!(s[3].ranges, vec![4.0]);
        // no geometry and no config: a half circle
        let s = ranger_scans(&[1.0, 1.0, 1.0], None, None);
        assert!((s[0].bearings[2] - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    }
}
