//! Every world of Stage's own suite loads and runs headless without error (controllers we do
//! not build in are reported as warnings, not failures).

mod common;

use stage_sim::World;
use worldfile::LoadOptions;

/// Worlds whose bitmap is not in Stage's suite at all: Stage exits on them, we refuse them with
/// an error naming the file.
const MISSING_BITMAP: &[&str] = &["large.world", "wifi_ray.world"];

fn run_suite(seconds: u64) {
    let Some(worlds) = common::suite_worlds() else {
        eprintln!("skipping: ../shared/stage-worlds not found (set PLAYERSTAGE_SHARED)");
        return;
    };
    assert!(
        worlds.len() >= 20,
        "suite looks incomplete: {}",
        worlds.len()
    );
    let root = common::shared_dir().unwrap().join("stage-worlds");
    for path in worlds {
        let t0 = std::time::Instant::now();
        let file = path.file_name().unwrap().to_string_lossy().to_string();
        // Stage's STAGEPATH: the suite root, so wifi/*.world find their includes
        let mut opts = LoadOptions::from_env();
        opts.stage_path.push(root.clone());
        let loaded = World::load_with(&path, &opts, 1);
        if MISSING_BITMAP.contains(&file.as_str()) {
            let err = loaded
                .err()
                .expect("a world whose bitmap is missing must not load");
            assert!(err.to_string().contains("bitmap"), "{file}: {err}");
            eprintln!("{file}: refused as expected: {err}");
            continue;
        }
        let (mut w, _spec) = loaded.unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let quit = seconds * 1_000_000;
        w.set_quit_time_us(quit);
        let mut steps = 0u64;
        while w.step() {
            steps += 1;
        }
        let dt = w.config().interval_sim_us;
        assert!(
            w.sim_time() >= quit && w.sim_time() < quit + dt,
            "{file}: stopped at {}",
            w.sim_time()
        );
        for m in w.models() {
            let p = w.pose(m).unwrap();
            assert!(
                p.x.is_finite() && p.y.is_finite() && p.a.is_finite(),
                "{}: model {} has a non-finite pose",
                path.display(),
                w.name(m).unwrap()
            );
        }
        eprintln!(
            "{}: {} models, {steps} steps, {} warnings, {:.2} s",
            path.display(),
            w.model_count(),
            w.warnings().len(),
            t0.elapsed().as_secs_f64()
        );
    }
}

/// The acceptance run: 60 simulated seconds of every world (about 15 s in the dev profile).
#[test]
fn every_suite_world_runs_60_simulated_seconds() {
    run_suite(60);
}

/// Same world, same seed: bit-identical state after 1,000 steps (cave.world: 100 robots with
/// `expand_pioneer`, every sonar and move in play), whatever the thread count.
#[test]
fn suite_world_runs_are_repeatable() {
    let Some(root) = common::shared_dir().map(|s| s.join("stage-worlds")) else {
        eprintln!("skipping: ../shared/stage-worlds not found (set PLAYERSTAGE_SHARED)");
        return;
    };
    let path = root.join("benchmark/cave.world");
    let run = |seed: u64, threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let (mut w, _) = World::load(&path, seed).unwrap();
            for _ in 0..1000 {
                w.step();
            }
            w.state_digest()
        })
    };
    let a = run(7, 2);
    assert_eq!(a, run(7, 2));
    assert_eq!(a, run(7, 1));
}
