//! Loading speed, phase by phase: a worldfile text to a document (lexing, includes, macro
//! expansion), the document to a resolved [`WorldSpec`], the spec to a [`World`], and dropping
//! all three. `stage -g --fast` pays every phase before its first step, and in a 10,000-robot
//! swarm loading was a quarter of the run (issue 21).
//!
//! Worlds: a generated swarm of `swarmbot`s (hospital.world's robot: a position with a ranger
//! of 12 IR `sensor`s, all through `define`) in a walled arena with a quarter as many
//! obstacles, and, when the shared reference material is there (`PLAYERSTAGE_SHARED`),
//! Stage's `benchmark/hospital.world` (1,000 swarmbots and a bitmap floorplan).
//!
//! Run: `cargo bench -p stage-sim --bench load` (`-- --quick` for fewer repetitions; a number,
//! e.g. `-- 1000`, sets the swarm's robot count).

use std::path::Path;
use std::time::{Duration, Instant};

use stage_sim::World;
use worldfile::loader::{load_document, parse_document};
use worldfile::world::resolve;
use worldfile::{Dialect, Document, LoadOptions, WorldSpec};

/// Best and worst wall time of each phase over the repetitions.
#[derive(Default)]
struct Phases {
    document: Vec<Duration>,
    resolve: Vec<Duration>,
    build: Vec<Duration>,
    drop_world: Vec<Duration>,
    drop_spec: Vec<Duration>,
    drop_document: Vec<Duration>,
    total: Vec<Duration>,
}

impl Phases {
    fn print(&self, label: &str, models: usize) {
        let range = |d: &[Duration]| {
            let ms = |d: &Duration| d.as_secs_f64() * 1e3;
            let lo = d.iter().map(ms).fold(f64::INFINITY, f64::min);
            let hi = d.iter().map(ms).fold(0.0, f64::max);
            format!("{lo:7.1}–{hi:<7.1}")
        };
        println!("{label} ({models} models, {} runs), ms:", self.total.len());
        println!("  document      {}", range(&self.document));
        println!("  resolve       {}", range(&self.resolve));
        println!("  world         {}", range(&self.build));
        println!("  drop world    {}", range(&self.drop_world));
        println!("  drop spec     {}", range(&self.drop_spec));
        println!("  drop document {}", range(&self.drop_document));
        println!("  total         {}", range(&self.total));
    }
}

/// Times each phase of loading `runs` times; `document` makes the document afresh.
fn measure(runs: usize, document: impl Fn() -> Document, opts: &LoadOptions) -> (Phases, usize) {
    let mut phases = Phases::default();
    let mut models = 0;
    for _ in 0..runs {
        let t0 = Instant::now();
        let doc = document();
        let t1 = Instant::now();
        let spec: WorldSpec = resolve(&doc, opts).expect("the world resolves");
        let t2 = Instant::now();
        let world = World::from_spec(&spec, 1).expect("the world builds");
        let t3 = Instant::now();
        models = world.model_count();
        drop(world);
        let t4 = Instant::now();
        drop(spec);
        let t5 = Instant::now();
        drop(doc);
        let t6 = Instant::now();
        phases.document.push(t1 - t0);
        phases.resolve.push(t2 - t1);
        phases.build.push(t3 - t2);
        phases.drop_world.push(t4 - t3);
        phases.drop_spec.push(t5 - t4);
        phases.drop_document.push(t6 - t5);
        phases.total.push(t6 - t0);
    }
    (phases, models)
}

/// `n` swarmbots on a 1 m grid, `n / 4` obstacles on a 0.5 m grid between them, and the four
/// walls of the arena as blocks of one model: the shape of the generated swarm worlds issue 21
/// measures, with every robot written through the same two macros.
fn swarm_text(n: usize) -> String {
    use std::fmt::Write;
    let side = (n as f64).sqrt().ceil().max(2.0) as usize;
    let half = side as f64 / 2.0 + 0.5;
    let mut s = String::from(
        "resolution 0.02\nspeedup -1\nthreads 2\nquit_time 0.1\n\n\
         define ir sensor ( samples 1 range [0 2] fov 30 color_rgba [1 0 0 0.3] )\n\
         define swarmbot position\n(\n  size [0.100 0.100 0.100]\n  ranger\n  (\n    pose [0 0 -0.050 0]\n",
    );
    for k in 0..12 {
        // writing to a String cannot fail
        let _ = writeln!(s, "    ir( pose [0 0 0 {}] )", 30 * k);
    }
    s.push_str("  )\n  ctrl \"expand_swarm\"\n)\n\n");
    let w = 2.0 * half;
    let _ = writeln!(
        s,
        "model\n(\n  name \"arena\"\n  size [{w} {w} 0.5]\n  gui_move 0\n  color \"black\""
    );
    for (x0, y0, x1, y1) in [
        (-half, -half, half, -half + 0.05),
        (-half, half - 0.05, half, half),
        (-half, -half, -half + 0.05, half),
        (half - 0.05, -half, half, half),
    ] {
        let _ = writeln!(
            s,
            "  block( points 4 point[0] [{x0} {y0}] point[1] [{x1} {y0}] point[2] [{x1} {y1}] point[3] [{x0} {y1}] z [0 0.5] )"
        );
    }
    s.push_str(")\n");
    let cell = |i: usize| {
        (
            -(side as f64) / 2.0 + 0.5 + (i % side) as f64,
            -(side as f64) / 2.0 + 0.5 + (i / side) as f64,
        )
    };
    for i in 0..n / 4 {
        let (x, y) = cell(i * 4);
        let _ = writeln!(
            s,
            "model( name \"obstacle{i}\" pose [{:.3} {:.3} 0 {}] size [0.300 0.300 0.500] color_rgba [0.5 0.5 0.5 1] )",
            x + 0.5,
            y + 0.5,
            (i * 37) % 360
        );
    }
    for i in 0..n {
        let (x, y) = cell(i);
        let _ = writeln!(
            s,
            "swarmbot( name \"r{i}\" pose [{x:.3} {y:.3} 0 {}] color_rgba [{:.2} {:.2} 1 1] )",
            (i * 53) % 360,
            (i % 100) as f64 / 100.0,
            (i % 7) as f64 / 7.0
        );
    }
    s
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let quick = args.iter().any(|a| a == "--quick");
    let robots = args
        .iter()
        .find_map(|a| a.parse::<usize>().ok())
        .unwrap_or(10_000);
    let runs = if quick { 3 } else { 10 };
    let opts = LoadOptions::default();

    let text = swarm_text(robots);
    let path = Path::new("swarm.world");
    let (phases, models) = measure(
        runs,
        || {
            parse_document(path, text.clone().into_bytes(), Dialect::World, &opts)
                .expect("the generated swarm parses")
        },
        &opts,
    );
    phases.print(
        &format!(
            "generated swarm of {robots} swarmbots ({} lines)",
            text.lines().count()
        ),
        models,
    );

    let Some(worlds) = test_support::stage_worlds() else {
        println!(
            "skipping benchmark/hospital.world: shared reference material not found (set PLAYERSTAGE_SHARED)"
        );
        return;
    };
    let hospital = worlds.join("benchmark/hospital.world");
    let (phases, models) = measure(
        runs,
        || load_document(&hospital, Dialect::World, &opts).expect("hospital.world parses"),
        &opts,
    );
    phases.print("benchmark/hospital.world", models);
}
