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
