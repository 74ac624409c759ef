//! Real libplayerc / libplayerc++ 3.0.2 programs against our server: `examples/c/basic.c` and
//! the C++ Bigbob controller `examples/bigbob/bigbob.cc` are built with their Makefiles into a
//! temporary folder and run against the Bigbob world on a free port, and
//! `examples/c/stage_devices.c` against the Pioneer world of `common`. Skipped (with a
//! message) when `pkg-config` does not find `playerc` and `playerc++`.

mod common;

use std::time::Duration;

use common::{build_example, pioneer_odom_cfg, root, run_bounded, serve_cfg};
use player_server::Pace;

#[test]
fn libplayerc_basic_client_runs_against_our_server() {
    if !test_support::pkg_config_finds(&["playerc", "playerc++"], "the real-client tests") {
        return;
    }
    let program = build_example("c", "basic");
    let server = serve_cfg(
        &root().join("worlds/bigbob.cfg"),
        Pace::RealTime { speedup: 5.0 },
    );
    let port = server.port(6665).to_string();
    let out = run_bounded(
        &program,
        &["localhost".into(), port, "20".into()],
        Duration::from_secs(60),
    );
    let _ = std::fs::remove_dir_all(program.parent().unwrap());
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "basic failed: {stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        stdout.contains("basic: robot 1.25 x 1.00 m, 4 sonars"),
        "{stdout}"
    );
    assert!(stdout.contains("4 ranges"), "{stdout}");
    assert!(
        stdout.contains("basic: carton1 at 1.00 -2.00 0.50"),
        "{stdout}"
    );
    assert!(stdout.contains("basic: ok"), "{stdout}");
}

#[test]
fn libplayerc_plus_plus_bigbob_controller_runs_against_our_server() {
    if !test_support::pkg_config_finds(&["playerc", "playerc++"], "the real-client tests") {
        return;
    }
    let program = build_example("bigbob", "bigbob");
    let server = serve_cfg(
        &root().join("worlds/bigbob.cfg"),
        Pace::RealTime { speedup: 5.0 },
    );
    let port = server.port(6665).to_string();
    let out = run_bounded(
        &program,
        &["localhost".into(), port, "100".into()],
        Duration::from_secs(120),
    );
    let _ = std::fs::remove_dir_all(program.parent().unwrap());
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "bigbob failed: {stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        stdout.contains("bigbob: connected to localhost:"),
        "{stdout}"
    );
    // bob1 starts facing orange1: it sees blobs.
    let summary = stdout.lines().last().unwrap_or_default();
    assert!(summary.starts_with("bigbob: pose "), "{stdout}");
    assert!(!summary.contains(" 0 reads with blobs"), "{summary}");
}

/// libplayerc sees the odometry start in world coordinates, the actuator's goal clamped to its
/// limit, and a laser on the SICK-like ranger with the ranger's size that refuses libplayerc++'s
/// test configuration (Player 2 units) but takes it in radians and metres, refuses a finer
/// resolution than its rays and narrows its scan.
#[test]
fn libplayerc_stage_devices_client_checks_odometry_actuator_and_laser() {
    if !test_support::pkg_config_finds(&["playerc", "playerc++"], "the real-client tests") {
        return;
    }
    let program = build_example("c", "stage_devices");
    let (cfg, dir) = pioneer_odom_cfg("clients-stage-devices");
    let server = serve_cfg(&cfg, Pace::RealTime { speedup: 5.0 });
    let port = server.port(6665).to_string();
    let out = run_bounded(
        &program,
        &["localhost".into(), port],
        Duration::from_secs(60),
    );
    drop(server);
    let _ = std::fs::remove_dir_all(program.parent().unwrap());
    let _ = std::fs::remove_dir_all(&dir);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "stage_devices failed: {stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        stdout.contains("stage_devices: r0 odometry -6.946 -6.947 0.785398"),
        "{stdout}"
    );
    assert!(stdout.contains("speed 0.50 state 2"), "{stdout}");
    assert!(stdout.contains("size [0.156 0.155]"), "{stdout}");
    assert!(stdout.contains("stage_devices: ok"), "{stdout}");
}
