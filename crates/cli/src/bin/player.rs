//! The `player` binary: `player [-p port] [-q] [-d level] [-l logfile] [FILE.cfg]`, Player
//! 3.0.2's command line. Loads the cfg, builds every driver block (`stage` and `testdriver`),
//! listens on every port a device names and serves until SIGINT/SIGTERM. Without a cfg it
//! serves the built-in Bigbob world (`worlds/bigbob.cfg`, embedded). `player --check FILE.cfg`
//! builds the server the same way, with the same drivers, but binds no port and runs nothing:
//! it reports what the configuration creates and every problem in it. `player FILE.cfg --ros2`
//! also serves the stage world as the `stage_ros2` node does (`ros2-bridge`), so Player clients
//! and ROS 2 nodes drive one simulation.

use std::fs::OpenOptions;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use anyhow::{Context, bail};
use clap::Parser;
use player_proto::constants::PLAYERTCP_DEFAULT_PORT;
use player_server::stage::{self, StageHandle, StageOptions, StepHook};
use player_server::test_driver::{TEST_DRIVER_NAME, TestDriver};
use player_server::{DriverRegistry, Pace, Server, ServerConfig, ServerError};
use ros2_bridge::params::split_ros_args;
use ros2_bridge::{Bridge, Discovery, Params, RosArgs};
use stage_sim::World;
use tracing_subscriber::EnvFilter;
use viewer::handle::WorldHandle;
use viewer::world_window::{self, WindowOptions};
use worldfile::{CfgFile, LoadOptions};

/// Player 3.0.2-compatible robot server.
///
/// The simulation keeps real time (times `--speedup`) whether Stage's window is open or not.
/// Player 3.0.2 with Stage 4.1.1 paces it only in its window (a step every `interval_sim` /
/// `speedup`, the worldfile's, which this server does not read); with `usegui 0` it steps the
/// world once per pass of Player's main loop, which waits at most 10 ms for client traffic,
/// so batch clients finish sooner there. Give `--fast` for that.
#[derive(Parser, Debug)]
#[command(name = "player", version)]
struct Args {
    /// Build the server from the cfg as start-up does, without listening or running: report
    /// the drivers, devices, model bindings, ports and every problem, and exit (status 1 if the
    /// server would refuse the configuration).
    #[arg(long)]
    check: bool,
    /// Print the check report as JSON.
    #[arg(long, requires = "check")]
    json: bool,
    /// Default port for addresses without one.
    #[arg(short = 'p', long = "port", default_value_t = PLAYERTCP_DEFAULT_PORT)]
    port: u16,
    /// Quiet start-up: no banner, no cfg warnings.
    #[arg(short, long)]
    quiet: bool,
    /// Debug message level: 0 errors only, 1 (default) also warnings and client connections,
    /// 2 debugging detail, 3 and up everything.
    #[arg(short = 'd', long = "debug", default_value_t = 1)]
    debug: u8,
    /// Append log messages to this file instead of printing them.
    #[arg(short = 'l', long = "logfile")]
    logfile: Option<PathBuf>,
    /// Step drivers (the simulation) as fast as they compute instead of in real time, and
    /// replay `readlog` logs without waiting between messages: what a cfg with `usegui 0`
    /// gets from Player/Stage, which does not pace its simulation headless.
    #[arg(long, conflicts_with = "speedup")]
    fast: bool,
    /// Record every device the cfg provides (that Player's log format covers) to this log
    /// file, as a `writelog` block would, without editing the cfg (an addition to Player's
    /// flags). A name ending in `.gz` is written gzip-compressed.
    #[arg(long, value_name = "FILE")]
    record: Option<PathBuf>,
    /// Run the simulation this many times faster than real time.
    #[arg(long, value_name = "FACTOR")]
    speedup: Option<f64>,
    /// Seed of the simulation's random choices (runs are repeatable for a given seed).
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Never open Stage's world window, even when the worldfile asks for it and a display
    /// exists (an addition to Player's flags, like Stage's `-g`).
    #[arg(short = 'g', long = "no-gui")]
    no_gui: bool,
    /// Also serve the stage world to ROS 2 as the `stage_ros2` node does (its topics, frames,
    /// services and parameters, given after `--ros-args`; ROS_DOMAIN_ID and
    /// ROS_LOCALHOST_ONLY as there), stepped with the server: Player clients and ROS 2 nodes
    /// drive one simulation (an addition to Player's flags).
    #[arg(long)]
    ros2: bool,
    /// The configuration file; without one, the built-in Bigbob world (`worlds/bigbob.cfg`).
    cfgfile: Option<PathBuf>,
}

/// The Bigbob world, built into the binary so that `player` alone has something to serve.
const BUILTIN_WORLD: [(&str, &[u8]); 4] = [
    (
        "worlds/bigbob.cfg",
        include_bytes!("../../../../worlds/bigbob.cfg"),
    ),
    (
        "worlds/bigbob.world",
        include_bytes!("../../../../worlds/bigbob.world"),
    ),
    (
        "worlds/bigbob.inc",
        include_bytes!("../../../../worlds/bigbob.inc"),
    ),
    (
        "bitmaps/bigbob_cave.png",
        include_bytes!("../../../../bitmaps/bigbob_cave.png"),
    ),
];

/// Writes the built-in world into a fresh directory (the loaders read files) and returns the
/// cfg's path; the directory is removed when the guard drops.
fn unpack_builtin_world() -> anyhow::Result<(PathBuf, TempDir)> {
    let dir = std::env::temp_dir().join(format!("playerstage-bigbob-{}", std::process::id()));
    let guard = TempDir(dir.clone());
    for (rel, bytes) in BUILTIN_WORLD {
        let path = dir.join(rel);
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent)
                .with_context(|| format!("creating {}", parent.display()))?;
        }
        std::fs::write(&path, bytes).with_context(|| format!("writing {}", path.display()))?;
    }
    Ok((dir.join(BUILTIN_WORLD[0].0), guard))
}

/// A directory removed on drop.
struct TempDir(PathBuf);

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn init_logging(args: &Args) -> anyhow::Result<()> {
    let level = match args.debug {
        0 => "error",
        1 => "info",
        2 => "debug",
        _ => "trace",
    };
    // RustDDS and ros2-client (`--ros2`) narrate discovery at info and warn: only their errors,
    // unless RUST_LOG asks for more
    let filter = EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| EnvFilter::new(format!("{level},rustdds=error,ros2_client=error")));
    let builder = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_target(false);
    match &args.logfile {
        Some(path) => {
            let file = OpenOptions::new()
                .create(true)
                .append(true)
                .open(path)
                .with_context(|| format!("opening log file {}", path.display()))?;
            builder
                .with_ansi(false)
                .with_writer(Mutex::new(file))
                .init();
        }
        None => builder
            .with_ansi(std::io::stderr().is_terminal())
            .with_writer(std::io::stderr)
            .init(),
    }
    Ok(())
}

fn run_check(args: &Args, cfgfile: &Path) -> anyhow::Result<()> {
    let opts = LoadOptions::from_env();
    let cfg = CfgFile::load(cfgfile, &opts).map_err(|e| anyhow::anyhow!("{e}"))?;
    let (mut registry, stage) = registry(args);
    let report = player_server::check::check(&cfg, args.port, &mut registry, &stage);
    if !args.quiet {
        for w in &report.warnings {
            eprintln!("{w}");
        }
    }
    if args.json {
        let json = serde_json::to_string_pretty(&report).context("serialising the report")?;
        cli::print_out(&json).context("writing the report")?;
    } else {
        cli::print_out(&report.to_string()).context("writing the report")?;
    }
    if !report.problems.is_empty() {
        bail!(
            "{} problem(s): the server would refuse this configuration",
            report.problems.len()
        );
    }
    Ok(())
}

/// The drivers this binary can build, by cfg name, and the stage driver's handle on its world.
fn registry(args: &Args) -> (DriverRegistry, StageHandle) {
    let mut registry = DriverRegistry::new();
    TestDriver::register(&mut registry, TEST_DRIVER_NAME);
    player_drivers::register_all(&mut registry);
    let stage = stage::register(
        &mut registry,
        StageOptions {
            seed: args.seed,
            usegui: None,
        },
    );
    (registry, stage)
}

/// The ROS 2 node of `--ros2`, stepped by the stage driver: inbound messages before each step,
/// publications after it. The DDS context outlives the node built on it.
struct Ros2Hook<C> {
    bridge: Bridge,
    _context: C,
}

impl<C> StepHook for Ros2Hook<C> {
    fn before_step(&mut self, world: &mut World) {
        self.bridge.inbound(world);
    }

    fn after_step(&mut self, world: &World) {
        self.bridge.publish(world);
    }
}

/// Builds the `stage_ros2` node on the stage world of this server (parameters from
/// `--ros-args`; `world_file` and `enable_gui` have no say: the cfg names the world) and hooks
/// it to the world's steps. Any failure is a start-up error.
fn attach_ros2(stage: &StageHandle, ros: &RosArgs) -> anyhow::Result<()> {
    let world = stage.world().ok_or_else(|| {
        anyhow::anyhow!(
            "--ros2: the cfg runs no Stage world (a `stage` driver block providing `simulation`)"
        )
    })?;
    let mut params = Params::default();
    for (name, value) in &ros.parameters {
        match name.as_str() {
            "world_file" | "enable_gui" => {
                tracing::warn!("--ros2: parameter `{name}` ignored: the cfg sets up the world")
            }
            _ => match params.set(name, value) {
                Err(ros2_bridge::Error::UnknownParameter(n)) => {
                    tracing::warn!("--ros2: unknown parameter `{n}` ignored")
                }
                r => r.context("--ros2")?,
            },
        }
    }
    let discovery = Discovery::from_env().context("--ros2")?;
    let context = discovery.context().context("--ros2")?;
    let bridge = {
        let mut w = world.write().unwrap_or_else(|e| e.into_inner());
        Bridge::new(&context, &mut w, params, ros).context("--ros2")?
    };
    println!(
        "ROS 2: node {} on domain {}{}: vehicles [{}]",
        bridge.node_name(),
        discovery.domain_id,
        if discovery.localhost_only {
            " (localhost only)"
        } else {
            ""
        },
        bridge.vehicle_names().join(", ")
    );
    stage.set_step_hook(Box::new(Ros2Hook {
        bridge,
        _context: context,
    }));
    Ok(())
}

fn serve(args: &Args, ros: &RosArgs, cfgfile: &Path) -> anyhow::Result<()> {
    init_logging(args)?;
    eprintln!(
        "Player v.3.0.2 (playerstage-rs {})",
        env!("CARGO_PKG_VERSION")
    );
    let cfgname = cfgfile.display();
    let opts = LoadOptions::from_env();
    let cfg = CfgFile::load(cfgfile, &opts)
        .map_err(|e| anyhow::anyhow!("failed to load config file {cfgname}: {e}"))?;
    if !args.quiet {
        for w in &cfg.warnings {
            eprintln!("{w}");
        }
    }
    let pace = match (args.fast, args.speedup) {
        (true, _) => Pace::AsFastAsPossible,
        (false, Some(f)) if f > 0.0 && f.is_finite() => Pace::RealTime { speedup: f },
        (false, Some(f)) => bail!("--speedup must be a positive number, not {f}"),
        (false, None) => Pace::default(),
    };
    let mut server = Server::new(ServerConfig {
        pace,
        ..ServerConfig::default()
    });
    let (mut registry, stage_handle) = registry(args);
    let mut blocks = player_server::cfg::driver_blocks(&cfg, args.port)
        .map_err(|e| anyhow::anyhow!("failed to parse config file {cfgname} driver blocks: {e}"))?;
    if args.fast {
        player_drivers::shell::readlog::replay_fast(&mut blocks);
    }
    if let Some(file) = &args.record {
        match player_drivers::shell::writelog::recording_block(&blocks, file, args.port) {
            Some(block) => {
                println!(
                    "Recording {} devices to {}",
                    block.requires.len(),
                    file.display()
                );
                blocks.push(block);
            }
            None => bail!("--record: {cfgname} provides no device Player's log format covers"),
        }
    }
    for block in &blocks {
        server
            .add_block(block, &mut registry)
            .map_err(|e| match e {
                // The driver says what is wrong (a world file that cannot be read, a bad option),
                // with its place in the cfg: nothing failed to parse.
                ServerError::DriverFailed { .. } => anyhow::anyhow!("{e}"),
                _ => anyhow::anyhow!("failed to parse config file {cfgname} driver blocks: {e}"),
            })?;
    }
    if server.table().is_empty() {
        bail!("No devices read in configuration file {cfgname}. Is it correct?");
    }
    if args.ros2 {
        attach_ros2(&stage_handle, ros)?;
    }
    let handle = server
        .start()
        .map_err(|e| anyhow::anyhow!("failed to start: {e}"))?;
    let ports: Vec<String> = handle.ports().iter().map(u16::to_string).collect();
    println!("Listening on ports: {}", ports.join(" "));
    handle.stop_on_signals();
    if stage_handle.gui_requested() && !args.no_gui {
        world_window(&handle, &stage_handle);
    }
    handle.stop_on_signals();
    handle.wait();
    println!("Quitting.");
    handle.shutdown();
    Ok(())
}

/// Stage's world window on the main thread while the server runs on its own threads (as
/// Player/Stage shows it when the worldfile asks for the GUI and a display exists). Closing the
/// window stops the server; a stopped server (SIGINT) closes the window. Without a display, or
/// when the window cannot open, the server simply goes on headless.
fn world_window(server: &player_server::ServerHandle, stage: &StageHandle) {
    let (Some(world), Some(spec)) = (stage.world(), stage.world_spec()) else {
        return;
    };
    if !world_window::display_available() {
        tracing::info!("no display: running headless");
        return;
    }
    let shared = WorldHandle::from_shared(world, &spec, stage.paused());
    // The localisers this server runs (amcl, ...): the window shows their beliefs beside the
    // true poses, read as any client reads them.
    let localizers: Vec<player_proto::DeviceAddr> = server
        .table()
        .devices()
        .iter()
        .filter(|d| {
            d.addr.interf == player_proto::InterfaceCode::LOCALIZE
                && d.driver_name != player_server::REMOTE_DRIVER_NAME
        })
        .map(|d| d.addr)
        .collect();
    std::thread::scope(|scope| {
        if !localizers.is_empty() {
            let shared = shared.clone();
            scope.spawn(move || feed_estimates(&shared, &localizers));
        }
        // the window closes when the server stops (signal) and the server stops when it closes
        scope.spawn(|| {
            server.wait();
            shared.request_quit();
        });
        if let Err(e) = world_window::run(shared.clone(), WindowOptions::default()) {
            eprintln!("note: cannot open the world window ({e}): running headless");
            // keep serving: the watcher ends with the server (SIGINT)
            return;
        }
        server.stop();
    });
}

/// Reads the localisers' hypotheses over TCP (one client per port, PUSH) and hands the best
/// of each to the world window until the window closes or the server goes away.
fn feed_estimates(window: &WorldHandle, localizers: &[player_proto::DeviceAddr]) {
    use player_client::{DataMode, LocalizeProxy, PlayerClient};
    let mut ports: Vec<u16> = localizers.iter().map(|a| a.robot as u16).collect();
    ports.sort_unstable();
    ports.dedup();
    let mut links = Vec::new();
    for port in ports {
        let Ok(client) = PlayerClient::connect("127.0.0.1", port) else {
            tracing::warn!("world window: cannot read the localisers on port {port}");
            continue;
        };
        client.set_read_timeout(Some(std::time::Duration::from_millis(200)));
        if client.set_datamode(DataMode::Push).is_err() {
            continue;
        }
        let proxies: Vec<(String, LocalizeProxy)> = localizers
            .iter()
            .filter(|a| a.robot as u16 == port)
            .filter_map(|a| {
                let p = LocalizeProxy::new(&client, a.index).ok()?;
                Some((
                    format!("{port}:localize:{} ({})", a.index, p.driver_name()),
                    p,
                ))
            })
            .collect();
        links.push((client, proxies));
    }
    while !window.quit_requested() && !links.is_empty() {
        links.retain(|(client, _)| {
            !matches!(
                client.read(),
                Err(player_client::ClientError::Closed | player_client::ClientError::Io(_))
            )
        });
        let estimates = links
            .iter()
            .flat_map(|(_, proxies)| proxies.iter())
            .filter_map(|(label, p)| {
                let h = p.best()?;
                Some(viewer::handle::Estimate {
                    label: label.clone(),
                    pose: [h.mean.px, h.mean.py, h.mean.pa],
                    cov: h.cov,
                })
            })
            .collect();
        window.set_estimates(estimates);
    }
}

fn main() -> std::process::ExitCode {
    cli::exit_status(run())
}

fn run() -> anyhow::Result<()> {
    // `--ros-args ... [--]` sections are the ROS 2 node's (as a launch file passes them)
    let (ours, ros) = split_ros_args(std::env::args())?;
    let args = Args::parse_from(ours);
    if ros != RosArgs::default() && !args.ros2 {
        bail!("--ros-args configures the ROS 2 node: give --ros2 too");
    }
    let (cfgfile, _unpacked) = match &args.cfgfile {
        Some(path) => (path.clone(), None),
        None => {
            let (path, guard) = unpack_builtin_world()?;
            if !args.quiet && !args.check {
                eprintln!(
                    "No cfg file given: serving the built-in Bigbob world (worlds/bigbob.cfg)"
                );
            }
            (path, Some(guard))
        }
    };
    if args.check {
        run_check(&args, &cfgfile)
    } else {
        serve(&args, &ros, &cfgfile)
    }
}
