//! The converters and passthrough end to end: a server built from a cfg as the `player` binary
//! builds it (stage driver, these drivers), on a small Stage world, with real TCP clients
//! through the Rust client library.
//!
//! The robot has three rangers: `ranger:0` binds the first (19 samples over 180°), `sonar:0`
//! the three-transducer ring, `laser:0` the third (7 samples). The converter blocks come
//! before the stage blocks in the cfg, so each requires a device of a later block.

use std::collections::HashMap;
use std::net::TcpListener;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use player_client::{ClientError, LaserProxy, PlayerClient, RangerProxy, SonarProxy};
use player_drivers::ranger::rangertolaser::{intensity_byte, laser_config};
use player_proto::{DeviceAddr, InterfaceCode, LaserConfig, Message};
use player_server::stage::{self, StageOptions};
use player_server::{
    ClientId, Context, Driver, DriverBlock, DriverError, DriverRegistry, Reply, RequestError,
    RequestTicket, Server, ServerConfig, ServerHandle,
};

const WORLD: &str = r#"
interval_sim 100
resolution 0.02
define ring sensor ( range [0 5] fov 15 samples 1 )
position
(
  name "r0"
  size [0.5 0.5 0.5]
  pose [0 0 0 30]
  drive "diff"
  ranger ( sensor ( pose [0.1 0 0 0] size [0.15 0.15 0.1] range [0 8] fov 180 samples 19 ) )
  ranger ( ring ( pose [0.2 0 0 0] ) ring ( pose [0 0.2 0 90] ) ring ( pose [0 -0.2 0 -90] ) )
  ranger ( sensor ( pose [-0.1 0 0 180] range [0 4] fov 90 samples 7 ) )
)
model ( name "east" size [0.2 6 1] pose [2 0 0 0] ranger_return 2 )
model ( name "north" size [6 0.2 1] pose [0 2.5 0 0] )
model ( name "west" size [0.2 6 1] pose [-1.5 0 0 0] )
"#;

const CFG: &str = r#"
driver ( name "passthrough" requires ["laser:1"] provides ["laser:2"] )
driver ( name "rangertolaser" requires ["ranger:0"] provides ["laser:1"] )
driver ( name "lasertoranger" requires ["laser:0"] provides ["ranger:5"] )
driver ( name "sonartoranger" requires ["sonar:0"] provides ["ranger:6"] )
driver ( name "stage" provides ["simulation:0"] worldfile "conv.world" )
driver ( name "stage" provides ["position2d:0" "ranger:0" "sonar:0" "laser:0"] model "r0" )
"#;

/// Subscriptions per device of a wrapped driver, and its setups and teardowns.
#[derive(Debug, Default)]
struct Counts {
    subs: HashMap<(InterfaceCode, u16), i64>,
    setups: u32,
    teardowns: u32,
}

type SharedCounts = Arc<Mutex<Counts>>;

/// A driver that counts what the core asks of another, then lets it do it.
struct Counted {
    inner: Box<dyn Driver>,
    counts: SharedCounts,
}

impl Counted {
    fn count(&self) -> std::sync::MutexGuard<'_, Counts> {
        self.counts.lock().unwrap()
    }
}

impl Driver for Counted {
    fn subscribe(&mut self, addr: DeviceAddr) -> Result<(), DriverError> {
        self.inner.subscribe(addr)?;
        *self
            .count()
            .subs
            .entry((addr.interf, addr.index))
            .or_default() += 1;
        Ok(())
    }
    fn unsubscribe(&mut self, addr: DeviceAddr) -> Result<(), DriverError> {
        *self
            .count()
            .subs
            .entry((addr.interf, addr.index))
            .or_default() -= 1;
        self.inner.unsubscribe(addr)
    }
    fn client_unsubscribed(&mut self, addr: DeviceAddr, client: ClientId) {
        self.inner.client_unsubscribed(addr, client)
    }
    fn setup(&mut self, ctx: &mut Context<'_>) -> Result<(), DriverError> {
        self.count().setups += 1;
        self.inner.setup(ctx)
    }
    fn teardown(&mut self, ctx: &mut Context<'_>) {
        self.count().teardowns += 1;
        self.inner.teardown(ctx)
    }
    fn handle_request(&mut self, ctx: &mut Context<'_>, request: &Message) -> Reply {
        self.inner.handle_request(ctx, request)
    }
    fn handle_command(&mut self, ctx: &mut Context<'_>, command: &Message) {
        self.inner.handle_command(ctx, command)
    }
    fn handle_data(&mut self, ctx: &mut Context<'_>, data: &Message) {
        self.inner.handle_data(ctx, data)
    }
    fn handle_reply(
        &mut self,
        ctx: &mut Context<'_>,
        ticket: RequestTicket,
        reply: Result<Message, RequestError>,
    ) {
        self.inner.handle_reply(ctx, ticket, reply)
    }
    fn wake(&mut self, ctx: &mut Context<'_>) {
        self.inner.wake(ctx)
    }
    fn update(&mut self, ctx: &mut Context<'_>) {
        self.inner.update(ctx)
    }
    fn step(&self) -> Option<Duration> {
        self.inner.step()
    }
    fn clock(&self) -> Option<f64> {
        self.inner.clock()
    }
    fn always_on(&self) -> bool {
        self.inner.always_on()
    }
    fn shutdown(&mut self) {
        self.inner.shutdown()
    }
}

/// A running server on a free port, and the counts of the stage block serving `model "r0"`.
struct Running {
    server: ServerHandle,
    port: u16,
    robot: SharedCounts,
}

impl Running {
    fn client(&self) -> PlayerClient {
        let c = PlayerClient::connect("127.0.0.1", self.port).unwrap();
        c.set_read_timeout(Some(Duration::from_secs(5)));
        c
    }

    fn robot_subs(&self, interf: InterfaceCode, index: u16) -> i64 {
        let c = self.robot.lock().unwrap();
        c.subs.get(&(interf, index)).copied().unwrap_or(0)
    }
}

fn folder(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("conv-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Builds the server of `cfg` (in a fresh folder beside the world) the way the `player`
/// binary does, the robot's stage block wrapped in [`Counted`].
fn try_serve(tag: &str, cfg: &str) -> Result<Running, String> {
    let dir = folder(tag);
    std::fs::write(dir.join("conv.world"), WORLD).unwrap();
    let cfg_path = dir.join("conv.cfg");
    std::fs::write(&cfg_path, cfg).unwrap();
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();

    let mut stage_only = DriverRegistry::new();
    stage::register(&mut stage_only, StageOptions::default());
    let robot: SharedCounts = Arc::default();
    let counts = robot.clone();
    let mut registry = DriverRegistry::new();
    player_drivers::register_all(&mut registry);
    registry.register("stage", move |block: &DriverBlock| {
        let inner = stage_only
            .create(block)
            .map_err(|e| DriverError::new(e.to_string()))?;
        let counts = if block.option("model") == Some("r0") {
            counts.clone()
        } else {
            Arc::default()
        };
        Ok(Box::new(Counted { inner, counts }) as Box<dyn Driver>)
    });

    let opts = worldfile::LoadOptions::from_env();
    let cfg = worldfile::CfgFile::load(&cfg_path, &opts).map_err(|e| e.to_string())?;
    let blocks = player_server::cfg::driver_blocks(&cfg, port).map_err(|e| e.to_string())?;
    let mut server = Server::new(ServerConfig::default());
    for b in &blocks {
        server
            .add_block(b, &mut registry)
            .map_err(|e| e.to_string())?;
    }
    server.use_listener(u32::from(port), listener);
    let server = server.start().map_err(|e| e.to_string())?;
    Ok(Running {
        server,
        port,
        robot,
    })
}

fn serve(tag: &str) -> Running {
    try_serve(tag, CFG).unwrap()
}

/// Reads rounds until `ready` holds (at most 5 s).
fn read_until(client: &PlayerClient, mut ready: impl FnMut() -> bool) {
    let end = Instant::now() + Duration::from_secs(5);
    loop {
        client.read().unwrap();
        if ready() {
            return;
        }
        assert!(Instant::now() < end, "no matching data within 5 s");
    }
}

#[test]
fn rangertolaser_publishes_the_rangers_scans_with_its_configuration() {
    let s = serve("r2l");
    let client = s.client();
    let ranger = RangerProxy::new(&client, 0).unwrap();
    let laser = LaserProxy::new(&client, 1).unwrap();
    assert_eq!(laser.driver_name(), "rangertolaser");
    let config = ranger.request_config().unwrap();

    // Several rounds: every latest scan is a whole scan (upstream's would be the empty one
    // its INTNS made), equal to the ranger reading of the same time.
    let mut matched = 0;
    let end = Instant::now() + Duration::from_secs(10);
    while matched < 3 {
        assert!(
            Instant::now() < end,
            "only {matched} matching scans in 10 s"
        );
        client.read().unwrap();
        let Some(scan) = laser.scan() else { continue };
        assert_eq!(scan.ranges.len(), 19, "a scan without its ranges: {scan:?}");
        assert_eq!(scan.intensity.len(), 19, "a scan without its intensities");
        if laser.datatime() != ranger.datatime() {
            continue;
        }
        let ranges: Vec<f32> = ranger.ranges().iter().map(|&r| r as f32).collect();
        assert_eq!(scan.ranges, ranges);
        let intensities: Vec<u8> = ranger
            .intensities()
            .iter()
            .map(|&v| intensity_byte(v))
            .collect();
        assert_eq!(scan.intensity, intensities);
        assert!(
            scan.intensity.contains(&2),
            "the east wall returns 2: {:?}",
            scan.intensity
        );
        assert_eq!(scan.min_angle, config.min_angle as f32);
        assert_eq!(scan.max_angle, config.max_angle as f32);
        assert_eq!(scan.resolution, config.angular_res as f32);
        assert_eq!(scan.max_range, config.max_range as f32);
        assert_eq!(scan.id, 0);
        matched += 1;
    }

    // Requests: the ranger's geometry (pose and size) and configuration, as a laser's.
    let rg = ranger.request_geom().unwrap();
    let lg = laser.request_geom().unwrap();
    assert_eq!((lg.pose, lg.size), (rg.pose, rg.size));
    assert_eq!(laser.request_config().unwrap(), laser_config(&config, 0));
    // Stage refuses ranger SET_CONFIG, so the laser SET_CONFIG is refused, once.
    let refused = laser.request(player_proto::LaserReq::SetConfig(Some(
        LaserConfig::default(),
    )));
    assert!(
        matches!(refused, Err(ClientError::Nack { .. })),
        "{refused:?}"
    );
    assert!(
        laser.request_geom().is_ok(),
        "the client still gets its own answers"
    );
    drop((laser, ranger));
    s.server.shutdown();
}

#[test]
fn one_subscription_starts_a_two_driver_chain_and_its_unsubscribe_stops_it() {
    let s = serve("chain");
    let client = s.client();
    assert_eq!(s.robot_subs(InterfaceCode::RANGER, 0), 0);
    let (setups, teardowns) = {
        let c = s.robot.lock().unwrap();
        (c.setups, c.teardowns)
    };

    // laser:2 is a passthrough of rangertolaser's laser:1, which reads the stage ranger:0.
    let end = LaserProxy::new(&client, 2).unwrap();
    assert_eq!(end.driver_name(), "passthrough");
    assert_eq!(
        s.robot_subs(InterfaceCode::RANGER, 0),
        1,
        "the chain reached the model"
    );
    assert_eq!(s.robot.lock().unwrap().setups, setups + 1);
    read_until(&client, || {
        end.scan().is_some_and(|scan| scan.ranges.len() == 19)
    });

    // A request relayed down the chain and its answer back up.
    let through = end.request_geom().unwrap();
    let direct = RangerProxy::new(&client, 0).unwrap();
    let rg = direct.request_geom().unwrap();
    assert_eq!((through.pose, through.size), (rg.pose, rg.size));
    assert_eq!(end.request_config().unwrap().max_range, 8.0);
    drop(direct);
    assert_eq!(s.robot_subs(InterfaceCode::RANGER, 0), 1);

    drop(end); // unsubscribes
    let deadline = Instant::now() + Duration::from_secs(2);
    while s.robot_subs(InterfaceCode::RANGER, 0) != 0 {
        assert!(
            Instant::now() < deadline,
            "the stage ranger is still subscribed"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
    assert_eq!(s.robot.lock().unwrap().teardowns, teardowns + 1);

    // And it starts again.
    let again = LaserProxy::new(&client, 2).unwrap();
    assert_eq!(s.robot_subs(InterfaceCode::RANGER, 0), 1);
    read_until(&client, || {
        again.scan().is_some_and(|scan| scan.ranges.len() == 19)
    });
    drop(again);
    s.server.shutdown();
}

#[test]
fn lasertoranger_and_sonartoranger_read_the_stage_laser_and_sonar() {
    let s = serve("l2r");
    let client = s.client();
    let laser = LaserProxy::new(&client, 0).unwrap();
    let from_laser = RangerProxy::new(&client, 5).unwrap();
    let sonar = SonarProxy::new(&client, 0).unwrap();
    let from_sonar = RangerProxy::new(&client, 6).unwrap();
    read_until(&client, || {
        !from_laser.ranges().is_empty()
            && from_laser.datatime() == laser.datatime()
            && !from_sonar.ranges().is_empty()
            && from_sonar.datatime() == sonar.datatime()
    });
    let scan = laser.scan().unwrap();
    let widened: Vec<f64> = scan.ranges.iter().map(|&r| f64::from(r)).collect();
    assert_eq!(from_laser.ranges(), widened);
    assert_eq!(widened.len(), 7);
    let intensities: Vec<f64> = scan.intensity.iter().map(|&v| f64::from(v)).collect();
    assert_eq!(from_laser.intensities(), intensities);
    let sonar_ranges: Vec<f64> = sonar.ranges().iter().map(|&r| f64::from(r)).collect();
    assert_eq!(from_sonar.ranges(), sonar_ranges);
    assert_eq!(sonar_ranges.len(), 3);

    // Geometry: the laser's pose and size as the device and its one element.
    let lg = laser.request_geom().unwrap();
    let g = from_laser.request_geom().unwrap();
    assert_eq!((g.pose, g.size), (lg.pose, lg.size));
    assert_eq!(
        (g.element_poses, g.element_sizes),
        (vec![lg.pose], vec![lg.size])
    );
    let lc = laser.request_config().unwrap();
    let rc = from_laser.request_config().unwrap();
    assert_eq!(rc.min_angle, f64::from(lc.min_angle));
    assert_eq!(rc.angular_res, f64::from(lc.resolution));
    assert_eq!(rc.max_range, f64::from(lc.max_range));

    // The sonar ring: one element per transducer, the device spanning them and the origin.
    let sg = sonar.request_geom().unwrap();
    let g = from_sonar.request_geom().unwrap();
    assert_eq!(g.element_poses, sg.poses);
    assert_eq!(g.element_sizes.len(), 3);
    let span = |f: fn(&player_proto::Pose3d) -> f64| {
        let (lo, hi) = sg
            .poses
            .iter()
            .map(f)
            .fold((0f64, 0f64), |(lo, hi), v| (lo.min(v), hi.max(v)));
        hi - lo
    };
    assert_eq!((g.size.sw, g.size.sl), (span(|p| p.px), span(|p| p.py)));
    assert_eq!(from_sonar.request_config().unwrap(), Default::default());
    drop((laser, from_laser, sonar, from_sonar));
    s.server.shutdown();
}

#[test]
fn a_requires_nobody_provides_is_refused_naming_its_line() {
    let cfg = format!(
        "{CFG}driver ( name \"rangertolaser\" requires [\"ranger:9\"] provides [\"laser:7\"] )\n"
    );
    let err = try_serve("missing", &cfg).err().expect("refused");
    assert!(err.contains("conv.cfg:8"), "{err}");
    let cfg = "driver ( name \"passthrough\" requires [\"laser:0\" \"ranger:0\"] provides [\"laser:3\"] )\n";
    let err = try_serve("mismatch", cfg).err().expect("refused");
    assert!(err.contains("mismatched number of entries"), "{err}");
}
