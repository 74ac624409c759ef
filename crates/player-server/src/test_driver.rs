//! A small driver with predictable behaviour, for the server's tests, benchmarks and manual
//! checks with real clients before the `stage` driver exists.
//!
//! It serves any interface. While subscribed, every step it publishes: position2d STATE (pose
//! integrated from the last velocity command), ranger RANGE then INTNS (`samples` values that
//! change every step), blobfinder BLOBS (one blob), gripper STATE and fiducial SCAN (empty);
//! other interfaces publish nothing. It answers position2d GET_GEOM / MOTOR_POWER / SET_ODOM /
//! RESET_ODOM, ranger GET_GEOM / GET_CONFIG, gripper and fiducial GET_GEOM, simulation
//! GET/SET_POSE2D and GET_POSE3D for the names in `models`, and CAPABILITIES for simulation
//! pose requests; everything else is left unhandled (empty NACK).
//!
//! cfg options: `step_ms` (default 100), `sim_clock 1` (supply simulated time, starting at 0,
//! one step per update, as Stage does), `samples` (ranger values, default 4), `models`
//! (simulation model names, default `"bob1"`), `fail_subscribe 1` (refuse subscriptions),
//! `silent 1` (publish nothing), `alwayson`.

use std::collections::{BTreeMap, HashMap};
use std::time::Duration;

use player_proto::constants::PLAYER_GRIPPER_STATE_OPEN;
use player_proto::{
    Bbox3d, BlobfinderBlob, BlobfinderData, BlobfinderDataBlobs, Body, CapabilitiesReq, DeviceAddr,
    FiducialData, FiducialDataScan, FiducialGeom, FiducialReq, GripperData, GripperDataState,
    GripperGeom, GripperReq, InterfaceCode, Message, MsgType, Pose2d, Pose3d, Position2dCmd,
    Position2dData, Position2dDataState, Position2dGeom, Position2dMsg, Position2dReq,
    RangerConfig, RangerData, RangerDataIntns, RangerDataRange, RangerGeom, RangerMsg, RangerReq,
    SimulationMsg, SimulationPose2dReq, SimulationPose3dReq, SimulationReq, UniversalMsg,
    UniversalReq,
};

use crate::driver::{Context, Driver, DriverBlock, DriverError, DriverRegistry, Reply};

/// The name the `player` binary registers the test driver under (never a real driver's name).
pub const TEST_DRIVER_NAME: &str = "testdriver";

#[derive(Clone, Copy, Debug, Default)]
struct Base {
    pose: Pose2d,
    vel: Pose2d,
}

/// The test driver. See the module docs for its behaviour and options.
#[derive(Debug)]
pub struct TestDriver {
    devices: Vec<DeviceAddr>,
    step: Duration,
    sim_time: Option<f64>,
    samples: usize,
    fail_subscribe: bool,
    silent: bool,
    subscriptions: HashMap<DeviceAddr, usize>,
    bases: HashMap<DeviceAddr, Base>,
    models: BTreeMap<String, Pose2d>,
    steps: u64,
}

impl TestDriver {
    /// Builds the driver from its cfg block.
    pub fn from_block(block: &DriverBlock) -> Result<TestDriver, DriverError> {
        let flag = |key: &str| -> Result<bool, DriverError> {
            Ok(block.option_parse::<i64>(key)?.unwrap_or(0) != 0)
        };
        let step_ms = block.option_parse::<u64>("step_ms")?.unwrap_or(100);
        if step_ms == 0 {
            return Err(DriverError::new("option `step_ms` must be at least 1"));
        }
        let models = match block.options.get("models") {
            Some(names) => names.clone(),
            None => vec!["bob1".to_string()],
        };
        Ok(TestDriver {
            devices: block.provides.iter().map(|p| p.addr).collect(),
            step: Duration::from_millis(step_ms),
            sim_time: flag("sim_clock")?.then_some(0.0),
            samples: block
                .option_parse::<usize>("samples")?
                .unwrap_or(4)
                .min(4096),
            fail_subscribe: flag("fail_subscribe")?,
            silent: flag("silent")?,
            subscriptions: HashMap::new(),
            bases: HashMap::new(),
            models: models
                .into_iter()
                .enumerate()
                .map(|(i, n)| {
                    let pose = Pose2d {
                        px: i as f64,
                        py: -(i as f64),
                        pa: 0.0,
                    };
                    (n, pose)
                })
                .collect(),
            steps: 0,
        })
    }

    /// Registers the test driver's factory under `name`.
    pub fn register(registry: &mut DriverRegistry, name: &str) {
        registry.register(name, |block: &DriverBlock| {
            Ok(Box::new(TestDriver::from_block(block)?) as Box<dyn Driver>)
        });
    }

    /// Steps taken so far.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    fn publish_device(&mut self, ctx: &mut Context<'_>, addr: DeviceAddr, dt: f64) {
        let stamp = |ctx: &mut Context<'_>, sim: Option<f64>, body: Body| match sim {
            Some(t) => ctx.publish_at(addr, body, t),
            None => ctx.publish(addr, body),
        };
        let sim = self.sim_time;
        let k = self.steps as f64;
        match addr.interf {
            InterfaceCode::POSITION2D => {
                let base = self.bases.entry(addr).or_default();
                base.pose.px += base.vel.px * base.pose.pa.cos() * dt;
                base.pose.py += base.vel.px * base.pose.pa.sin() * dt;
                base.pose.pa += base.vel.pa * dt;
                let state = Position2dDataState {
                    pos: base.pose,
                    vel: base.vel,
                    stall: 0,
                };
                stamp(ctx, sim, Position2dData::State(state).into());
            }
            InterfaceCode::RANGER => {
                let ranges = (0..self.samples)
                    .map(|i| 1.0 + i as f64 * 0.25 + (k % 10.0) * 0.01)
                    .collect();
                stamp(
                    ctx,
                    sim,
                    RangerData::Range(RangerDataRange { ranges }).into(),
                );
                let intensities = vec![0.5; self.samples];
                stamp(
                    ctx,
                    sim,
                    RangerData::Intns(RangerDataIntns { intensities }).into(),
                );
            }
            InterfaceCode::BLOBFINDER => {
                let blob = BlobfinderBlob {
                    id: 0,
                    color: 0x00ff_a500,
                    area: 100,
                    x: 80,
                    y: 60,
                    left: 75,
                    right: 85,
                    top: 55,
                    bottom: 65,
                    range: 1.5,
                };
                let data = BlobfinderDataBlobs {
                    width: 160,
                    height: 120,
                    blobs: vec![blob],
                };
                stamp(ctx, sim, BlobfinderData::Blobs(data).into());
            }
            InterfaceCode::GRIPPER => {
                let state = GripperDataState {
                    state: PLAYER_GRIPPER_STATE_OPEN,
                    beams: 0,
                    stored: 0,
                };
                stamp(ctx, sim, GripperData::State(state).into());
            }
            InterfaceCode::FIDUCIAL => {
                stamp(
                    ctx,
                    sim,
                    FiducialData::Scan(FiducialDataScan::default()).into(),
                );
            }
            _ => {}
        }
    }
}

fn geom_size() -> Bbox3d {
    Bbox3d {
        sw: 0.4,
        sl: 0.5,
        sh: 0.3,
    }
}

impl Driver for TestDriver {
    fn subscribe(&mut self, addr: DeviceAddr) -> Result<(), DriverError> {
        if self.fail_subscribe {
            return Err(DriverError::new("test driver refuses subscriptions"));
        }
        *self.subscriptions.entry(addr).or_default() += 1;
        Ok(())
    }

    fn unsubscribe(&mut self, addr: DeviceAddr) -> Result<(), DriverError> {
        match self.subscriptions.get_mut(&addr) {
            Some(n) if *n > 0 => {
                *n -= 1;
                Ok(())
            }
            _ => Err(DriverError::new(format!("{addr} was not subscribed"))),
        }
    }

    fn handle_request(&mut self, _ctx: &mut Context<'_>, request: &Message) -> Reply {
        let addr = request.header.addr;
        match &request.body {
            Body::Position2d(Position2dMsg::Req(r)) => match r {
                Position2dReq::GetGeom(None) => {
                    Reply::ack(Position2dReq::GetGeom(Some(Position2dGeom {
                        pose: Pose3d {
                            px: 0.1,
                            ..Pose3d::default()
                        },
                        size: geom_size(),
                    })))
                }
                Position2dReq::MotorPower(Some(_)) => Reply::empty_ack(),
                Position2dReq::SetOdom(Some(odom)) => {
                    self.bases.entry(addr).or_default().pose = odom.pose;
                    Reply::empty_ack()
                }
                Position2dReq::ResetOdom => {
                    self.bases.entry(addr).or_default().pose = Pose2d::default();
                    Reply::empty_ack()
                }
                _ => Reply::NotHandled,
            },
            Body::Ranger(RangerMsg::Req(r)) => match r {
                RangerReq::GetGeom(None) => Reply::ack(RangerReq::GetGeom(Some(RangerGeom {
                    size: geom_size(),
                    element_poses: vec![Pose3d::default(); self.samples],
                    element_sizes: vec![Bbox3d::default(); self.samples],
                    ..RangerGeom::default()
                }))),
                RangerReq::GetConfig(None) => {
                    let fov = std::f64::consts::PI;
                    Reply::ack(RangerReq::GetConfig(Some(RangerConfig {
                        min_angle: -fov / 2.0,
                        max_angle: fov / 2.0,
                        angular_res: fov / self.samples.max(1) as f64,
                        min_range: 0.0,
                        max_range: 5.0,
                        range_res: 0.01,
                        frequency: 1.0 / self.step.as_secs_f64(),
                    })))
                }
                _ => Reply::NotHandled,
            },
            Body::Gripper(player_proto::GripperMsg::Req(GripperReq::GetGeom(None))) => {
                Reply::ack(GripperReq::GetGeom(Some(GripperGeom {
                    outer_size: geom_size(),
                    num_beams: 2,
                    capacity: 1,
                    ..GripperGeom::default()
                })))
            }
            Body::Fiducial(player_proto::FiducialMsg::Req(FiducialReq::GetGeom(None))) => {
                Reply::ack(FiducialReq::GetGeom(Some(FiducialGeom {
                    size: geom_size(),
                    ..FiducialGeom::default()
                })))
            }
            Body::Simulation(SimulationMsg::Req(r)) => self.simulation(r),
            Body::Universal(UniversalMsg::Req(UniversalReq::Capabilities(Some(
                CapabilitiesReq { msg_type, subtype },
            )))) if addr.interf == InterfaceCode::SIMULATION
                && *msg_type == u32::from(MsgType::Req.code())
                && [
                    SimulationReq::GET_POSE2D,
                    SimulationReq::SET_POSE2D,
                    SimulationReq::GET_POSE3D,
                ]
                .contains(&(*subtype as u8)) =>
            {
                Reply::empty_ack()
            }
            _ => Reply::NotHandled,
        }
    }

    fn handle_command(&mut self, _ctx: &mut Context<'_>, command: &Message) {
        let addr = command.header.addr;
        match &command.body {
            Body::Position2d(Position2dMsg::Cmd(Position2dCmd::Vel(v))) => {
                self.bases.entry(addr).or_default().vel = v.vel;
            }
            Body::Position2d(Position2dMsg::Cmd(Position2dCmd::Car(c))) => {
                self.bases.entry(addr).or_default().vel = Pose2d {
                    px: c.velocity,
                    py: 0.0,
                    pa: c.angle,
                };
            }
            other => tracing::debug!("test driver ignores {}", other.constant()),
        }
    }

    fn update(&mut self, ctx: &mut Context<'_>) {
        self.steps += 1;
        let dt = self.step.as_secs_f64();
        if let Some(t) = &mut self.sim_time {
            *t += dt;
        }
        if self.silent {
            return;
        }
        for addr in self.devices.clone() {
            if self.subscriptions.get(&addr).copied().unwrap_or(0) > 0 {
                self.publish_device(ctx, addr, dt);
            }
        }
    }

    fn step(&self) -> Option<Duration> {
        Some(self.step)
    }

    fn clock(&self) -> Option<f64> {
        self.sim_time
    }
}

impl TestDriver {
    fn simulation(&mut self, r: &SimulationReq) -> Reply {
        let name = |text: &player_proto::Text| text.to_str_lossy().into_owned();
        match r {
            SimulationReq::GetPose2d(Some(req)) => match self.models.get(&name(&req.name)) {
                Some(pose) => Reply::ack(SimulationReq::GetPose2d(Some(SimulationPose2dReq {
                    name: req.name.clone(),
                    pose: *pose,
                }))),
                None => Reply::Nack,
            },
            SimulationReq::SetPose2d(Some(req)) => match self.models.get_mut(&name(&req.name)) {
                Some(pose) => {
                    *pose = req.pose;
                    Reply::empty_ack()
                }
                None => Reply::Nack,
            },
            SimulationReq::GetPose3d(Some(req)) => match self.models.get(&name(&req.name)) {
                Some(pose) => Reply::ack(SimulationReq::GetPose3d(Some(SimulationPose3dReq {
                    name: req.name.clone(),
                    pose: Pose3d {
                        px: pose.px,
                        py: pose.py,
                        pyaw: pose.pa,
                        ..Pose3d::default()
                    },
                    simtime: self.sim_time.unwrap_or(0.0) * 1e6,
                }))),
                None => Reply::Nack,
            },
            _ => Reply::NotHandled,
        }
    }
}
