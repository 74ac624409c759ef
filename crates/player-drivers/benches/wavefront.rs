//! How long the `wavefront` planner takes on a large real map: Stage's `bitmaps/hospital.png`
//! (3117 x 1189 pixels) loaded through the `mapfile` code at 0.1 m per cell, i.e. a 312 m x
//! 119 m floor of 3.7 million cells, planned for a Pioneer-sized robot with the driver's
//! defaults.
//!
//! `cargo bench -p player-drivers --bench wavefront` prints, in milliseconds (mean and
//! fastest of the rounds, the fastest being the figure least disturbed by other work on the
//! machine):
//! - the c-space update (distance to the nearest obstacle for every cell, the work the driver
//!   does once per map, `robot_radius` 0.2 m + the default `safety_dist` 0.25 m, default
//!   `max_radius` 1 m);
//! - the plan (`Plan::plan_path`, the work of upstream's `plan_do_global`): the wavefront
//!   propagated from the goal until it reaches the start, and the path from the start
//!   followed down the costs;
//! - the waypoints extracted from that path (upstream's `plan_update_waypoints`).
//!
//! The start is at the west end of the long corridor, the goals at its east end and at the
//! top of the central wing. With `NAVBENCH_DUMP=<dir>` set, the bench also writes the grid,
//! the parameters and the waypoints it found to `<dir>` (`wavefront.txt`, `wavefront.cells`,
//! `wavefront.<goal>.waypoints`) so another implementation can be timed on identical inputs
//! and its waypoints compared.

use std::hint::black_box;
use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

use player_drivers::map::mapfile::MapFileOptions;
use player_drivers::planner::wavefront::plan::{Plan, PlanParams};

/// Half the width of a Pioneer 2-DX (m): the radius the driver derives from the geometry.
const ROBOT_RADIUS: f64 = 0.2;
/// The driver's default `safety_dist`, `max_radius` and `dist_penalty`.
const SAFETY_DIST: f64 = 0.25;
const MAX_RADIUS: f64 = 1.0;
const DIST_PENALTY: f64 = 1.0;
/// Timed repetitions of each phase.
const ROUNDS: usize = 5;

/// Where the planning starts (m): the west end of the main corridor.
const START: (f64, f64) = (-130.85, -26.15);
/// The goals (m), named.
const GOALS: [(&str, (f64, f64)); 2] = [("east", (118.15, -27.15)), ("north", (-7.85, 39.35))];

/// A bitmap of Stage's suite in the shared reference folder (`test_support`).
fn stage_bitmap(name: &str) -> PathBuf {
    // where it would be, so that the caller's read reports the path when it is absent
    test_support::shared_dir()
        .unwrap_or_else(|| test_support::workspace_root().join("../shared"))
        .join("stage-worlds/bitmaps")
        .join(name)
}

/// Mean and fastest (ms) of `ROUNDS` runs of `f`, and its last result.
fn time<T>(mut f: impl FnMut() -> T) -> (f64, f64, T) {
    let mut total = 0.0;
    let mut fastest = f64::INFINITY;
    let mut last = None;
    for _ in 0..ROUNDS {
        let t0 = Instant::now();
        let out = black_box(f());
        let dt = t0.elapsed().as_secs_f64() * 1000.0;
        total += dt;
        fastest = fastest.min(dt);
        last = Some(out);
    }
    (total / ROUNDS as f64, fastest, last.expect("ROUNDS > 0"))
}

fn main() -> std::io::Result<()> {
    let path = std::env::var_os("NAVBENCH_HOSPITAL")
        .map(PathBuf::from)
        .unwrap_or_else(|| stage_bitmap("hospital.png"));
    let options = MapFileOptions {
        filename: path.clone(),
        resolution: 0.1,
        negate: false,
        origin: None,
    };
    let grid = match options.load() {
        Ok(g) => g,
        Err(e) => {
            println!("wavefront bench skipped: {} ({e})", path.display());
            return Ok(());
        }
    };
    let (w, h) = (grid.width() as usize, grid.height() as usize);
    let scale = f64::from(grid.scale());
    let origin = (grid.origin().px, grid.origin().py);
    let params = PlanParams {
        abs_min_radius: ROBOT_RADIUS + SAFETY_DIST,
        max_radius: MAX_RADIUS,
        dist_penalty: DIST_PENALTY,
    };
    println!(
        "{}: {w} x {h} cells of {scale} m, robot radius {ROBOT_RADIUS} + safety {SAFETY_DIST} m",
        path.display()
    );
    let (mean, fastest, plan) = time(|| Plan::new(w, h, scale, origin, grid.cells(), params));
    let mut plan = plan.expect("the map's size and scale are valid");
    println!("c-space update                  {mean:>9.1} ms, fastest {fastest:.1}");

    let dump = std::env::var_os("NAVBENCH_DUMP").map(PathBuf::from);
    if let Some(dir) = &dump {
        std::fs::create_dir_all(dir)?;
        let mut f = std::fs::File::create(dir.join("wavefront.txt"))?;
        writeln!(
            f,
            "{w} {h} {scale:.17} {:.17} {:.17} {:.17} {:.17} {:.17}",
            origin.0, origin.1, params.abs_min_radius, params.max_radius, params.dist_penalty
        )?;
        writeln!(f, "{:.17} {:.17}", START.0, START.1)?;
        for (name, goal) in GOALS {
            writeln!(f, "{name} {:.17} {:.17}", goal.0, goal.1)?;
        }
        let bytes: Vec<u8> = grid.cells().iter().map(|&c| c as u8).collect();
        std::fs::write(dir.join("wavefront.cells"), bytes)?;
    }

    for (name, goal) in GOALS {
        let (mean, fastest, path) = time(|| plan.plan_path(START, goal));
        if path.is_empty() {
            println!("goal {name} {goal:?}: no path from {START:?}");
            continue;
        }
        let (wmean, wfastest, waypoints) = time(|| plan.reduce_to_waypoints(&path));
        let result = plan.plan(START, goal);
        assert_eq!(result.path, path, "plan gives the path plan_path gives");
        let length: f64 = result
            .waypoints
            .windows(2)
            .map(|p| (p[1].0 - p[0].0).hypot(p[1].1 - p[0].1))
            .sum();
        println!(
            "plan to {name:<5} (wavefront + path) {mean:>9.1} ms, fastest {fastest:.1} \
             ({} path cells)",
            path.len()
        );
        println!(
            "waypoints to {name:<5}              {wmean:>9.3} ms, fastest {wfastest:.3} \
             ({} waypoints, {length:.1} m)",
            waypoints.len()
        );
        if let Some(dir) = &dump {
            let mut f = std::fs::File::create(dir.join(format!("wavefront.{name}.waypoints")))?;
            for c in &waypoints {
                writeln!(f, "{} {}", c.0, c.1)?;
            }
        }
    }
    Ok(())
}
