//! Parsing speed: models per second for the largest world of Stage's suite and for a generated
//! world of 10,000 models. Run with `cargo bench -p worldfile --bench parse`.

use std::path::Path;
use std::time::{Duration, Instant};

use worldfile::loader::parse_document;
use worldfile::{Dialect, LoadOptions, WorldSpec};

use test_support::shared_dir;

/// Runs `f` until at least `budget` has passed (and at least 3 times); returns the best time.
fn best_of(budget: Duration, mut f: impl FnMut() -> usize) -> (Duration, usize) {
    let start = Instant::now();
    let mut best = Duration::MAX;
    let mut runs = 0;
    let mut models = 0;
    while runs < 3 || start.elapsed() < budget {
        let t = Instant::now();
        models = f();
        best = best.min(t.elapsed());
        runs += 1;
    }
    (best, models)
}

fn report(label: &str, unit: &str, (time, count): (Duration, usize)) {
    let per_sec = count as f64 / time.as_secs_f64();
    println!(
        "{label}: {count} {unit} in {:.2} ms = {:.0} {unit}/s",
        time.as_secs_f64() * 1e3,
        per_sec
    );
}

fn generated_world(n: usize) -> String {
    let mut s = String::from(
        "resolution 0.02\n\
         define sonar sensor ( size [0.01 0.05 0.01] range [0 5] fov 15 samples 1 )\n\
         define ring ranger ( sonar ( pose [0.1 0 0 0] ) sonar ( pose [0 0.1 0 90] ) sonar ( pose [-0.1 0 0 180] ) sonar ( pose [0 -0.1 0 -90] ) )\n\
         define bot position (\n  size [0.3 0.3 0.2]\n  drive \"diff\"\n  block ( points 4 point[0] [0 0] point[1] [1 0] point[2] [1 1] point[3] [0 1] z [0 1] )\n  ring ( )\n)\n",
    );
    // Each `bot` is 2 models (position + ranger); n/2 bots give n models.
    for i in 0..n / 2 {
        s.push_str(&format!(
            "bot ( name \"b{i}\" pose [ {} {} 0 {} ] color \"red\" )\n",
            i % 100,
            i / 100,
            i % 360
        ));
    }
    s
}

fn main() {
    let opts = LoadOptions::default();
    let budget = Duration::from_secs(3);

    let text = generated_world(10_000);
    let path = Path::new("generated.world");
    report(
        "generated world, parse + resolve",
        "models",
        best_of(budget, || {
            WorldSpec::parse(path, &text, &opts).unwrap().models.len()
        }),
    );
    report(
        "generated world, parse only (document level)",
        "entities",
        best_of(budget, || {
            parse_document(path, text.clone().into_bytes(), Dialect::World, &opts)
                .unwrap()
                .entities
                .len()
        }),
    );

    let Some(shared) = shared_dir() else {
        println!(
            "skipping the suite world: shared reference material not found (set PLAYERSTAGE_SHARED)"
        );
        return;
    };
    let hospital = shared.join("stage-worlds/benchmark/hospital.world");
    if !hospital.is_file() {
        println!("skipping the suite world: {} not found", hospital.display());
        return;
    }
    report(
        "benchmark/hospital.world (largest suite world, bitmap included), load + resolve",
        "models",
        best_of(budget, || {
            WorldSpec::load(&hospital, &opts).unwrap().models.len()
        }),
    );
}
