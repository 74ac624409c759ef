//! The `stage` binary: runs Stage worldfiles in the world window when a display exists (the
//! simulation steps on its own thread, the window runs on the main thread), headless with `-g`
//! or without a display, or prints the resolved world as JSON with `--dump`.

use std::io::{IsTerminal, Write};
use std::path::PathBuf;
use std::time::{Duration, Instant};

use anyhow::Context;
use clap::Parser;
use stage_sim::World;
use viewer::handle::{Pacing, WindowSetup, WorldHandle, spawn_simulation};
use viewer::world_window::{self, WindowOptions};
use worldfile::{LoadOptions, WorldSpec};

/// Stage 4.1.1-compatible multi-robot simulator.
#[derive(Parser, Debug)]
#[command(name = "stage", version)]
struct Args {
    /// Headless: no window (Stage's `-g`); also the case when no display exists.
    #[arg(short = 'g', long = "gui")]
    headless: bool,
    /// Print the simulation clock (`[Stage: 0m 01s 300msec]`) every `show_clock_interval` steps.
    #[arg(short = 'c', long)]
    clock: bool,
    /// Stop at this simulated time (seconds), overriding the file's `quit_time`; 0 = never.
    #[arg(long, value_name = "SECONDS")]
    quit_time: Option<f64>,
    /// Seed for every random choice (random colours, odometry errors, controllers).
    #[arg(long, value_name = "N", default_value_t = 0)]
    seed: u64,
    /// Run as fast as possible, ignoring the file's `speedup`.
    #[arg(long)]
    fast: bool,
    /// Debug level for log output (0 = warnings, 1 = info, 2 = debug, 3+ = trace).
    #[arg(short = 'd', long, value_name = "LEVEL", default_value_t = 0)]
    debug: u8,
    /// Print the resolved world (models, properties, blocks) as JSON and exit.
    #[arg(long)]
    dump: bool,
    /// Do not print warnings (worldfile and simulator).
    #[arg(short, long)]
    quiet: bool,
    /// Save a PNG of the world window after `--screenshot-after` seconds, then quit.
    #[arg(long, value_name = "FILE.png")]
    screenshot: Option<PathBuf>,
    /// Wall seconds before `--screenshot` is taken.
    #[arg(long, value_name = "SECONDS", default_value_t = 2.0)]
    screenshot_after: f64,
    /// The worldfiles (several run in lock-step, as in Stage; the window shows the first).
    #[arg(required = true)]
    worldfiles: Vec<PathBuf>,
}

/// Stage's clock format: `[%uh]%um %02us %03umsec`, with Stage's leading space under an hour.
fn clock(us: u64) -> String {
    let text = viewer::world_window::clock_text(us);
    if us < 3_600_000_000 {
        format!(" {text}")
    } else {
        text
    }
}

fn main() -> std::process::ExitCode {
    cli::exit_status(run())
}

fn run() -> anyhow::Result<()> {
    let args = Args::parse();
    // simulator warnings (unknown controllers, legacy models) come through tracing
    let level = match (args.quiet, args.debug) {
        (true, 0) => "error",
        (_, 0) => "warn",
        (_, 1) => "info",
        (_, 2) => "debug",
        _ => "trace",
    };
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(level)),
        )
        .with_writer(std::io::stderr)
        .with_ansi(std::io::stderr().is_terminal())
        .with_target(false)
        .without_time()
        .init();

    let opts = LoadOptions::from_env();
    if args.dump {
        for f in &args.worldfiles {
            let spec = WorldSpec::load(f, &opts).map_err(|e| anyhow::anyhow!("{e}"))?;
            if !args.quiet {
                for w in &spec.warnings {
                    eprintln!("{w}");
                }
            }
            let json = serde_json::to_string_pretty(&spec).context("serialising the world")?;
            cli::print_out(&json).context("writing the world")?;
        }
        return Ok(());
    }

    let gui = !args.headless && world_window::display_available();
    if !args.headless && !gui {
        eprintln!("note: no display (DISPLAY and WAYLAND_DISPLAY unset): running headless (as -g)");
    }
    anyhow::ensure!(
        args.screenshot_after.is_finite() && args.screenshot_after >= 0.0,
        "--screenshot-after must be >= 0"
    );
    let mut banner = String::from("Stage 4.1.1 (playerstage-rs)");
    if !gui {
        banner.push_str(" [GUI disabled]");
    }
    if args.clock {
        banner.push_str(" [Clock enabled]");
    }
    let mut worlds = Vec::new();
    for f in &args.worldfiles {
        banner.push_str(&format!(" [Loading {}]", f.display()));
        let spec = WorldSpec::load(f, &opts).map_err(|e| anyhow::anyhow!("{e}"))?;
        if !args.quiet {
            for w in &spec.warnings {
                eprintln!("{w}");
            }
        }
        // what the window needs from the spec is taken first: the world is built from the
        // spec itself, which is released before the world is (peak memory of a large world)
        let setup = WindowSetup::from_spec(&spec);
        let mut world = World::from_owned_spec(spec, args.seed)
            .map_err(|e| anyhow::anyhow!("{}: {e}", f.display()))?;
        if let Some(q) = args.quit_time {
            anyhow::ensure!(q.is_finite() && q >= 0.0, "--quit-time must be >= 0");
            world.set_quit_time_us((q * 1e6) as u64);
        }
        worlds.push(WorldHandle::with_setup(world, setup));
    }
    println!("{banner}");

    // pacing: the slowest requested speed wins when several worlds run together
    let speedup = if args.fast {
        -1.0
    } else {
        worlds
            .iter()
            .map(|w| w.read().config().speedup)
            .fold(f64::INFINITY, f64::min)
    };
    if gui {
        match windowed(&args, &worlds, speedup) {
            Ok(()) => return Ok(()),
            Err(e) => eprintln!("note: cannot open the world window ({e}): running headless"),
        }
    }
    let run = headless(&args, &worlds, speedup);
    // the process ends here and its memory goes back to the system at once; dropping the
    // worlds would free a large world's allocations one by one first (a 10,000-robot swarm:
    // ~8 ms, median of 10 alternating load-only runs)
    std::mem::forget(worlds);
    run
}

/// The world window on this thread, the simulation on its own; returns when the window closes.
fn windowed(args: &Args, worlds: &[WorldHandle], speedup: f64) -> anyhow::Result<()> {
    if worlds.len() > 1 {
        eprintln!(
            "note: the window shows {}; the other worlds run alongside it",
            worlds[0].title()
        );
    }
    let clock_on = args.clock;
    let sim = spawn_simulation(worlds.to_vec(), Pacing { speedup }, move |_, w| {
        if clock_on && w.updates() % w.config().show_clock_interval == 0 {
            print!("\r[Stage: {}]", clock(w.sim_time()));
            std::io::stdout().flush().ok();
        }
    })
    .context("starting the simulation thread")?;
    let options = WindowOptions {
        screenshot: args.screenshot.clone(),
        screenshot_after: Duration::from_secs_f64(args.screenshot_after),
    };
    let shown = world_window::run(worlds[0].clone(), options);
    for w in worlds {
        w.request_quit();
    }
    sim.join()
        .map_err(|_| anyhow::anyhow!("the simulation thread panicked"))?;
    if let Some(p) = &args.screenshot {
        if shown.is_ok() {
            println!("\nscreenshot saved to {}", p.display());
        }
    }
    shown.map_err(Into::into)
}

/// Steps the worlds until all reach their `quit_time` (Stage's `-g`), on a thread of the
/// simulation's pool so that each step's parallel work is cheap to split (`stage_sim::pool`).
fn headless(args: &Args, worlds: &[WorldHandle], speedup: f64) -> anyhow::Result<()> {
    stage_sim::on_sim_threads(|| step_headless(args, worlds, speedup))
}

/// The headless loop: steps, pacing by `speedup`, clock and progress lines.
fn step_headless(args: &Args, worlds: &[WorldHandle], speedup: f64) -> anyhow::Result<()> {
    let interval = worlds[0].read().config().interval_sim_us;
    let step_wall = stage_sim::pacing::step_wall(interval, speedup);
    let quit = worlds
        .iter()
        .map(|w| w.read().config().quit_time_us)
        .max()
        .unwrap_or(0);
    let forever = worlds.iter().any(|w| w.read().config().quit_time_us == 0);
    let tty = std::io::stderr().is_terminal();
    let start = Instant::now();
    let mut last_progress = start;
    let mut steps: u64 = 0;
    let mut stdout = std::io::stdout();
    loop {
        let mut any = false;
        for h in worlds {
            // nobody else holds the lock here: this costs an uncontended lock per step
            let (stepped, line) = h.update(|w| {
                let line = (args.clock && w.updates() % w.config().show_clock_interval == 0)
                    .then(|| clock(w.sim_time()));
                (w.step(), line)
            });
            if let Some(l) = line {
                write!(stdout, "\r[Stage: {l}]")?;
                stdout.flush()?;
            }
            any |= stepped;
        }
        if !any {
            break;
        }
        steps += 1;
        if let Some(d) = step_wall {
            let due = start + d * steps as u32;
            let now = Instant::now();
            if due > now {
                std::thread::sleep(due - now);
            }
        }
        let now = Instant::now();
        let every = if tty { 1 } else { 10 };
        if now.duration_since(last_progress).as_secs() >= every && !args.quiet {
            last_progress = now;
            let t = worlds[0].read().sim_time() as f64 * 1e-6;
            let rate = t / now.duration_since(start).as_secs_f64();
            let total = if forever {
                String::new()
            } else {
                format!(
                    " / {:.1} s ({:.0}%)",
                    quit as f64 * 1e-6,
                    100.0 * t * 1e6 / quit as f64
                )
            };
            let line = format!("[progress: {t:.1} s{total}, {rate:.1}x real time]");
            if tty {
                eprint!("\r{line}");
            } else {
                eprintln!("{line}");
            }
        }
    }
    if tty && !args.quiet && start.elapsed().as_secs() >= 1 {
        eprintln!();
    }
    println!("\n[Stage: done]");
    Ok(())
}
