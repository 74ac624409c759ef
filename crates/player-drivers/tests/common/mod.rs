//! Test helpers: servers built from cfg text the way the `player` binary builds them.

#![allow(dead_code)] // each test binary uses a different subset

use std::path::Path;

use player_server::stage::{self, StageOptions};
use player_server::{DriverRegistry, Pace, Server, ServerConfig, ServerHandle, cfg};
use worldfile::{CfgFile, LoadOptions};

/// The workspace's `worlds/` folder (Bigbob's world and its includes).
pub fn worlds() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../worlds")
}

/// Every driver the `player` binary has: stage (headless, seed 1) and this crate's.
pub fn registry() -> DriverRegistry {
    let mut registry = DriverRegistry::new();
    stage::register(
        &mut registry,
        StageOptions {
            seed: 1,
            usegui: Some(false),
        },
    );
    player_drivers::register_all(&mut registry);
    registry
}

/// A server built from `text` as if it were the cfg file `dir/name`, with `pace`; started.
/// Write ports as `0:` in the cfg to let the OS choose them.
pub fn serve_cfg(dir: &Path, name: &str, text: &str, pace: Pace) -> ServerHandle {
    let server = build_cfg(dir, name, text, pace).unwrap_or_else(|e| panic!("{e}"));
    server.start().unwrap_or_else(|e| panic!("{e}"))
}

/// A server built from cfg text, not started (`Err` is the start-up error as `player` prints
/// it).
pub fn build_cfg(dir: &Path, name: &str, text: &str, pace: Pace) -> Result<Server, String> {
    let cfgfile = CfgFile::parse(&dir.join(name), text, &LoadOptions::default())
        .map_err(|e| e.to_string())?;
    let mut registry = registry();
    let mut server = Server::new(ServerConfig {
        pace,
        ..ServerConfig::default()
    });
    for block in cfg::driver_blocks(&cfgfile, 6665).map_err(|e| e.to_string())? {
        server
            .add_block(&block, &mut registry)
            .map_err(|e| e.to_string())?;
    }
    server.resolve_requires().map_err(|e| e.to_string())?;
    Ok(server)
}

#[allow(unused_imports)] // test binaries each use a different subset
pub use test_support::stage_worlds;

/// simple.world as Player users run it with vfh.cfg: without the `wander` controller (the
/// world's comment says to drop it under Player; it would drive r0 too), and with the cave's
/// walls solid (map.inc makes floorplans pass-through), so that touching one stalls the robot.
pub fn simple_world_for_vfh(src: &Path, dir: &Path) {
    for f in ["pioneer.inc", "map.inc", "sick.inc"] {
        std::fs::copy(src.join(f), dir.join(f)).unwrap();
    }
    std::fs::create_dir_all(dir.join("bitmaps")).unwrap();
    std::fs::copy(src.join("bitmaps/cave.png"), dir.join("bitmaps/cave.png")).unwrap();
    let world = std::fs::read_to_string(src.join("simple.world")).unwrap();
    let without_ctrl: Vec<&str> = world
        .lines()
        .filter(|l| !l.trim_start().starts_with("ctrl"))
        .collect();
    assert_eq!(
        without_ctrl.len() + 1,
        world.lines().count(),
        "one ctrl line"
    );
    let cave = "bitmap \"bitmaps/cave.png\"";
    let world = without_ctrl.join("\n");
    assert!(world.contains(cave));
    let world = world.replace(cave, &format!("{cave}\n  obstacle_return 1"));
    std::fs::write(dir.join("simple.world"), world).unwrap();
}
