//! Helpers of the end-to-end tests: where the workspace and the shared reference material are,
//! and servers running the `stage` driver on a cfg with its ports mapped to free ones.

#![allow(dead_code)] // each test binary uses a different subset

use std::collections::BTreeMap;
use std::net::TcpListener;
use std::path::{Path, PathBuf};

use player_server::stage::{self, StageHandle, StageOptions};
use player_server::{DriverRegistry, Pace, Server, ServerConfig, ServerHandle};
use worldfile::{CfgFile, LoadOptions};

/// The workspace root (this package's folder).
pub fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// `rel` inside the shared reference folder: `$PLAYERSTAGE_SHARED`, else `../shared` beside
/// the workspace root; `None` (after printing why) when absent, so the caller can skip.
pub fn shared(rel: &str) -> Option<PathBuf> {
    let dir = match std::env::var_os("PLAYERSTAGE_SHARED") {
        Some(d) => PathBuf::from(d),
        None => root().parent()?.join("shared"),
    };
    let path = dir.join(rel);
    if path.exists() {
        Some(path)
    } else {
        eprintln!(
            "SKIP: {} not found (set PLAYERSTAGE_SHARED to the shared folder)",
            path.display()
        );
        None
    }
}

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
    let mut registry = DriverRegistry::new();
    let stage = stage::register(
        &mut registry,
        StageOptions {
            seed: 1,
            usegui: Some(false),
        },
    );
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
