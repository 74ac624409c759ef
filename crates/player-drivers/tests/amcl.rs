//! `amcl` on the stage driver, over TCP: a robot wandering (Stage's `wander` controller) in a
//! room with drifting odometry and a laser (or a sonar ring), localised against a map of the
//! same room served by a small map driver of this test. The estimate must stay near the
//! simulation's true pose, and two runs must publish the same hypotheses.

mod common;

use std::collections::BTreeMap;
use std::path::Path;
use std::time::{Duration, Instant};

use player_client::{ClientProxy, PlayerClient, Position2dProxy, SimulationProxy};
use player_proto::{
    Body, InterfaceCode, LocalizeData, LocalizeDataHypoths, LocalizeMsg, LocalizeReq,
    LocalizeSetPose, MapInfo, MapMsg, MapReq, MapTile, Message, Pose2d,
};
use player_server::{
    Context, Driver, DriverBlock, Pace, Reply, Server, ServerConfig, ServerHandle, cfg,
};
use worldfile::{CfgFile, LoadOptions};

/// The room: (centre x, centre y, size x, size y) of every wall and obstacle, in metres. The
/// world file and the map are both made from this list.
const WALLS: [(f64, f64, f64, f64); 7] = [
    (0.0, 4.0, 10.2, 0.2),
    (0.0, -4.0, 10.2, 0.2),
    (5.0, 0.0, 0.2, 8.2),
    (-5.0, 0.0, 0.2, 8.2),
    (2.0, 1.5, 1.0, 1.0),
    (-2.0, -1.0, 0.6, 2.0),
    (2.5, -2.5, 1.6, 0.3),
];

/// The robot's start (x, y, heading in degrees).
const START: (f64, f64, f64) = (-3.0, 2.0, -20.0);

/// Map cell size (m) and extent: 11 x 9 m around the room.
const MAP_SCALE: f64 = 0.05;
const MAP_ORIGIN: (f64, f64) = (-5.5, -4.5);
const MAP_SIZE: (usize, usize) = (220, 180);

/// The robot's range sensor, and how amcl is told about it.
#[derive(Clone, Copy)]
enum Sensor {
    /// A 181-beam, 180 degree, 8 m laser served as `laser:0`.
    Laser,
    /// A Pioneer's ring of 16 sonars (5 m) served as `sonar:0` (and a laser that only the
    /// robot's controller uses).
    Sonar,
}

impl Sensor {
    fn world(self) -> String {
        match self {
            Sensor::Laser => {
                "ranger( pose [0.1 0 0 0] sensor( range [0 8] fov 180 samples 181 ) )".into()
            }
            Sensor::Sonar => {
                let ring = [
                    (0.075, 0.130, 90.0),
                    (0.115, 0.115, 50.0),
                    (0.150, 0.080, 30.0),
                    (0.170, 0.025, 10.0),
                    (0.170, -0.025, -10.0),
                    (0.150, -0.080, -30.0),
                    (0.115, -0.115, -50.0),
                    (0.075, -0.130, -90.0),
                    (-0.155, -0.130, -90.0),
                    (-0.195, -0.115, -130.0),
                    (-0.230, -0.080, -150.0),
                    (-0.250, -0.025, -170.0),
                    (-0.250, 0.025, 170.0),
                    (-0.230, 0.080, 150.0),
                    (-0.195, 0.115, 130.0),
                    (-0.155, 0.130, 90.0),
                ];
                let sensors: String = ring
                    .iter()
                    .map(|(x, y, a)| {
                        format!(
                            " sensor( pose [{x} {y} 0 {a}] size [0.01 0.05 0.01] range [0 5] fov 15 samples 1 )"
                        )
                    })
                    .collect();
                // The laser after the ring is for the wander controller (it reads the second
                // ranger, as Stage's wander does); amcl sees only the sonar.
                format!(
                    "ranger({sensors} )\n  ranger( pose [0.1 0 0 0] sensor( range [0 8] fov 180 samples 181 ) )"
                )
            }
        }
    }

    fn cfg(self) -> (&'static str, &'static str) {
        match self {
            Sensor::Laser => ("0:laser:0", "0:laser:0\" \"laser::0:map:0"),
            Sensor::Sonar => ("0:sonar:0", "0:sonar:0\" \"sonar::0:map:0"),
        }
    }
}

fn world_text(sensor: Sensor) -> String {
    let mut w = String::from(
        "resolution 0.02\ninterval_sim 100\n\
         define wall model ( color \"gray30\" obstacle_return 1 ranger_return 1 gui_nose 0 )\n",
    );
    for (i, (x, y, sx, sy)) in WALLS.iter().enumerate() {
        w += &format!("wall( name \"wall{i}\" pose [{x} {y} 0 0] size [{sx} {sy} 0.5] )\n");
    }
    let (x, y, a) = START;
    w += &format!(
        "position(\n  name \"robot\" pose [{x} {y} 0 {a}] size [0.4 0.4 0.3] drive \"diff\"\n  \
         localization \"odom\" odom_error [0.05 0.05 0 0.1]\n  ctrl \"wander\"\n  {}\n)\n",
        sensor.world()
    );
    w
}

/// The room rasterised: a cell is occupied when its centre lies in a wall, free otherwise.
fn map_cells() -> Vec<i8> {
    let (w, h) = MAP_SIZE;
    let mut cells = vec![-1i8; w * h];
    for j in 0..h {
        for i in 0..w {
            let x = MAP_ORIGIN.0 + (i as f64 + 0.5) * MAP_SCALE;
            let y = MAP_ORIGIN.1 + (j as f64 + 0.5) * MAP_SCALE;
            let inside = WALLS
                .iter()
                .any(|&(cx, cy, sx, sy)| (x - cx).abs() <= sx / 2.0 && (y - cy).abs() <= sy / 2.0);
            if inside {
                cells[j * w + i] = 1;
            }
        }
    }
    cells
}

/// A map device answering GET_INFO and GET_DATA from [`map_cells`]; with the option
/// `fail "info"` it refuses GET_INFO, with `fail "tile"` it answers tiles with half their
/// cells.
struct RoomMap {
    cells: Vec<i8>,
    fail: Option<String>,
}

impl Driver for RoomMap {
    fn handle_request(&mut self, _ctx: &mut Context<'_>, request: &Message) -> Reply {
        let (w, h) = MAP_SIZE;
        match &request.body {
            Body::Map(MapMsg::Req(MapReq::GetInfo(_))) if self.fail.as_deref() == Some("info") => {
                Reply::Nack
            }
            Body::Map(MapMsg::Req(MapReq::GetInfo(_))) => {
                Reply::ack(MapReq::GetInfo(Some(MapInfo {
                    scale: MAP_SCALE as f32,
                    width: w as u32,
                    height: h as u32,
                    origin: Pose2d {
                        px: MAP_ORIGIN.0,
                        py: MAP_ORIGIN.1,
                        pa: 0.0,
                    },
                })))
            }
            Body::Map(MapMsg::Req(MapReq::GetData(Some(t)))) => {
                let (c0, r0) = (t.col as usize, t.row as usize);
                let (tw, th) = (t.width as usize, t.height as usize);
                if c0 + tw > w || r0 + th > h {
                    return Reply::Nack;
                }
                let mut data = Vec::with_capacity(tw * th);
                for r in r0..r0 + th {
                    data.extend_from_slice(&self.cells[r * w + c0..r * w + c0 + tw]);
                }
                if self.fail.as_deref() == Some("tile") {
                    data.truncate(data.len() / 2);
                }
                Reply::ack(MapReq::GetData(Some(MapTile { data, ..t.clone() })))
            }
            _ => Reply::NotHandled,
        }
    }
}

fn cfg_text(sensor: Sensor, map_options: &str, extra: &str) -> String {
    let (provided, required) = sensor.cfg();
    format!(
        r#"
driver( name "stage" provides ["0:simulation:0"] plugin "stageplugin" worldfile "amcl-room.world" )
driver( name "stage" provides ["0:position2d:0" "{provided}"] model "robot" )
driver( name "roommap" provides ["0:map:0"] {map_options} )
driver(
  name "amcl"
  provides ["0:localize:0" "0:position2d:1"]
  requires ["odometry::0:position2d:0" "{required}"]
  {init}
  alwayson 1
  {extra}
)
"#,
        init = if extra.contains("init_pose") {
            ""
        } else {
            "init_pose [-2.8 2.2 -10]\n  init_pose_var [0.3 0.3 10]"
        }
    )
}

fn serve(dir: &Path, sensor: Sensor, map_options: &str, extra: &str) -> ServerHandle {
    std::fs::write(dir.join("amcl-room.world"), world_text(sensor)).unwrap();
    let cfgfile = CfgFile::parse(
        &dir.join("amcl-room.cfg"),
        &cfg_text(sensor, map_options, extra),
        &LoadOptions::default(),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let mut registry = common::registry();
    let cells = map_cells();
    registry.register("roommap", move |b: &DriverBlock| {
        Ok(Box::new(RoomMap {
            cells: cells.clone(),
            fail: b.option("fail").map(str::to_string),
        }) as Box<dyn Driver>)
    });
    let mut server = Server::new(ServerConfig {
        pace: Pace::RealTime { speedup: 5.0 },
        ..ServerConfig::default()
    });
    for block in cfg::driver_blocks(&cfgfile, 6665).unwrap() {
        server
            .add_block(&block, &mut registry)
            .unwrap_or_else(|e| panic!("{e}"));
    }
    server.resolve_requires().unwrap_or_else(|e| panic!("{e}"));
    server.start().unwrap_or_else(|e| panic!("{e}"))
}

/// What one run saw.
struct Run {
    /// Hypotheses by timestamp (ms).
    hypotheses: BTreeMap<i64, LocalizeDataHypoths>,
    /// (time s, true pose, amcl's position2d estimate at that time).
    checks: Vec<(f64, Pose2d, Pose2d)>,
    /// Distance the robot travelled (m), from the true poses checked.
    travelled: f64,
    /// The largest distance between dead reckoning and the true pose at the checks (m).
    odometry_error: f64,
    /// The pose SET_POSE gave at the end, and the best hypotheses published after it.
    set_pose: (Pose2d, Vec<Pose2d>),
    /// The GET_PARTICLES answer at the end.
    particle_count: usize,
    particle_weight: f64,
}

fn ms(t: f64) -> i64 {
    (t * 1000.0).round() as i64
}

/// Runs the world until `until` simulated seconds, recording amcl's output and checking the
/// true pose about every simulated second.
fn run(dir: &Path, sensor: Sensor, until: f64) -> Run {
    observe(serve(dir, sensor, "", ""), "robot", START, until)
}

/// Watches the server of `handle` until `until` simulated seconds: amcl's output, the true
/// pose of the model `robot` about every simulated second, and the odometry placed in the
/// world by `odom_frame` (where the odometry's origin is, heading in degrees); then asks for
/// the particles and sets a pose.
fn observe(handle: ServerHandle, robot: &str, odom_frame: (f64, f64, f64), until: f64) -> Run {
    let port = handle.ports()[0];
    let client = PlayerClient::connect("localhost", port).unwrap();
    let localize = ClientProxy::subscribe(&client, InterfaceCode::LOCALIZE, 0).unwrap();
    assert_eq!(localize.driver_name(), "amcl");
    let estimate = Position2dProxy::new(&client, 1).unwrap();
    let sim = SimulationProxy::new(&client, 0).unwrap();
    let odom = Position2dProxy::new(&client, 0).unwrap();

    let mut hypotheses = BTreeMap::new();
    let mut estimates: BTreeMap<i64, Pose2d> = BTreeMap::new();
    let mut truths: Vec<(f64, Pose2d)> = Vec::new();
    let mut next_check = 1.0;
    let mut odometry_error: f64 = 0.0;
    let deadline = Instant::now() + Duration::from_secs(120);
    loop {
        assert!(Instant::now() < deadline, "the run took too long");
        client.read().unwrap();
        if localize.is_fresh() {
            localize.not_fresh();
            if let Some(Body::Localize(LocalizeMsg::Data(LocalizeData::Hypoths(h)))) =
                localize.latest(1)
            {
                hypotheses.insert(ms(localize.datatime()), h);
            }
        }
        if estimate.is_fresh() {
            estimate.not_fresh();
            estimates.insert(ms(estimate.datatime()), estimate.pose());
        }
        let now = client.datatime();
        if now >= next_check {
            let (p, simtime_us) = sim.get_pose3d(robot).unwrap();
            truths.push((
                simtime_us / 1e6,
                Pose2d {
                    px: p.px,
                    py: p.py,
                    pa: p.pyaw,
                },
            ));
            next_check = now + 1.0;
            // Dead reckoning: the odometry (which starts at zero) placed at the start pose.
            let o = odom.pose();
            let (sx, sy, sa) = (odom_frame.0, odom_frame.1, odom_frame.2.to_radians());
            let (wx, wy) = (
                sx + o.px * sa.cos() - o.py * sa.sin(),
                sy + o.px * sa.sin() + o.py * sa.cos(),
            );
            odometry_error = odometry_error.max((wx - p.px).hypot(wy - p.py));
        }
        if now >= until {
            break;
        }
    }
    // Let the filter's output for the last checks arrive.
    let settle = Instant::now() + Duration::from_millis(500);
    while Instant::now() < settle {
        client.read().unwrap();
        if estimate.is_fresh() {
            estimate.not_fresh();
            estimates.insert(ms(estimate.datatime()), estimate.pose());
        }
    }
    let particles = match localize.request(LocalizeReq::GetParticles(None)).unwrap() {
        Some(Body::Localize(LocalizeMsg::Ack(LocalizeReq::GetParticles(Some(p))))) => p,
        other => panic!("GET_PARTICLES answered {other:?}"),
    };
    // SET_POSE restarts the filter at the pose given: a metre and a quarter turn off the
    // truth, with a tight covariance, the next hypotheses are there (the filter is told, not
    // asked). Updates already under way when the request arrived may publish the old belief
    // first, so the first few hypotheses after it are looked at.
    let before = client.datatime();
    let told = {
        let t = truths.last().unwrap().1;
        Pose2d {
            px: t.px - 1.0,
            py: t.py,
            pa: t.pa + std::f64::consts::FRAC_PI_2,
        }
    };
    localize
        .request(LocalizeReq::SetPose(Some(LocalizeSetPose {
            mean: told,
            cov: [1e-4, 1e-4, 1e-4],
        })))
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(5);
    let mut after_set_pose = Vec::new();
    while Instant::now() < deadline && after_set_pose.len() < 3 {
        client.read().unwrap();
        if localize.is_fresh() && localize.datatime() > before {
            localize.not_fresh();
            if let Some(Body::Localize(LocalizeMsg::Data(LocalizeData::Hypoths(h)))) =
                localize.latest(1)
            {
                after_set_pose.push(h.hypoths[0].mean);
            }
        }
    }
    drop((localize, estimate, sim, odom));
    drop(client);
    handle.shutdown();

    let travelled = truths
        .windows(2)
        .map(|w| (w[1].1.px - w[0].1.px).hypot(w[1].1.py - w[0].1.py))
        .sum();
    let checks = truths
        .iter()
        .filter_map(|&(t, truth)| estimates.get(&ms(t)).map(|&e| (t, truth, e)))
        .collect();
    Run {
        hypotheses,
        checks,
        travelled,
        odometry_error,
        set_pose: (told, after_set_pose),
        particle_count: particles.particles.len(),
        particle_weight: particles.particles.iter().map(|p| p.alpha).sum(),
    }
}

fn angle_diff(a: f64, b: f64) -> f64 {
    (a - b).sin().atan2((a - b).cos())
}

#[test]
fn amcl_follows_a_wandering_robot_and_repeats_exactly() {
    let dir = std::env::temp_dir().join(format!("amcl-e2e-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let first = run(&dir, Sensor::Laser, 40.0);

    assert!(
        first.travelled > 4.0,
        "the robot only moved {:.2} m",
        first.travelled
    );
    assert!(
        first.checks.len() >= 20,
        "only {} true poses matched an estimate",
        first.checks.len()
    );
    for &(t, truth, est) in &first.checks {
        let err = (truth.px - est.px).hypot(truth.py - est.py);
        let aerr = angle_diff(truth.pa, est.pa).abs();
        assert!(
            err < 0.3 && aerr < 10f64.to_radians(),
            "at {t:.1} s the estimate {est:?} is {err:.3} m / {aerr:.3} rad from the true pose {truth:?}"
        );
    }
    // Odometry alone would be off by more than that.
    assert!(
        first.odometry_error > 0.3,
        "dead reckoning stayed within {:.3} m",
        first.odometry_error
    );
    assert!(first.hypotheses.len() >= 5);
    assert!(first.particle_count > 100 && first.particle_count <= 10_000);
    assert!((first.particle_weight - 1.0).abs() < 1e-6);
    let (told, next) = &first.set_pose;
    assert!(
        next.iter()
            .any(|m| (told.px - m.px).hypot(told.py - m.py) < 0.1
                && angle_diff(told.pa, m.pa).abs() < 0.1),
        "after SET_POSE to {told:?} the best hypotheses were {next:?}"
    );

    // The same world, seed and inputs: the same hypotheses, bit for bit, over the time both
    // clients listened.
    let second = run(&dir, Sensor::Laser, 25.0);
    let from = *first
        .hypotheses
        .keys()
        .next()
        .unwrap()
        .max(second.hypotheses.keys().next().unwrap());
    let to = *second.hypotheses.keys().last().unwrap();
    let window = |r: &Run| -> Vec<(i64, LocalizeDataHypoths)> {
        r.hypotheses
            .range(from..=to)
            .map(|(t, h)| (*t, h.clone()))
            .collect()
    };
    let (a, b) = (window(&first), window(&second));
    assert!(a.len() >= 5, "only {} hypotheses to compare", a.len());
    assert_eq!(a, b, "two runs published different hypotheses");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Lost at the start: amcl is told the robot is at the room's centre facing east, 3.6 m and
/// 20° from the truth, with a spread (standard deviations 2 m, 2 m, 180°) that covers most of
/// the room. The laser pulls the belief onto the true pose within 10 simulated seconds (the
/// robot wanders at about 0.4 m/s, so amcl updates every half second or so), and it stays there
/// for the rest of the drive.
#[test]
fn amcl_converges_from_a_wrong_pose_with_a_wide_spread() {
    const CONVERGED_BY: f64 = 10.0;
    let dir = std::env::temp_dir().join(format!("amcl-e2e-lost-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let handle = serve(
        &dir,
        Sensor::Laser,
        "",
        "init_pose [0 0 0]\n  init_pose_var [2 2 180]",
    );
    let r = observe(handle, "robot", START, 40.0);
    let _ = std::fs::remove_dir_all(&dir);
    assert!(r.checks.len() >= 20, "only {} checks", r.checks.len());
    let off = |truth: Pose2d, est: Pose2d| {
        (
            (truth.px - est.px).hypot(truth.py - est.py),
            angle_diff(truth.pa, est.pa).abs(),
        )
    };
    // The first estimate is the wrong pose it was given (or near it).
    let (first_err, _) = off(r.checks[0].1, r.checks[0].2);
    assert!(first_err > 1.0, "started only {first_err:.2} m off");
    // From some time on, every check is within 0.3 m and 10°: that time is the convergence.
    let converged_at = r
        .checks
        .iter()
        .rposition(|&(_, truth, est)| {
            let (d, a) = off(truth, est);
            d >= 0.3 || a >= 10f64.to_radians()
        })
        .map_or(r.checks[0].0, |i| {
            r.checks.get(i + 1).map_or(f64::INFINITY, |c| c.0)
        });
    eprintln!(
        "lost amcl: {first_err:.2} m off at first, converged at {converged_at:.1} simulated s"
    );
    assert!(
        converged_at <= CONVERGED_BY,
        "converged only at {converged_at:.1} s: {:?}",
        r.checks
            .iter()
            .map(|&(t, truth, est)| (t, off(truth, est)))
            .collect::<Vec<_>>()
    );
}

/// The sonar sensor (Player 2.0's options, transducer poses from the sonar's GET_GEOM):
/// 16 sonars keep the estimate as close as the laser does in this room.
#[test]
fn amcl_localises_with_a_sonar_ring_from_its_geometry() {
    let dir = std::env::temp_dir().join(format!("amcl-e2e-sonar-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let r = run(&dir, Sensor::Sonar, 40.0);
    let _ = std::fs::remove_dir_all(&dir);
    assert!(
        r.travelled > 4.0,
        "the robot only moved {:.2} m",
        r.travelled
    );
    assert!(r.checks.len() >= 20, "only {} checks", r.checks.len());
    assert!(r.odometry_error > 0.3);
    for &(t, truth, est) in &r.checks {
        let err = (truth.px - est.px).hypot(truth.py - est.py);
        assert!(
            err < 0.3,
            "at {t:.1} s the estimate {est:?} is {err:.3} m from the true pose {truth:?}"
        );
    }
}

/// A map device that refuses its info, or sends short tiles: amcl says why in the log,
/// refuses GET_PARTICLES, and the rest of the server carries on.
#[test]
fn a_broken_map_leaves_amcl_refusing_and_the_server_running() {
    let dir = std::env::temp_dir().join(format!("amcl-e2e-broken-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for fail in ["info", "tile"] {
        let handle = serve(&dir, Sensor::Laser, &format!("fail \"{fail}\""), "");
        let client = PlayerClient::connect("localhost", handle.ports()[0]).unwrap();
        let localize = ClientProxy::subscribe(&client, InterfaceCode::LOCALIZE, 0).unwrap();
        let reply = localize.request(LocalizeReq::GetParticles(None));
        assert!(
            matches!(reply, Err(player_client::ClientError::Nack { .. })),
            "{fail}: {reply:?}"
        );
        // The stage devices still serve.
        let odom = Position2dProxy::new(&client, 0).unwrap();
        let deadline = Instant::now() + Duration::from_secs(10);
        while odom.state().is_none() {
            assert!(Instant::now() < deadline, "{fail}: no odometry");
            client.read().unwrap();
        }
        drop((localize, odom));
        drop(client);
        handle.shutdown();
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Stage's `amcl-sonar.cfg` (written for Player 2.0's amcl): its amcl block's options read as
/// they mean (16 transducer poses in degrees, `update_thresh [0.1 5]`). The next test runs it.
#[test]
fn stage_amcl_sonar_cfg_options_are_read() {
    let Some(path) = test_support::shared("stage-worlds/amcl-sonar.cfg") else {
        return;
    };
    let text = std::fs::read_to_string(&path).unwrap();
    let cfgfile = CfgFile::parse(&path, &text, &LoadOptions::default()).unwrap();
    let spec = cfgfile
        .drivers
        .iter()
        .find(|d| d.name == "amcl")
        .expect("an amcl block");
    let block = DriverBlock {
        name: spec.name.clone(),
        options: spec.options.clone(),
        ..DriverBlock::default()
    };
    let s = player_drivers::localization::amcl::settings::Settings::from_block(&block).unwrap();
    assert_eq!(s.update_dist, 0.1);
    assert!((s.update_angle - 5f64.to_radians()).abs() < 1e-12);
    let poses = s.sonar_poses.expect("scount 16 with spose[i]");
    assert_eq!(poses.len(), 16);
    assert_eq!((poses[0].x, poses[0].y), (0.075, 0.130));
    assert!((poses[0].z - 90f64.to_radians()).abs() < 1e-12);
    assert!((poses[11].z + 170f64.to_radians()).abs() < 1e-12);
    // Untouched options keep 3.0.2's defaults.
    assert_eq!(s.pf_max_samples, 10_000);
}

/// Stage's `amcl-sonar.cfg` run: the Pioneer of `simple.world` wandering the cave, its 16
/// sonars, the cave bitmap through `mapfile` (0.032 m) and `mapscale` (0.1 m), and the cfg's
/// amcl block (`scount`, `spose[i]`, `update_thresh [0.1 5]`, Player 2.0's sonar defaults).
/// The cfg predates Player 3 and Stage 4 and needs four fixes, each of which alone stops it
/// from working: it names the model `robot1` (simple.world's robot is `r0`); it writes Player
/// 1's `odometry::position:0` and `sonar::map:0`; it reads the bitmap with `negate 1`, which
/// inverts a Stage 4 bitmap (walls become free space: every ray starts in a wall and the
/// sonar tells the particles nothing); and amcl starts from the default estimate at the
/// origin, 10 m from the robot, so an `init_pose` at the robot's start is added.
#[test]
fn stage_amcl_sonar_cfg_localises_in_the_cave() {
    let Some(root) = common::stage_worlds() else {
        return;
    };
    let text = std::fs::read_to_string(root.join("amcl-sonar.cfg")).unwrap();
    let fixed = text
        .replace("model \"robot1\"", "model \"r0\"")
        .replace("negate 1", "negate 0")
        .replace("\"position:0\" \"sonar:0\"", "\"0:position:0\" \"0:sonar:0\"")
        .replace("\"simulation:0\"", "\"0:simulation:0\"")
        .replace("\"map:1\"", "\"0:map:1\"")
        .replace("\"map:0\"", "\"0:map:0\"")
        .replace("\"localize:0\"", "\"0:localize:0\" \"0:position2d:1\"")
        .replace(
            "[\"odometry::position:0\" \"sonar:0\" \"sonar::map:0\"]",
            "[\"odometry::0:position:0\" \"0:sonar:0\" \"sonar::0:map:0\"]\n  init_pose [-6.946 -6.947 45]\n  init_pose_var [0.3 0.3 10]",
        );
    assert!(
        fixed.contains("init_pose ["),
        "amcl-sonar.cfg changed: {fixed}"
    );
    let path = root.join("amcl-sonar-fixed.cfg");
    let mut opts = LoadOptions::default();
    opts.stage_path.push(root.clone());
    let cfgfile = CfgFile::parse(&path, &fixed, &opts).unwrap_or_else(|e| panic!("{e}"));
    let mut registry = common::registry();
    let mut server = Server::new(ServerConfig {
        pace: Pace::RealTime { speedup: 5.0 },
        ..ServerConfig::default()
    });
    for block in cfg::driver_blocks(&cfgfile, 6665).unwrap() {
        server
            .add_block(&block, &mut registry)
            .unwrap_or_else(|e| panic!("{e}"));
    }
    server.resolve_requires().unwrap_or_else(|e| panic!("{e}"));
    let handle = server.start().unwrap_or_else(|e| panic!("{e}"));
    // simple.world reports odometry in world coordinates (localization "gps").
    let r = observe(handle, "r0", (0.0, 0.0, 0.0), 40.0);
    assert!(
        r.travelled > 4.0,
        "the robot only moved {:.2} m",
        r.travelled
    );
    assert!(r.checks.len() >= 20, "only {} checks", r.checks.len());
    for &(t, truth, est) in &r.checks {
        let err = (truth.px - est.px).hypot(truth.py - est.py);
        assert!(
            err < 0.3,
            "at {t:.1} s the estimate {est:?} is {err:.3} m from the true pose {truth:?}"
        );
    }
}
