//! Measures navigation drivers on a simulated robot over Player protocol only, so the same
//! run can be made against our `player` and against the original Player 3.0.2 hosting its
//! drivers on devices of our simulation server (remote `requires`).
//!
//! Two connections: the simulation server (`--sim`: its `simulation` device for the robot's
//! true pose, its `position2d` for odometry and the simulated clock) and the server hosting the
//! drivers under test (`--nav`). Each goal is sent, then at every odometry sample the true pose
//! is read (simulation GET_POSE2D), the path length accumulated and, with `--localizer`, the
//! localiser's pose (its `position2d` output, the best hypothesis) compared with the true pose.
//! A goal is reached when the robot has stood still within `--tolerance` of it for a few
//! samples (the time to goal runs to the first of them); in planner mode the planner's `done`
//! flag at that moment is reported too.
//!
//! ```text
//! cargo run --release -p player-drivers --example nav_compare -- \
//!     --sim localhost:7000 --nav localhost:7001 --mode vfh \
//!     --goals="-3,0,90;-6,4.5,90" [--start=-6.946,-6.947,45] [--localizer 2]
//! ```
//! Goals and start are in the world (= map) frame, angles in degrees; a vfh goal is turned
//! into the odometry frame the base reports, from the odometry and true poses at the start.
//! One line per goal and a summary are printed; `--json` prints them as JSON lines instead.

use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use clap::{Parser, ValueEnum};
use player_client::{DataMode, PlannerProxy, PlayerClient, Position2dProxy, SimulationProxy};
use player_proto::Pose2d;

/// Which driver takes the goals.
#[derive(Clone, Copy, Debug, PartialEq, ValueEnum)]
enum Mode {
    /// A `position2d` driver taking position commands (vfh, nd, snd): goals in odometry frame.
    Vfh,
    /// A `planner` (wavefront): goals in the map frame.
    Planner,
}

#[derive(Parser, Debug)]
#[command(about = "time to goal, path length and localisation error of navigation drivers")]
struct Args {
    /// host:port of the simulation server (simulation:0 and the robot's odometry).
    #[arg(long)]
    sim: String,
    /// host:port of the server hosting the drivers under test.
    #[arg(long)]
    nav: String,
    /// How goals are given.
    #[arg(long, value_enum)]
    mode: Mode,
    /// Goals "x,y,deg;x,y,deg;..." in the world frame, driven one after another.
    #[arg(long)]
    goals: String,
    /// Move the robot here first (simulation SET_POSE2D), "x,y,deg".
    #[arg(long)]
    start: Option<String>,
    /// The robot's model name in the world.
    #[arg(long, default_value = "r0")]
    model: String,
    /// Index of the base's odometry position2d on the simulation server.
    #[arg(long, default_value_t = 0)]
    odometry: u16,
    /// Index of the driver's position2d (vfh mode) or planner (planner mode) on --nav.
    #[arg(long, default_value_t = 1)]
    driver: u16,
    /// Index of a localiser's position2d on --nav (amcl's best hypothesis) to compare with
    /// the true pose.
    #[arg(long)]
    localizer: Option<u16>,
    /// In vfh mode, first subscribe to this planner on --nav (and keep it, idle). Player
    /// 3.0.2 can only set up a vfh on remote devices from a driver thread (a wavefront's, as
    /// in wavefront-remote.cfg): set up by a client's subscription, its geometry request to
    /// the remote base never returns. Subscribing the planner first sets the chain up that way.
    #[arg(long)]
    hold_planner: Option<u16>,
    /// Distance (m) from the goal within which a stop counts as arrival.
    #[arg(long, default_value_t = 0.6)]
    tolerance: f64,
    /// Simulated seconds allowed per goal.
    #[arg(long, default_value_t = 180.0)]
    limit: f64,
    /// Print JSON lines.
    #[arg(long)]
    json: bool,
}

/// "x,y,deg" as a pose in radians.
fn parse_pose(text: &str) -> Result<Pose2d> {
    let v: Vec<f64> = text
        .split(',')
        .map(|s| s.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("pose {text:?}: expected x,y,deg"))?;
    let [px, py, deg] = v[..] else {
        bail!("pose {text:?}: expected x,y,deg");
    };
    Ok(Pose2d {
        px,
        py,
        pa: deg.to_radians(),
    })
}

fn connect(addr: &str) -> Result<PlayerClient> {
    let (host, port) = addr
        .rsplit_once(':')
        .with_context(|| format!("{addr:?}: expected host:port"))?;
    let port: u16 = port
        .parse()
        .with_context(|| format!("{addr:?}: bad port"))?;
    let client = PlayerClient::connect(host, port).with_context(|| format!("connect {addr}"))?;
    client.set_request_timeout(Duration::from_secs(30));
    Ok(client)
}

/// `a` composed with `b` (b given in a's frame).
fn compose(a: Pose2d, b: Pose2d) -> Pose2d {
    let (s, c) = a.pa.sin_cos();
    Pose2d {
        px: a.px + c * b.px - s * b.py,
        py: a.py + s * b.px + c * b.py,
        pa: normalize(a.pa + b.pa),
    }
}

/// The inverse transform of `a`.
fn invert(a: Pose2d) -> Pose2d {
    let (s, c) = a.pa.sin_cos();
    Pose2d {
        px: -c * a.px - s * a.py,
        py: s * a.px - c * a.py,
        pa: normalize(-a.pa),
    }
}

use pose::angle::normalize_atan2 as normalize;

/// One goal's figures.
#[derive(Debug, Default)]
struct Leg {
    reached: bool,
    sim_seconds: f64,
    wall_seconds: f64,
    path_length: f64,
    final_error: f64,
    stalls: usize,
    /// Whether the planner said it was done when the robot stopped at the goal.
    planner_done: bool,
    /// Localiser position errors (m) and heading errors (rad), one per sample.
    loc_errors: Vec<(f64, f64)>,
}

/// Position and heading error of `est` against `truth`.
fn error(est: Pose2d, truth: Pose2d) -> (f64, f64) {
    (
        (est.px - truth.px).hypot(est.py - truth.py),
        normalize(est.pa - truth.pa).abs(),
    )
}

fn mean_max(v: impl Iterator<Item = f64> + Clone) -> (f64, f64) {
    let n = v.clone().count().max(1) as f64;
    (v.clone().sum::<f64>() / n, v.fold(0.0, f64::max))
}

fn main() -> Result<()> {
    let args = Args::parse();
    let goals: Vec<Pose2d> = args
        .goals
        .split(';')
        .filter(|s| !s.trim().is_empty())
        .map(parse_pose)
        .collect::<Result<_>>()?;

    let sim_client = connect(&args.sim)?;
    let sim = SimulationProxy::new(&sim_client, 0).context("subscribe simulation:0")?;
    let odom = Position2dProxy::new(&sim_client, args.odometry).context("subscribe odometry")?;
    sim_client.set_datamode(DataMode::Push)?;

    let nav_client = connect(&args.nav)?;
    let held = args
        .hold_planner
        .map(|i| PlannerProxy::new(&nav_client, i))
        .transpose()
        .context("subscribe the held planner")?;
    if let Some(held) = &held {
        // Player 3.0.2 sets a threaded driver up on its own thread after answering the
        // subscription: wait for the planner's first data (its setup done, the vfh it
        // requires set up from that thread) before subscribing to anything else.
        let wall = Instant::now();
        while held.data().is_none() {
            if wall.elapsed() > Duration::from_secs(120) {
                bail!("the held planner sent no data for 120 s");
            }
            nav_client.read()?;
        }
    }
    let (drive, planner) = match args.mode {
        Mode::Vfh => (
            Some(Position2dProxy::new(&nav_client, args.driver).context("subscribe driver")?),
            None,
        ),
        Mode::Planner => (
            None,
            Some(PlannerProxy::new(&nav_client, args.driver).context("subscribe planner")?),
        ),
    };
    let localizer = args
        .localizer
        .map(|i| Position2dProxy::new(&nav_client, i))
        .transpose()
        .context("subscribe localiser")?;
    nav_client.set_datamode(DataMode::Pull)?;
    let banner = nav_client.banner();

    // The next odometry sample: (sim time, odometry state).
    let next_sample = || -> Result<(f64, player_proto::Position2dDataState)> {
        let wall = Instant::now();
        loop {
            sim_client.read()?;
            if odom.is_fresh() {
                odom.not_fresh();
                if let Some(s) = odom.state() {
                    return Ok((odom.datatime(), s));
                }
            }
            if wall.elapsed() > Duration::from_secs(20) {
                bail!("no odometry from {} for 20 s", args.sim);
            }
        }
    };

    if let Some(start) = &args.start {
        let p = parse_pose(start)?;
        sim.set_pose2d(&args.model, p.px, p.py, p.pa)?;
    }
    // Let the drivers see a few scans before the first goal.
    for _ in 0..10 {
        next_sample()?;
    }
    let (_, s0) = next_sample()?;
    let true0 = sim.get_pose2d(&args.model)?;
    // world = odom_to_world ∘ odometry.
    let odom_to_world = compose(true0, invert(s0.pos));
    let world_to_odom = invert(odom_to_world);

    let mut legs = Vec::new();
    for goal in &goals {
        match (&drive, &planner) {
            (Some(d), _) => {
                let g = compose(world_to_odom, *goal);
                d.go_to(g.px, g.py, g.pa)?;
            }
            (_, Some(p)) => p.set_goal(goal.px, goal.py, goal.pa)?,
            _ => unreachable!("one of the two is set by the mode"),
        }
        let (t_start, _) = next_sample()?;
        let wall = Instant::now();
        let mut leg = Leg::default();
        let mut last = sim.get_pose2d(&args.model)?;
        let mut still = 0;
        let mut arrived_at = None;
        loop {
            let (t, s) = next_sample()?;
            let truth = sim.get_pose2d(&args.model)?;
            leg.path_length += (truth.px - last.px).hypot(truth.py - last.py);
            last = truth;
            if s.stall != 0 {
                leg.stalls += 1;
            }
            nav_client.read()?;
            if let Some(estimate) = localizer.as_ref().and_then(|l| l.state()) {
                leg.loc_errors.push(error(estimate.pos, truth));
            }
            let off = (truth.px - goal.px).hypot(truth.py - goal.py);
            let stopped = s.vel.px == 0.0 && s.vel.py == 0.0 && s.vel.pa == 0.0;
            let planner_done = planner
                .as_ref()
                .is_some_and(|p| p.data().is_some_and(|d| d.done != 0));
            if off < args.tolerance && stopped {
                leg.planner_done = planner_done;
                let first = *arrived_at.get_or_insert((t, wall.elapsed().as_secs_f64()));
                still += 1;
                if still >= 5 {
                    leg.reached = off < args.tolerance;
                    leg.sim_seconds = first.0 - t_start;
                    leg.wall_seconds = first.1;
                    leg.final_error = off;
                    break;
                }
            } else {
                still = 0;
                arrived_at = None;
            }
            if t - t_start > args.limit {
                leg.sim_seconds = t - t_start;
                leg.wall_seconds = wall.elapsed().as_secs_f64();
                leg.final_error = off;
                break;
            }
        }
        report_leg(&args, &banner, goal, &leg);
        legs.push(leg);
    }
    let reached = legs.iter().filter(|l| l.reached).count();
    let sim_total: f64 = legs.iter().map(|l| l.sim_seconds).sum();
    let length_total: f64 = legs.iter().map(|l| l.path_length).sum();
    let all_errors: Vec<(f64, f64)> = legs.iter().flat_map(|l| l.loc_errors.clone()).collect();
    let (loc_mean, loc_max) = mean_max(all_errors.iter().map(|e| e.0));
    let (head_mean, head_max) = mean_max(all_errors.iter().map(|e| e.1.to_degrees()));
    if args.json {
        println!(
            "{{\"summary\":true,\"nav\":{:?},\"mode\":\"{:?}\",\"goals\":{},\"reached\":{reached},\
             \"sim_s\":{sim_total:.2},\"path_m\":{length_total:.3},\"loc_mean_m\":{loc_mean:.4},\
             \"loc_max_m\":{loc_max:.4},\"head_mean_deg\":{head_mean:.3},\"head_max_deg\":{head_max:.3}}}",
            args.nav,
            args.mode,
            goals.len()
        );
    } else {
        println!(
            "TOTAL {:?} on {} ({banner}): {reached}/{} goals, {sim_total:.1} sim s, {length_total:.2} m{}",
            args.mode,
            args.nav,
            goals.len(),
            if all_errors.is_empty() {
                String::new()
            } else {
                format!(
                    ", localisation error mean {loc_mean:.3} m max {loc_max:.3} m, heading mean \
                     {head_mean:.2} max {head_max:.2} deg ({} samples)",
                    all_errors.len()
                )
            }
        );
    }
    Ok(())
}

fn report_leg(args: &Args, banner: &str, goal: &Pose2d, leg: &Leg) {
    let (loc_mean, loc_max) = mean_max(leg.loc_errors.iter().map(|e| e.0));
    if args.json {
        println!(
            "{{\"nav\":{:?},\"goal\":[{:.3},{:.3},{:.1}],\"reached\":{},\"sim_s\":{:.2},\
             \"wall_s\":{:.2},\"path_m\":{:.3},\"final_error_m\":{:.3},\"stalls\":{},\"planner_done\":{},\
             \"loc_mean_m\":{loc_mean:.4},\"loc_max_m\":{loc_max:.4}}}",
            args.nav,
            goal.px,
            goal.py,
            goal.pa.to_degrees(),
            leg.reached,
            leg.sim_seconds,
            leg.wall_seconds,
            leg.path_length,
            leg.final_error,
            leg.stalls,
            leg.planner_done
        );
    } else {
        println!(
            "goal ({:.2}, {:.2}, {:.0} deg) via {banner}: {} in {:.1} sim s ({:.1} wall s), \
             path {:.2} m, stopped {:.2} m off, {} stalled samples{}{}",
            goal.px,
            goal.py,
            goal.pa.to_degrees(),
            if leg.reached {
                "reached"
            } else {
                "NOT reached"
            },
            leg.sim_seconds,
            leg.wall_seconds,
            leg.path_length,
            leg.final_error,
            leg.stalls,
            if args.mode == Mode::Planner && leg.reached {
                format!(", planner done {}", leg.planner_done)
            } else {
                String::new()
            },
            if leg.loc_errors.is_empty() {
                String::new()
            } else {
                format!(", localisation error mean {loc_mean:.3} m max {loc_max:.3} m")
            }
        );
    }
}
