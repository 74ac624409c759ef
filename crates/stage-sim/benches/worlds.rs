//! World benchmarks: steps/s, simulated seconds per wall second (× real time), rays/s and
//! threads, for Stage's own worlds (when `../shared/stage-worlds` or `PLAYERSTAGE_SHARED` is
//! there) and generated swarm worlds of 1 … 10,000 robots. Run: `cargo bench -p stage-sim`.
//! Stage 4.3 on the same 2-core machine: simple 809×, cave 15.9×, hospital 3.5× real time (the
//! issue's figures). Stage 4.3.0 built from source and run (`stage -g`, the same worlds, load
//! time subtracted, several runs) on the 2-core VM of 2026-11-25: simple 635–668×, cave
//! 33.5–40.5×, hospital 5.3–8.6×; this bench there: simple 7,700–8,800× (5,530–6,100× before
//! ray fans shared their setup), cave 185–214×, hospital 42–47×. That VM's speed drifted by
//! up to 8% within minutes: compare builds in alternating runs.
//!
//! Options: a word filters the worlds by label (`cave`, `swarm1000`); `--quick` shortens the
//! runs; `--steps N` runs exactly N steps per world after the warm-up and skips the ray
//! micro-benchmarks (for instruction counts under `valgrind --tool=callgrind`); `--digest`
//! prints each world's state digest after the run (same code and seed ⇒ same digest, so a
//! change that must not alter results can be checked with `--steps N --digest`).
//!
//! Instructions per step: `RAYON_NUM_THREADS=1 valgrind --tool=callgrind
//! --toggle-collect='stage_sim::world::step::<impl stage_sim::world::World>::step' … --steps N
//! WORLD`. On one thread a step runs its updates in order; until 2026-11-27 it split them
//! through rayon even then, and the toggled count missed a fifth (cave, hospital) to two fifths
//! (swarm1000) of the step (whole-program counts agreed), so earlier figures for those
//! worlds are low.

use stage_sim::generate::swarm_world;
use stage_sim::{RayQuery, World};
use std::time::{Duration, Instant};
use worldfile::LoadOptions;

/// How a world is run.
struct Run {
    budget: Duration,
    /// Exactly this many steps (no time budget).
    steps: Option<u64>,
    digest: bool,
}

fn measure(label: &str, mut w: World, run: &Run) {
    // warm-up: one simulated second
    for _ in 0..10 {
        w.step();
    }
    let rays0 = w.rays_cast();
    // steps on a pool thread, as `stage -g` runs them
    let (steps, secs) = stage_sim::on_sim_threads(|| {
        let t0 = Instant::now();
        let mut steps = 0u64;
        while match run.steps {
            Some(n) => steps < n,
            None => steps < 20 || t0.elapsed() < run.budget,
        } {
            if !w.step() {
                break;
            }
            steps += 1;
        }
        (steps, t0.elapsed().as_secs_f64())
    });
    let sim = steps as f64 * w.config().interval_sim_us as f64 * 1e-6;
    let rays = (w.rays_cast() - rays0) as f64;
    println!(
        "{label:<28} {:>10.0} steps/s {:>10.1}x real time {:>12.3e} rays/s  threads {}  ({} models, {} steps)",
        steps as f64 / secs,
        sim / secs,
        rays / secs,
        rayon::current_num_threads(),
        w.model_count(),
        steps
    );
    if run.digest {
        println!("{label:<28} digest {:016x}", w.state_digest());
    }
}

use test_support::stage_worlds;

/// Ray-cast micro-benchmark: `n` rays of length `range` from random points of the world's
/// bounding box, ignoring nothing but the robots' own trees (none here).
fn ray_micro(label: &str, w: &World, range: f64, n: usize) {
    let mut bb = stage_sim::geom::Aabb::EMPTY;
    for m in w.models() {
        bb.merge(&w.body(m).unwrap().aabb);
    }
    let mut rng = stage_sim::SimRng::new(3, 3);
    let queries: Vec<RayQuery> = (0..n)
        .map(|_| RayQuery {
            x: rng.uniform(bb.min[0], bb.max[0]),
            y: rng.uniform(bb.min[1], bb.max[1]),
            a: rng.uniform(-3.2, 3.2),
            range,
            z: Some(0.25),
        })
        .collect();
    let t0 = Instant::now();
    let mut hits = 0usize;
    for q in &queries {
        hits += w.raycast(q, None).unwrap().is_some() as usize;
    }
    let secs = t0.elapsed().as_secs_f64();
    println!(
        "{label:<28} {:>10.1} ns/ray (one thread, {:.0}% hit, {n} rays of {range} m)",
        secs * 1e9 / n as f64,
        100.0 * hits as f64 / n as f64
    );
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let quick = args.iter().any(|a| a == "--quick");
    let steps = args
        .iter()
        .position(|a| a == "--steps")
        .and_then(|i| args.get(i + 1)?.parse::<u64>().ok());
    let only: Option<String> = args
        .iter()
        .enumerate()
        .find(|(i, a)| {
            !a.starts_with("--") && (*i == 0 || args[i - 1] != "--steps") && a.as_str() != "--bench"
        })
        .map(|(_, a)| a.clone());
    let run = Run {
        budget: Duration::from_secs_f64(if quick { 0.5 } else { 5.0 }),
        steps,
        digest: args.iter().any(|a| a == "--digest"),
    };
    match stage_worlds() {
        Some(root) => {
            for (label, file) in [
                ("simple.world", "simple.world"),
                ("benchmark/cave.world", "benchmark/cave.world"),
                ("benchmark/hospital.world", "benchmark/hospital.world"),
            ] {
                if only.as_ref().is_some_and(|o| !label.contains(o.as_str())) {
                    continue;
                }
                let mut opts = LoadOptions::from_env();
                opts.stage_path.push(root.clone());
                let (mut w, _) = World::load_with(&root.join(file), &opts, 1).expect("suite world");
                w.set_quit_time_us(0);
                if run.steps.is_none() {
                    let n = if quick { 100_000 } else { 1_000_000 };
                    ray_micro(&format!("{label} rays"), &w, 2.0, n);
                    ray_micro(&format!("{label} rays"), &w, 8.0, n);
                }
                measure(label, w, &run);
            }
        }
        None => println!("Stage's worlds not found (set PLAYERSTAGE_SHARED): skipping them"),
    }
    for n in [1usize, 10, 100, 1000, 10_000] {
        if only.as_ref().is_some_and(|o| *o != format!("swarm{n}")) {
            continue;
        }
        let w = World::from_desc(&swarm_world(n, 1), 1).expect("generated world");
        measure(&format!("swarm {n} robots"), w, &run);
    }
}
