//! The `stage_ros2` binary: a Stage world behind the ROS 2 interface of tuw-robotics'
//! stage_ros2 node (topics, frames, parameters), over `ros2-bridge`. Parameters come as ROS 2
//! passes them (`--ros-args -p NAME:=VALUE`, `--params-file`) or as plain flags
//! (`--enforce-prefixes`, `--base-watchdog-timeout 2`); a positional world file wins over
//! `world_file`.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use anyhow::Context;
use clap::{Arg, ArgAction, ArgMatches, CommandFactory, FromArgMatches, Parser};
use ros2_bridge::params::{Kind, split_ros_args};
use ros2_bridge::{Bridge, Discovery, PARAMETERS, Params};
use stage_sim::World;
use viewer::handle::{Pacing, WindowSetup, WorldHandle, spawn_simulation};
use viewer::world_window::{self, WindowOptions};
use worldfile::{LoadOptions, WorldSpec};

/// ROS 2 node for the Stage simulator, a drop-in for stage_ros2.
#[derive(Parser, Debug)]
#[command(name = "stage_ros2", version)]
struct Args {
    /// Headless: no window (Stage's `-g`; same as `--enable-gui false`).
    #[arg(short = 'g', long = "gui")]
    headless: bool,
    /// Run as fast as possible, ignoring the world's `speedup`.
    #[arg(long)]
    fast: bool,
    /// Multiple of real time to run at, overriding the world's `speedup`.
    #[arg(long, value_name = "X")]
    speedup: Option<f64>,
    /// Seed for every random choice (odometry errors, random colours).
    #[arg(long, value_name = "N", default_value_t = 0)]
    seed: u64,
    /// Debug level for log output (0 = warnings, 1 = info, 2 = debug, 3+ = trace).
    #[arg(short = 'd', long, value_name = "LEVEL", default_value_t = 1)]
    debug: u8,
    /// The world file (wins over the `world_file` parameter).
    world: Option<PathBuf>,
}

/// The clap command: [`Args`] plus one flag per node parameter, from the parameter table.
fn command() -> clap::Command {
    let mut cmd = Args::command();
    for p in PARAMETERS {
        // clap keeps flag names as `&'static str`: the table's few names live for the run
        let flag: &'static str = Box::leak(p.name.replace('_', "-").into_boxed_str());
        let mut arg = Arg::new(p.name)
            .long(flag)
            .alias(p.name)
            .help(format!(
                "{} [ROS parameter {}, default {}]",
                p.doc, p.name, p.default
            ))
            .action(ArgAction::Set);
        arg = match p.kind {
            Kind::Bool => arg
                .value_name("BOOL")
                .num_args(0..=1)
                .default_missing_value("true"),
            Kind::Double => arg.value_name("SECONDS"),
            Kind::String => arg.value_name("VALUE"),
        };
        cmd = cmd.arg(arg);
    }
    cmd.after_help(
        "ROS 2 arguments are taken as a launch file passes them: --ros-args -p NAME:=VALUE \
         --params-file FILE -r __node:=NAME -r __ns:=/NS -r FROM:=TO [--]. ROS_DOMAIN_ID, \
         ROS_LOCALHOST_ONLY=1 and ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST are honoured.",
    )
}

fn main() -> std::process::ExitCode {
    cli::exit_status(run())
}

fn run() -> anyhow::Result<()> {
    let (ours, ros) = split_ros_args(std::env::args())?;
    let matches: ArgMatches = command().get_matches_from(ours);
    let args = Args::from_arg_matches(&matches)?;
    let level = match args.debug {
        0 => "warn",
        1 => "info",
        2 => "debug",
        _ => "trace",
    };
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| {
                // RustDDS and ros2-client narrate discovery at info and warn (every resend
                // and socket): only their errors, unless RUST_LOG asks for more
                tracing_subscriber::EnvFilter::new(format!(
                    "{level},rustdds=error,ros2_client=error"
                ))
            }),
        )
        .with_writer(std::io::stderr)
        .with_ansi(std::io::stderr().is_terminal())
        .with_target(false)
        .without_time()
        .init();

    // ROS arguments first, then plain flags, then the positional world file
    let mut params = Params::default();
    for (name, value) in &ros.parameters {
        match params.set(name, value) {
            Err(ros2_bridge::Error::UnknownParameter(n)) => {
                tracing::warn!("unknown parameter `{n}` ignored")
            }
            r => r?,
        }
    }
    for p in PARAMETERS {
        if let Some(v) = matches.get_one::<String>(p.name) {
            params.set(p.name, v)?;
        }
    }
    if let Some(w) = &args.world {
        params.world_file = w.clone();
    }
    if args.headless {
        params.enable_gui = false;
    }
    if let Some(s) = args.speedup {
        anyhow::ensure!(
            s.is_finite() && s > 0.0,
            "--speedup must be a number above 0"
        );
    }

    let file = params.world_file.clone();
    let spec = WorldSpec::load(&file, &LoadOptions::from_env())
        .map_err(|e| anyhow::anyhow!("{e}"))
        .with_context(|| format!("cannot load the world file {}", file.display()))?;
    for w in &spec.warnings {
        eprintln!("{w}");
    }
    let setup = WindowSetup::from_spec(&spec);
    let mut world = World::from_owned_spec(spec, args.seed)
        .map_err(|e| anyhow::anyhow!("{}: {e}", file.display()))?;
    let speedup = if args.fast {
        -1.0
    } else {
        args.speedup.unwrap_or(world.config().speedup)
    };
    let gui = params.enable_gui && world_window::display_available();
    if params.enable_gui && !gui {
        eprintln!("note: no display (DISPLAY and WAYLAND_DISPLAY unset): running headless (as -g)");
    }

    let discovery = Discovery::from_env()?;
    let context = discovery.context()?;
    let mut bridge = Bridge::new(&context, &mut world, params, &ros)?;
    let vehicles = bridge.vehicle_names().join(", ");
    cli::print_out(&format!(
        "stage_ros2: {} as {} on ROS domain {}{}: vehicles [{}]",
        file.display(),
        bridge.node_name(),
        discovery.domain_id,
        if discovery.localhost_only {
            " (localhost only)"
        } else {
            ""
        },
        vehicles
    ))?;
    if gui {
        return windowed(WorldHandle::with_setup(world, setup), bridge, speedup);
    }
    let quit = AtomicBool::new(false);
    let steps =
        stage_sim::on_sim_threads(|| ros2_bridge::run(&mut world, &mut bridge, speedup, &quit));
    tracing::info!("world done after {steps} steps");
    Ok(())
}

/// The bridge, shared by the simulation thread (publishing after each step) and the thread
/// applying what arrives; a panic elsewhere does not make it unusable.
fn lock(bridge: &Mutex<Bridge>) -> MutexGuard<'_, Bridge> {
    bridge
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// The world window on this thread (stage_ros2's `enable_gui`), the simulation on its own
/// publishing after each step, and a thread applying inbound messages between steps; when the
/// window cannot open, the node goes on headless.
fn windowed(handle: WorldHandle, bridge: Bridge, speedup: f64) -> anyhow::Result<()> {
    let bridge = Arc::new(Mutex::new(bridge));
    let publisher = bridge.clone();
    let sim = spawn_simulation(vec![handle.clone()], Pacing { speedup }, move |_, w| {
        lock(&publisher).publish(w)
    })
    .context("starting the simulation thread")?;
    let (h, b) = (handle.clone(), bridge.clone());
    let inbound = std::thread::Builder::new()
        .name("ros2 inbound".into())
        .spawn(move || {
            while !h.quit_requested() {
                h.update(|w| lock(&b).inbound(w));
                std::thread::sleep(Duration::from_millis(5));
            }
        })
        .context("starting the inbound thread")?;
    let options = WindowOptions {
        screenshot: None,
        screenshot_after: Duration::ZERO,
    };
    let shown = world_window::run(handle.clone(), options);
    handle.request_quit();
    sim.join()
        .map_err(|_| anyhow::anyhow!("the simulation thread panicked"))?;
    inbound
        .join()
        .map_err(|_| anyhow::anyhow!("the inbound thread panicked"))?;
    if let Err(e) = shown {
        eprintln!("note: cannot open the world window ({e}): running headless");
        let quit = AtomicBool::new(false);
        // both threads have ended: the bridge is this thread's alone again
        let mut bridge = Arc::try_unwrap(bridge)
            .map_err(|_| anyhow::anyhow!("the bridge is still shared"))?
            .into_inner()
            .unwrap_or_else(|poisoned| poisoned.into_inner());
        handle.update(|w| {
            stage_sim::on_sim_threads(|| ros2_bridge::run(w, &mut bridge, speedup, &quit))
        });
    }
    Ok(())
}
