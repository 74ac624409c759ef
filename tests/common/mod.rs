//! Helpers of the end-to-end tests: where the workspace and the shared reference material are,
//! and servers running the `stage` driver on a cfg with its ports mapped to free ones.

#![allow(dead_code)] // each test binary uses a different subset

use std::collections::BTreeMap;
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use player_server::stage::{self, StageHandle, StageOptions};
use player_server::{DriverRegistry, Pace, Server, ServerConfig, ServerHandle};
use worldfile::{CfgFile, LoadOptions};

/// The workspace root (this package's folder).
pub fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

#[allow(unused_imports)] // test binaries each use a different subset
pub use test_support::shared;

/// A running server on a cfg, its cfg ports mapped to free ports.
pub struct Running {
    handle: Option<ServerHandle>,
    /// cfg port → the port actually served.
    pub ports: BTreeMap<u32, u16>,
    /// The stage driver's handle (world, pause flag).
    pub stage: StageHandle,
}

impl Running {
    /// The port actually serving the cfg's `port`.
    pub fn port(&self, cfg_port: u32) -> u16 {
        self.ports[&cfg_port]
    }

    /// The server handle.
    pub fn handle(&self) -> &ServerHandle {
        self.handle.as_ref().unwrap()
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        if let Some(h) = self.handle.take() {
            h.shutdown();
        }
    }
}

/// Starts the server on `cfg` (default port 6665) at `pace`, every port the cfg names served
/// on a free port instead (device addresses relabelled accordingly).
pub fn serve_cfg(cfg: &Path, pace: Pace) -> Running {
    serve_cfg_on(cfg, pace, |_| {})
}

/// As [`serve_cfg`], with every driver of `player-drivers` available beside `stage`.
pub fn serve_cfg_with_drivers(cfg: &Path, pace: Pace) -> Running {
    serve_cfg_on(cfg, pace, player_drivers::register_all)
}

fn serve_cfg_on(cfg: &Path, pace: Pace, more: impl FnOnce(&mut DriverRegistry)) -> Running {
    let opts = LoadOptions::from_env();
    let cfg = CfgFile::load(cfg, &opts).unwrap_or_else(|e| panic!("{e}"));
    let mut blocks = player_server::cfg::driver_blocks(&cfg, 6665).unwrap();
    let mut ports = BTreeMap::new();
    let mut listeners = Vec::new();
    for b in &mut blocks {
        for p in &mut b.provides {
            let real = *ports.entry(p.addr.robot).or_insert_with(|| {
                let l = TcpListener::bind("0.0.0.0:0").unwrap();
                let port = l.local_addr().unwrap().port();
                listeners.push((u32::from(port), l));
                port
            });
            p.addr.robot = u32::from(real);
        }
    }
    // `requires` naming a port of this cfg name the port serving it.
    for b in &mut blocks {
        for r in &mut b.requires {
            if let Some(&real) = ports.get(&r.addr.robot) {
                r.addr.robot = u32::from(real);
            }
        }
    }
    let mut registry = DriverRegistry::new();
    let stage = stage::register(
        &mut registry,
        StageOptions {
            seed: 1,
            usegui: Some(false),
        },
    );
    more(&mut registry);
    let mut server = Server::new(ServerConfig {
        pace,
        ..ServerConfig::default()
    });
    for b in &blocks {
        server
            .add_block(b, &mut registry)
            .unwrap_or_else(|e| panic!("{e}"));
    }
    for (port, l) in listeners {
        server.use_listener(port, l);
    }
    Running {
        handle: Some(server.start().unwrap()),
        ports,
        stage,
    }
}

/// Our Bigbob world with both robots: bob1 on the cfg's port 6665, bob2 on 6666.
pub fn bigbob2(pace: Pace) -> Running {
    serve_cfg(&root().join("worlds/bigbob2.cfg"), pace)
}

/// The conformance world's cfg (`conformance/sessions/world/bigbob.cfg`), when present.
pub fn conformance_cfg() -> Option<PathBuf> {
    shared("conformance/sessions/world/bigbob.cfg")
}

/// A Pioneer 2DX-like world (our own; sizes as in Stage's pioneer.inc and sick.inc) for what
/// Player's own client programs check: `r0` at (-6.946, -6.947, 45°) on odometry started in
/// world coordinates (`localization_origin [0 0 0 0]`), with a SICK LMS200-like ranger
/// (180 rays over 180°, as sick.inc) and a lift limited to [0, 0.5] m; `r1` on odometry with
/// the default origin (its start pose). A wall stands 2.85 m east of `r0`.
pub const PIONEER_ODOM_WORLD: &str = r#"
interval_sim 100
resolution 0.02

model ( name "east_wall" pose [-4 -6.947 0 0] size [0.2 20 1] color "gray30" )

position
(
  name "r0"
  pose [-6.946 -6.947 0 45]
  size [0.44 0.38 0.22]
  origin [-0.04 0 0 0]
  drive "diff"
  localization "odom"
  localization_origin [0 0 0 0]
  odom_error [0 0 0 0]
  ranger
  (
    size [0.156 0.155 0.19]
    sensor ( range [0 8] fov 180 samples 180 pose [0 0 0.1 0] )
  )
  actuator
  (
    name "lift"
    size [0.1 0.1 0.05]
    type "linear" axis [0 0 1]
    min_position 0 max_position 0.5 max_speed 0.2
  )
)

position
(
  name "r1"
  pose [2 3 0 30]
  size [0.44 0.38 0.22]
  localization "odom"
  odom_error [0 0 0 0]
)
"#;

/// [`PIONEER_ODOM_WORLD`] and its cfg in a fresh temporary folder (removed by the caller):
/// `r0`'s base, laser and lift as position2d:0, laser:0 and actarray:0, `r1`'s base as
/// position2d:1, all on port 6665. Returns (cfg path, folder).
pub fn pioneer_odom_cfg(tag: &str) -> (PathBuf, PathBuf) {
    let dir = std::env::temp_dir().join(format!("playerstage-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("pioneer.world"), PIONEER_ODOM_WORLD).unwrap();
    let cfg = dir.join("pioneer.cfg");
    std::fs::write(
        &cfg,
        "driver( name \"stage\" provides [\"simulation:0\"] worldfile \"pioneer.world\" )\n\
         driver( name \"stage\" provides [\"position2d:0\" \"laser:0\" \"actarray:0\"] model \"r0\" )\n\
         driver( name \"stage\" provides [\"position2d:1\"] model \"r1\" )\n",
    )
    .unwrap();
    (cfg, dir)
}

/// Builds `examples/<dir>` with its Makefile into a fresh temporary folder (for the tests that
/// run libplayerc/libplayerc++ programs; they check `test_support::pkg_config_finds` first) and
/// returns the path of `program` there.
pub fn build_example(dir: &str, program: &str) -> PathBuf {
    let out =
        std::env::temp_dir().join(format!("playerstage-clients-{}-{dir}", std::process::id()));
    std::fs::create_dir_all(&out).unwrap();
    let status = Command::new("make")
        .arg("-s")
        .arg("-C")
        .arg(root().join("examples").join(dir))
        .arg(format!("OUT={}", out.display()))
        .status()
        .expect("running make");
    assert!(status.success(), "building examples/{dir}");
    out.join(program)
}

/// Runs `program` with `args`, killing it after `limit`.
pub fn run_bounded(program: &Path, args: &[String], limit: Duration) -> Output {
    let mut child = Command::new(program)
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > limit {
            let _ = child.kill();
            break;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

/// The laser configuration libplayerc's `test_laser.c` and libplayerc++'s laser test send:
/// ±90°, resolution "100", range_res "1" (Player 2's hundredths of a degree and millimetres,
/// where Player 3 reads radians and metres), intensity on.
pub fn player_2_units_laser_request() -> player_proto::LaserConfig {
    player_proto::LaserConfig {
        min_angle: (-90f32).to_radians(),
        max_angle: 90f32.to_radians(),
        resolution: 100.0,
        max_range: 0.0,
        range_res: 1.0,
        intensity: 1,
        scanning_frequency: 10.0,
    }
}

/// Fails unless an example program run by [`run_bounded`] exited successfully and printed
/// `NAME: ok` (how the C examples report that every check passed).
pub fn assert_example_ok(name: &str, out: &Output) {
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{name} failed ({:?}): {stdout}{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains(&format!("{name}: ok")), "{stdout}");
}
