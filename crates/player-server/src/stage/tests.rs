//! The stage driver on a small world, driven directly (no sockets): binding, start-up errors,
//! reference-counted subscriptions, publication cadence and order, requests and the pause flag.

use std::path::PathBuf;
use std::sync::atomic::Ordering;

use player_proto::constants::LOCALHOST_ADDR;
use player_proto::{
    Body, CapabilitiesReq, DeviceAddr, InterfaceCode, Message, MsgType, Position2dCmd,
    Position2dCmdVel, Position2dMsg, Position2dPowerConfig, Position2dReq,
    Position2dVelocityModeConfig, RangerData, RangerMsg, RangerReq, SimulationReq, UniversalMsg,
    UniversalReq,
};

use super::*;
use crate::driver::Publication;

const WORLD: &str = r#"
interval_sim 100
define eye sensor ( range [0 4] fov 20 samples 5 )
position
(
  name "robot"
  size [0.5 0.5 0.5]
  pose [0 0 0 0]
  drive "diff"
  ranger ( eye ( pose [0.25 0 0 0] ) eye ( pose [0 0.25 0 90] ) )
  ranger ( eye ( pose [0.25 0 0 0] ) )
  blobfinder ( colors_count 1 colors [ "red" ] )
  fiducial ( )
  gripper ( pose [0.3 0 -0.5 0] )
)
model ( name "wall" size [0.2 4 1] pose [2 0 0 0] color "red" fiducial_return 7 )
"#;

/// A robot with an arm (one linear joint) and a camera, for the remaining interfaces.
const ARM_WORLD: &str = r#"
interval_sim 100
position
(
  name "robot"
  size [0.5 0.5 0.5]
  actuator ( type "linear" axis [1 0 0] min_position 0 max_position 0.5 max_speed 1 )
  camera ( resolution [8 6] range [0.2 8] fov [70 40] )
)
model ( name "wall" size [0.2 4 1] pose [2 0 0 0] color "red" )
"#;

/// A world file in a fresh temporary folder.
fn world_file(tag: &str) -> PathBuf {
    world_file_with(tag, WORLD)
}

fn world_file_with(tag: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("stage-driver-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("small.world");
    std::fs::write(&path, text).unwrap();
    path
}

fn addr(interf: InterfaceCode, index: u16) -> DeviceAddr {
    DeviceAddr::new(LOCALHOST_ADDR, 6665, interf, index)
}

fn block(devices: &[(InterfaceCode, u16)], options: &[(&str, &str)]) -> DriverBlock {
    DriverBlock::new(STAGE_DRIVER_NAME, "small.cfg:3")
        .providing(devices.iter().map(|&(i, n)| addr(i, n)), "small.cfg:4")
        .with_options(options)
}

/// The simulation block's driver and the robot block's driver.
struct Setup {
    sim: Box<dyn Driver>,
    robot: Box<dyn Driver>,
    handle: StageHandle,
}

fn setup(tag: &str, robot_devices: &[(InterfaceCode, u16)]) -> Setup {
    setup_on(world_file(tag), robot_devices)
}

fn setup_on(world: PathBuf, robot_devices: &[(InterfaceCode, u16)]) -> Setup {
    let mut registry = DriverRegistry::new();
    let handle = register(&mut registry, StageOptions::default());
    let sim = registry
        .create(&block(
            &[(InterfaceCode::SIMULATION, 0)],
            &[("worldfile", world.to_str().unwrap())],
        ))
        .unwrap();
    let robot = registry
        .create(&block(robot_devices, &[("model", "robot")]))
        .unwrap();
    Setup { sim, robot, handle }
}

/// A robot block with one device of `interface` (index 0) on `world`, subscribed.
fn subscribed_on(world: PathBuf, interface: InterfaceCode) -> (Setup, DeviceAddr) {
    let a = addr(interface, 0);
    let mut s = setup_on(world, &[(interface, 0)]);
    s.robot.subscribe(a).unwrap();
    (s, a)
}

/// Why `registry` refuses to build `block`.
fn refusal(registry: &mut DriverRegistry, block: &DriverBlock) -> String {
    registry.create(block).err().expect("refused").to_string()
}

/// Steps the world once and returns what the robot block published.
fn step(s: &mut Setup) -> Vec<Publication> {
    let mut out = Vec::new();
    s.sim.update(&mut Context::new(0.0, None, &mut out));
    s.robot.update(&mut Context::new(0.0, None, &mut out));
    out
}

fn request(d: &mut Box<dyn Driver>, a: DeviceAddr, body: impl Into<Body>) -> Reply {
    let mut out = Vec::new();
    let m = Message::new(a, 0.0, body);
    d.handle_request(&mut Context::new(0.0, Some(ClientId(1)), &mut out), &m)
}

#[test]
fn a_device_before_the_simulation_block_is_a_clear_error() {
    let mut registry = DriverRegistry::new();
    register(&mut registry, StageOptions::default());
    let err = refusal(
        &mut registry,
        &block(&[(InterfaceCode::POSITION2D, 0)], &[("model", "robot")]),
    );
    assert!(
        err.contains("small.cfg:4") && err.contains("must come first"),
        "{err}"
    );
}

#[test]
fn missing_models_and_unsupported_interfaces_name_the_cfg_line() {
    let mut registry = DriverRegistry::new();
    register(&mut registry, StageOptions::default());
    let world = world_file("errors");
    registry
        .create(&block(
            &[(InterfaceCode::SIMULATION, 0)],
            &[("worldfile", world.to_str().unwrap())],
        ))
        .unwrap();
    let err = refusal(
        &mut registry,
        &block(&[(InterfaceCode::POSITION2D, 0)], &[("model", "nobody")]),
    );
    assert!(
        err.contains("small.cfg:4") && err.contains("nobody"),
        "{err}"
    );
    let err = refusal(
        &mut registry,
        &block(&[(InterfaceCode::BUMPER, 0)], &[("model", "robot")]),
    );
    assert!(
        err.contains("does not support") && err.contains("bumper"),
        "{err}"
    );
    // Three rangers wanted, two in the model.
    let err = refusal(
        &mut registry,
        &block(
            &[
                (InterfaceCode::RANGER, 0),
                (InterfaceCode::RANGER, 1),
                (InterfaceCode::RANGER, 2),
            ],
            &[("model", "robot")],
        ),
    );
    assert!(err.contains("ranger:2"), "{err}");
}

#[test]
fn the_world_is_shared_through_the_handle() {
    let s = setup("handle", &[(InterfaceCode::POSITION2D, 0)]);
    let world = s.handle.world().expect("world");
    assert!(
        world
            .read()
            .unwrap()
            .model_by_name("robot.ranger:1")
            .is_some()
    );
    assert!(s.handle.gui_requested(), "usegui defaults to 1");
    assert!(s.handle.world_spec().is_some());
}

#[test]
fn ranger_publishes_range_then_intensities_per_update_only_while_subscribed() {
    let r1 = addr(InterfaceCode::RANGER, 1);
    let mut s = setup(
        "ranger",
        &[(InterfaceCode::RANGER, 0), (InterfaceCode::RANGER, 1)],
    );
    assert!(step(&mut s).is_empty(), "nothing without subscribers");
    s.robot.subscribe(r1).unwrap();
    s.robot.subscribe(r1).unwrap();
    let mut stamps = Vec::new();
    for _ in 0..5 {
        let out = step(&mut s);
        assert_eq!(out.len(), 2, "{out:?}");
        assert!(out.iter().all(|p| p.addr == r1));
        let Body::Ranger(RangerMsg::Data(RangerData::Range(r))) = &out[0].body else {
            panic!("{:?}", out[0].body)
        };
        assert_eq!(r.ranges.len(), 5, "one transducer: all its samples");
        assert!(
            r.ranges.iter().all(|&v| (1.5..=4.0).contains(&v)),
            "{:?}",
            r.ranges
        );
        assert!(matches!(
            out[1].body,
            Body::Ranger(RangerMsg::Data(RangerData::Intns(_)))
        ));
        stamps.push(out[0].timestamp.unwrap());
    }
    assert!(
        stamps.windows(2).all(|w| (w[1] - w[0] - 0.1).abs() < 1e-9),
        "{stamps:?}"
    );
    // Two clients subscribed: the first unsubscription keeps the data flowing.
    s.robot.unsubscribe(r1).unwrap();
    assert_eq!(step(&mut s).len(), 2);
    s.robot.unsubscribe(r1).unwrap();
    assert!(step(&mut s).is_empty());
    assert!(s.robot.unsubscribe(r1).is_err(), "not subscribed");
}

#[test]
fn ranger_geometry_and_config_follow_the_worldfile() {
    let (mut s, r0) = subscribed_on(world_file("rgeom"), InterfaceCode::RANGER);
    step(&mut s);
    let Reply::Ack(Some(Body::Ranger(RangerMsg::Req(RangerReq::GetGeom(Some(g)))))) =
        request(&mut s.robot, r0, RangerReq::GetGeom(None))
    else {
        panic!("no geometry")
    };
    assert_eq!(g.element_poses.len(), 2);
    assert!((g.element_poses[1].pyaw - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    let Reply::Ack(Some(Body::Ranger(RangerMsg::Req(RangerReq::GetConfig(Some(c)))))) =
        request(&mut s.robot, r0, RangerReq::GetConfig(None))
    else {
        panic!("no config")
    };
    assert_eq!(c.max_range, 4.0);
    assert!((c.max_angle - 10f64.to_radians()).abs() < 1e-12);
    assert_eq!(
        request(&mut s.robot, r0, RangerReq::Power(Some(Default::default()))),
        Reply::NotHandled,
        "Stage refuses POWER"
    );
}

#[test]
fn blobfinder_and_fiducial_publish_every_update_even_when_empty() {
    let b = addr(InterfaceCode::BLOBFINDER, 0);
    let f = addr(InterfaceCode::FIDUCIAL, 0);
    let mut s = setup(
        "blobs",
        &[(InterfaceCode::BLOBFINDER, 0), (InterfaceCode::FIDUCIAL, 0)],
    );
    s.robot.subscribe(b).unwrap();
    s.robot.subscribe(f).unwrap();
    let out = step(&mut s);
    assert_eq!(out.len(), 2);
    let Body::Blobfinder(player_proto::BlobfinderMsg::Data(player_proto::BlobfinderData::Blobs(
        blobs,
    ))) = &out[0].body
    else {
        panic!("{:?}", out[0].body)
    };
    // The red wall ahead is a blob.
    assert_eq!(blobs.blobs.len(), 1, "{blobs:?}");
    assert_eq!(blobs.blobs[0].color, 0xff0000);
    let Body::Fiducial(player_proto::FiducialMsg::Data(player_proto::FiducialData::Scan(scan))) =
        &out[1].body
    else {
        panic!("{:?}", out[1].body)
    };
    assert_eq!(scan.fiducials.len(), 1);
    assert_eq!(scan.fiducials[0].id, 7);
    // Turn away: both still publish, empty.
    {
        let world = s.handle.world().unwrap();
        let mut w = world.write().unwrap();
        let first = w.model_id(0).unwrap();
        w.set_pose(first, Pose::new(0.0, 0.0, 0.0, std::f64::consts::PI))
            .unwrap();
    }
    let out = step(&mut s);
    assert_eq!(out.len(), 2);
}

#[test]
fn position2d_requests_and_commands_as_stage_answers_them() {
    let (mut s, p) = subscribed_on(world_file("position"), InterfaceCode::POSITION2D);
    assert_eq!(
        request(
            &mut s.robot,
            p,
            Position2dReq::MotorPower(Some(Position2dPowerConfig { state: 1 }))
        ),
        Reply::empty_ack()
    );
    assert_eq!(
        request(
            &mut s.robot,
            p,
            Position2dReq::VelocityMode(Some(Position2dVelocityModeConfig { value: 0 }))
        ),
        Reply::NotHandled
    );
    let mut out = Vec::new();
    let cmd = Message::new(
        p,
        0.0,
        Position2dCmd::Vel(Position2dCmdVel {
            vel: player_proto::Pose2d {
                px: 0.5,
                py: 0.0,
                pa: 0.0,
            },
            state: 1,
        }),
    );
    s.robot
        .handle_command(&mut Context::new(0.0, Some(ClientId(1)), &mut out), &cmd);
    let mut last = None;
    for _ in 0..10 {
        for publication in step(&mut s) {
            if let Body::Position2d(Position2dMsg::Data(player_proto::Position2dData::State(st))) =
                publication.body
            {
                last = Some(st);
            }
        }
    }
    let st = last.expect("position data");
    assert!(st.pos.px > 0.3 && st.pos.px < 0.6, "{st:?}");
    assert_eq!(st.vel.px, 0.5);
}

#[test]
fn simulation_capabilities_ack_only_the_3d_pose_requests() {
    let sim = addr(InterfaceCode::SIMULATION, 0);
    let mut s = setup("caps", &[(InterfaceCode::POSITION2D, 0)]);
    let cap = |subtype: u8| {
        Body::Universal(UniversalMsg::Req(UniversalReq::Capabilities(Some(
            CapabilitiesReq {
                msg_type: u32::from(MsgType::Req.code()),
                subtype: u32::from(subtype),
            },
        ))))
    };
    assert_eq!(
        request(&mut s.sim, sim, cap(SimulationReq::GET_POSE3D)),
        Reply::empty_ack()
    );
    assert_eq!(
        request(&mut s.sim, sim, cap(SimulationReq::GET_POSE2D)),
        Reply::Nack
    );
}

#[test]
fn the_pause_flag_stops_simulated_time() {
    let mut s = setup("pause", &[(InterfaceCode::POSITION2D, 0)]);
    step(&mut s);
    let t = s.sim.clock().unwrap();
    s.handle.paused().store(true, Ordering::Relaxed);
    step(&mut s);
    assert_eq!(s.sim.clock().unwrap(), t);
    s.handle.paused().store(false, Ordering::Relaxed);
    step(&mut s);
    assert!((s.sim.clock().unwrap() - t - 0.1).abs() < 1e-9);
}

/// A step hook that drives the robot forward before each step and records the sim time and
/// the robot's x after it.
struct Recorder {
    robot: ModelId,
    before: usize,
    after: Arc<Mutex<Vec<(u64, f64)>>>,
}

impl StepHook for Recorder {
    fn before_step(&mut self, world: &mut World) {
        self.before += 1;
        world.position_cmd_vel(self.robot, 1.0, 0.0, 0.0).unwrap();
    }

    fn after_step(&mut self, world: &World) {
        let x = world.pose(self.robot).unwrap().x;
        self.after.lock().unwrap().push((world.sim_time(), x));
        assert!(self.before > 0, "after_step before any before_step");
    }
}

#[test]
fn a_step_hook_runs_around_every_step_and_not_while_paused() {
    let a = addr(InterfaceCode::POSITION2D, 0);
    let mut s = setup("hook", &[(InterfaceCode::POSITION2D, 0)]);
    // a client keeps the robot subscribed, so the hook's command lasts
    s.robot.subscribe(a).unwrap();
    step(&mut s);
    let world = s.handle.world().unwrap();
    let robot = {
        let w = world.read().unwrap();
        w.models().find(|m| w.name(*m).unwrap() == "robot").unwrap()
    };
    let after = Arc::new(Mutex::new(Vec::new()));
    s.handle.set_step_hook(Box::new(Recorder {
        robot,
        before: 0,
        after: after.clone(),
    }));
    for _ in 0..3 {
        step(&mut s);
    }
    s.handle.paused().store(true, Ordering::Relaxed);
    step(&mut s);
    s.handle.paused().store(false, Ordering::Relaxed);
    let seen = after.lock().unwrap().clone();
    assert_eq!(
        seen.iter().map(|(t, _)| *t).collect::<Vec<_>>(),
        [200_000, 300_000, 400_000]
    );
    // the hook's command moved the robot: 1 m/s for 0.1 s per step
    assert!(
        seen[0].1 > 0.05 && seen[2].1 > seen[1].1 && seen[1].1 > seen[0].1,
        "{seen:?}"
    );
    // a Player client sees the move the hook commanded
    let data = step(&mut s)
        .into_iter()
        .find_map(|p| match p.body {
            Body::Position2d(Position2dMsg::Data(player_proto::Position2dData::State(st))) => {
                Some(st.pos)
            }
            _ => None,
        })
        .expect("position2d data");
    assert!(data.px >= seen[2].1 - 1e-9, "{data:?} after {seen:?}");
}

fn command(d: &mut Box<dyn Driver>, a: DeviceAddr, body: impl Into<Body>) {
    let mut out = Vec::new();
    let m = Message::new(a, 0.0, body);
    d.handle_command(&mut Context::new(0.0, Some(ClientId(1)), &mut out), &m);
}

#[test]
fn actarray_reports_one_linear_joint_and_its_goal() {
    use player_proto::{ActarrayCmd, ActarrayData, ActarrayMsg, ActarrayPositionCmd, ActarrayReq};
    let (mut s, a) = subscribed_on(
        world_file_with("actarray", ARM_WORLD),
        InterfaceCode::ACTARRAY,
    );
    let Reply::Ack(Some(Body::Actarray(ActarrayMsg::Req(ActarrayReq::GetGeom(Some(g)))))) =
        request(&mut s.robot, a, ActarrayReq::GetGeom(None))
    else {
        panic!("no geometry")
    };
    assert_eq!(g.actuators.len(), 1);
    assert_eq!((g.actuators[0].min, g.actuators[0].max), (0.0, 0.5));
    let state = |out: &[Publication]| match out.first().map(|p| &p.body) {
        Some(Body::Actarray(ActarrayMsg::Data(ActarrayData::State(st)))) => st.clone(),
        other => panic!("{other:?}"),
    };
    let idle = state(&step(&mut s));
    assert_eq!(idle.actuators.len(), 1);
    assert_eq!(
        idle.actuators[0].state,
        player_proto::constants::PLAYER_ACTARRAY_ACTSTATE_IDLE
    );
    command(
        &mut s.robot,
        a,
        ActarrayCmd::Pos(ActarrayPositionCmd {
            joint: 0,
            position: 0.3,
        }),
    );
    let moving = state(&step(&mut s));
    assert_eq!(
        moving.actuators[0].state,
        player_proto::constants::PLAYER_ACTARRAY_ACTSTATE_MOVING
    );
}

#[test]
fn camera_publishes_the_ray_cast_image() {
    use player_proto::{CameraData, CameraMsg};
    let (mut s, _) = subscribed_on(world_file_with("camera", ARM_WORLD), InterfaceCode::CAMERA);
    let out = step(&mut s);
    let Some(Body::Camera(CameraMsg::Data(CameraData::State(img)))) = out.first().map(|p| &p.body)
    else {
        panic!("{out:?}")
    };
    assert_eq!((img.width, img.height, img.bpp), (8, 6, 24));
    assert_eq!(img.image.len(), 8 * 6 * 3);
    // The red wall fills the middle of the view.
    let mid = (3 * 8 + 4) * 3;
    assert!(
        img.image[mid] > 128 && img.image[mid + 1] < 64,
        "{:?}",
        &img.image[mid..mid + 3]
    );
}

#[test]
fn speech_sets_the_models_bubble() {
    use player_proto::{SpeechCmd, SpeechCmdSay, Text};
    let (mut s, sp) = subscribed_on(world_file("speech"), InterfaceCode::SPEECH);
    command(
        &mut s.robot,
        sp,
        SpeechCmd::Say(SpeechCmdSay {
            string: Text::new("hello"),
        }),
    );
    let world = s.handle.world().unwrap();
    let w = world.read().unwrap();
    assert_eq!(w.said(w.model_by_name("robot").unwrap()).unwrap(), "hello");
}

#[test]
fn odometry_requests_last_in_odom_localisation() {
    use player_proto::{Position2dData, Position2dSetOdomReq};
    let p = addr(InterfaceCode::POSITION2D, 0);
    let world = world_file_with(
        "odom",
        r#"
interval_sim 100
position ( name "robot" size [0.5 0.5 0.5] localization "odom" odom_error [0 0 0 0] )
"#,
    );
    let mut s = setup_on(world, &[(InterfaceCode::POSITION2D, 0)]);
    s.robot.subscribe(p).unwrap();
    let reply = request(
        &mut s.robot,
        p,
        Position2dReq::SetOdom(Some(Position2dSetOdomReq {
            pose: player_proto::Pose2d {
                px: 1.0,
                py: 2.0,
                pa: 0.5,
            },
        })),
    );
    assert_eq!(reply, Reply::empty_ack());
    let pose = |out: Vec<Publication>| {
        out.into_iter()
            .find_map(|p| match p.body {
                Body::Position2d(Position2dMsg::Data(Position2dData::State(st))) => Some(st.pos),
                _ => None,
            })
            .expect("position data")
    };
    step(&mut s);
    let after = pose(step(&mut s));
    assert_eq!((after.px, after.py, after.pa), (1.0, 2.0, 0.5));
    assert_eq!(
        request(&mut s.robot, p, Position2dReq::ResetOdom),
        Reply::empty_ack()
    );
    let reset = pose(step(&mut s));
    assert_eq!((reset.px, reset.py, reset.pa), (0.0, 0.0, 0.0));
}

#[test]
fn map_serves_the_named_models_blocks_at_the_world_resolution() {
    use player_proto::{MapMsg, MapReq, MapTile};
    let world = world_file_with(
        "map",
        "resolution 0.1\n\
         model ( name \"wall\" size [0.2 4 1] pose [2 0 0 0] )\n\
         position ( name \"robot\" size [0.5 0.5 0.5] pose [0 0 0 0] )\n",
    );
    let mut registry = DriverRegistry::new();
    let handle = register(&mut registry, StageOptions::default());
    let _sim = registry
        .create(&block(
            &[(InterfaceCode::SIMULATION, 0)],
            &[("worldfile", world.to_str().unwrap())],
        ))
        .unwrap();
    let mut wall = registry
        .create(&block(&[(InterfaceCode::MAP, 0)], &[("model", "wall")]))
        .unwrap();
    // Another block may serve a map of a model other devices are bound to.
    let mut robot = registry
        .create(&block(
            &[(InterfaceCode::POSITION2D, 0), (InterfaceCode::MAP, 1)],
            &[("model", "robot")],
        ))
        .unwrap();
    let info = |d: &mut Box<dyn Driver>, index| match request(
        d,
        addr(InterfaceCode::MAP, index),
        MapReq::GetInfo(None),
    ) {
        Reply::Ack(Some(Body::Map(MapMsg::Req(MapReq::GetInfo(Some(i)))))) => i,
        other => panic!("{other:?}"),
    };
    let tile = |d: &mut Box<dyn Driver>, index, col, row, width, height| {
        let want = MapTile {
            col,
            row,
            width,
            height,
            data: Vec::new(),
        };
        match request(
            d,
            addr(InterfaceCode::MAP, index),
            MapReq::GetData(Some(want)),
        ) {
            Reply::Ack(Some(Body::Map(MapMsg::Req(MapReq::GetData(Some(t)))))) => t.data,
            other => panic!("{other:?}"),
        }
    };
    // The wall: 0.2 m × 4 m centred on (2, 0) at 0.1 m, all occupied.
    let i = info(&mut wall, 0);
    assert_eq!((i.width, i.height, i.scale), (2, 40, 0.1f32));
    assert!((i.origin.px - 1.9).abs() < 1e-9 && (i.origin.py + 2.0).abs() < 1e-9);
    assert_eq!(i.origin.pa, 0.0);
    assert_eq!(tile(&mut wall, 0, 0, 0, 2, 40), vec![1i8; 80]);
    // Off the map: unknown, as Player's map drivers fill it.
    assert_eq!(tile(&mut wall, 0, 1, 39, 2, 2), [1, 0, 0, 0]);
    // The robot's map follows it when it moves.
    let i = info(&mut robot, 1);
    assert_eq!((i.width, i.height), (5, 5));
    assert!((i.origin.px + 0.25).abs() < 1e-9);
    let world = handle.world().unwrap();
    let id = world.read().unwrap().model_by_name("robot").unwrap();
    world
        .write()
        .unwrap()
        .set_pose(id, stage_sim::Pose::new(3.0, 1.0, 0.0, 0.0))
        .unwrap();
    let i = info(&mut robot, 1);
    assert!((i.origin.px - 2.75).abs() < 1e-9 && (i.origin.py - 0.75).abs() < 1e-9);
    // No vector map.
    assert_eq!(
        request(
            &mut wall,
            addr(InterfaceCode::MAP, 0),
            MapReq::GetVector(None)
        ),
        Reply::NotHandled
    );
}

/// A Pioneer-like robot as Stage's pioneer.inc and simple.world make it, but with odometry:
/// `localization_origin [0 0 0 0]` at (-6.946, -6.947, 45°); a SICK-like ranger (Stage's
/// sick.inc size, 361 rays over 180°) and an arm with one joint limited to [0, 0.5].
const PIONEER_WORLD: &str = r#"
interval_sim 100
resolution 0.02
position
(
  name "robot"
  size [0.44 0.38 0.22]
  pose [-6.946 -6.947 0 45]
  localization "odom"
  localization_origin [0 0 0 0]
  odom_error [0 0 0 0]
  ranger
  (
    size [0.156 0.155 0.19]
    sensor ( range [0 8] fov 180 samples 361 pose [0 0 0.1 0] )
  )
  actuator ( type "linear" axis [1 0 0] min_position 0 max_position 0.5 max_speed 1 )
)
model ( name "wall" size [0.2 20 1] pose [-4 -6.947 0 0] )
"#;

fn first_body(out: &[Publication]) -> &Body {
    &out.first().expect("a publication").body
}

#[test]
fn odometry_starts_at_the_world_pose_under_a_zero_localization_origin() {
    use player_proto::{Position2dData, Position2dSetOdomReq};
    let (mut s, p) = subscribed_on(
        world_file_with("odomstart", PIONEER_WORLD),
        InterfaceCode::POSITION2D,
    );
    let pose = |out: &[Publication]| match first_body(out) {
        Body::Position2d(Position2dMsg::Data(Position2dData::State(st))) => st.pos,
        other => panic!("{other:?}"),
    };
    let start = pose(&step(&mut s));
    assert!(
        (start.px + 6.946).abs() < 1e-9
            && (start.py + 6.947).abs() < 1e-9
            && (start.pa - std::f64::consts::FRAC_PI_4).abs() < 1e-9,
        "{start:?}"
    );
    // SET_ODOM and RESET_ODOM move the estimate for good (odom mode)
    let set = Position2dReq::SetOdom(Some(Position2dSetOdomReq {
        pose: player_proto::Pose2d {
            px: 1.0,
            py: -1.0,
            pa: 0.25,
        },
    }));
    assert_eq!(request(&mut s.robot, p, set), Reply::empty_ack());
    step(&mut s);
    let after = pose(&step(&mut s));
    assert_eq!((after.px, after.py, after.pa), (1.0, -1.0, 0.25));
    assert_eq!(
        request(&mut s.robot, p, Position2dReq::ResetOdom),
        Reply::empty_ack()
    );
    let reset = pose(&step(&mut s));
    assert_eq!((reset.px, reset.py, reset.pa), (0.0, 0.0, 0.0));
}

#[test]
fn actarray_reports_a_position_goal_clamped_to_the_joint_limits() {
    use player_proto::constants::{PLAYER_ACTARRAY_ACTSTATE_IDLE, PLAYER_ACTARRAY_ACTSTATE_MOVING};
    use player_proto::{
        ActarrayCmd, ActarrayData, ActarrayMsg, ActarrayPositionCmd, ActarraySpeedCmd,
    };
    let (mut s, a) = subscribed_on(
        world_file_with("actlimits", PIONEER_WORLD),
        InterfaceCode::ACTARRAY,
    );
    let joint = |out: &[Publication]| match first_body(out) {
        Body::Actarray(ActarrayMsg::Data(ActarrayData::State(st))) => st.actuators[0].clone(),
        other => panic!("{other:?}"),
    };
    let send = |s: &mut Setup, cmd: ActarrayCmd| {
        command(&mut s.robot, a, cmd);
        joint(&step(s))
    };
    let pos = |position| ActarrayCmd::Pos(ActarrayPositionCmd { joint: 0, position });
    let above = send(&mut s, pos(1.0));
    assert_eq!(
        (above.speed, above.state),
        (0.5, PLAYER_ACTARRAY_ACTSTATE_MOVING)
    );
    let below = send(&mut s, pos(-0.3));
    assert_eq!(
        (below.speed, below.state),
        (0.0, PLAYER_ACTARRAY_ACTSTATE_IDLE)
    );
    // max_speed bounds the motion Stage computes, not the reported speed goal
    let fast = send(
        &mut s,
        ActarrayCmd::Speed(ActarraySpeedCmd {
            joint: 0,
            speed: 3.0,
        }),
    );
    assert_eq!((fast.speed, fast.acceleration), (3.0, 0.0));
}

#[test]
fn laser_on_a_ranger_answers_sick_configuration_requests() {
    use player_proto::{LaserConfig, LaserData, LaserMsg, LaserReq};
    let (mut s, l) = subscribed_on(
        world_file_with("lasercfg", PIONEER_WORLD),
        InterfaceCode::LASER,
    );
    let Reply::Ack(Some(Body::Laser(LaserMsg::Req(LaserReq::GetGeom(Some(g)))))) =
        request(&mut s.robot, l, LaserReq::GetGeom(None))
    else {
        panic!("no geometry")
    };
    assert_eq!((g.size.sl, g.size.sw), (0.156, 0.155), "the ranger's size");
    let get = |s: &mut Setup| match request(&mut s.robot, l, LaserReq::GetConfig(None)) {
        Reply::Ack(Some(Body::Laser(LaserMsg::Req(LaserReq::GetConfig(Some(c)))))) => c,
        other => panic!("{other:?}"),
    };
    let whole = get(&mut s);
    assert!(
        (whole.resolution.to_degrees() - 0.5).abs() < 1e-4,
        "{whole:?}"
    );
    assert!((whole.max_angle.to_degrees() - 90.0).abs() < 1e-4);
    assert_eq!(whole.intensity, 1);
    assert!(
        (whole.range_res - 0.02).abs() < 1e-7,
        "the world's resolution"
    );

    let wanted = LaserConfig {
        min_angle: (-45f32).to_radians(),
        max_angle: 45f32.to_radians(),
        resolution: 1f32.to_radians(),
        max_range: f32::NAN,
        range_res: 0.1,
        intensity: 0,
        scanning_frequency: f32::NAN,
    };
    let Reply::Ack(Some(Body::Laser(LaserMsg::Req(LaserReq::SetConfig(Some(applied)))))) =
        request(&mut s.robot, l, LaserReq::SetConfig(Some(wanted.clone())))
    else {
        panic!("SET_CONFIG refused")
    };
    assert_eq!(applied, get(&mut s));
    assert!(
        (applied.min_angle.to_degrees() + 45.0).abs() < 1e-4,
        "{applied:?}"
    );
    assert!((applied.resolution.to_degrees() - 1.0).abs() < 1e-4);
    assert_eq!((applied.range_res, applied.intensity), (0.1, 0));
    assert_eq!(applied.max_range, 8.0, "the worldfile's");

    let out = step(&mut s);
    let Body::Laser(LaserMsg::Data(LaserData::Scan(scan))) = first_body(&out) else {
        panic!("{out:?}")
    };
    assert_eq!(scan.ranges.len(), 91);
    assert_eq!(scan.intensity, vec![0; 91]);
    assert_eq!(
        (scan.min_angle, scan.resolution),
        (applied.min_angle, applied.resolution)
    );
    // Ranges in whole 0.1 m units; the first ray (-45° on a robot facing 45°) runs along +x to
    // the wall's face 2.846 m away.
    assert!(
        scan.ranges
            .iter()
            .all(|&r| ((r * 10.0).round() - r * 10.0).abs() < 1e-4),
        "{:?}",
        scan.ranges
    );
    assert!((scan.ranges[0] - 2.8).abs() < 1e-4, "{}", scan.ranges[0]);

    // Finer than the rays: refused, and the configuration stays.
    let finer = LaserConfig {
        resolution: 0.25f32.to_radians(),
        ..wanted
    };
    assert_eq!(
        request(&mut s.robot, l, LaserReq::SetConfig(Some(finer))),
        Reply::Nack
    );
    assert_eq!(get(&mut s), applied);
}

#[test]
fn every_listed_interface_has_its_own_code() {
    let codes = Served::CODES;
    let distinct: HashSet<InterfaceCode> = codes.iter().copied().collect();
    assert_eq!(
        distinct.len(),
        codes.len(),
        "a code listed twice: {codes:?}"
    );
    for &code in codes {
        assert!(Served::new(code).is_some(), "{code}");
        assert!(stage_binding(code).is_some(), "{code}");
    }
    assert!(Served::new(InterfaceCode::WIFI).is_none());
    assert_eq!(stage_binding(InterfaceCode::WIFI), None);
}

#[test]
fn the_worldfile_is_looked_for_beside_the_cfg_then_on_stagepath() {
    let root = std::env::temp_dir().join(format!("stage-driver-path-{}", std::process::id()));
    let (cfgdir, worlds, other) = (root.join("cfgs"), root.join("worlds"), root.join("other"));
    for d in [&cfgdir, &worlds, &other] {
        std::fs::create_dir_all(d).unwrap();
    }
    std::fs::write(worlds.join("w.world"), WORLD).unwrap();
    std::fs::write(cfgdir.join("here.world"), WORLD).unwrap();
    let mut sim = block(&[(InterfaceCode::SIMULATION, 0)], &[]);
    sim.cfg_path = Some(cfgdir.join("x.cfg"));
    sim.option_origins
        .insert("worldfile".into(), "x.cfg:5:3".into());
    let stage_path = [other.clone(), worlds.clone()];
    // Beside the cfg first; then each STAGEPATH folder, by base name as Stage does.
    assert_eq!(
        find_worldfile(&sim, "here.world", &stage_path).unwrap(),
        cfgdir.join("here.world")
    );
    assert_eq!(
        find_worldfile(&sim, "w.world", &stage_path).unwrap(),
        worlds.join("w.world")
    );
    assert_eq!(
        find_worldfile(&sim, "sub/w.world", &stage_path).unwrap(),
        worlds.join("w.world")
    );
    // Nowhere: the message names the file, where the cfg names it and where we looked.
    let e = find_worldfile(&sim, "w.world", std::slice::from_ref(&other)).unwrap_err();
    assert_eq!(e.kind, BindErrorKind::WorldDoesNotLoad);
    assert_eq!(
        e.message,
        format!(
            "cannot read world file \"w.world\" named at x.cfg:5:3: No such file or directory \
             (os error 2) (looked for {}; nor on STAGEPATH {})",
            cfgdir.join("w.world").display(),
            other.display()
        )
    );
    let e = find_worldfile(&sim, "w.world", &[]).unwrap_err();
    assert!(
        e.message.ends_with("; STAGEPATH is not set)"),
        "{}",
        e.message
    );
    let _ = std::fs::remove_dir_all(root);
}
