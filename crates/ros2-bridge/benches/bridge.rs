//! What the bridge costs: a world of 100 diff robots, each with a 181-ray laser, stepped
//! headless as fast as possible, without the bridge and with it (every vehicle's odom,
//! ground truth, scan and transform, and /clock, published after every step). The DDS
//! participant is loopback only (`ROS_LOCALHOST_ONLY=1` semantics) in `ROS_DOMAIN_ID` or 231;
//! without subscribers RustDDS still serialises and queues every sample, so this is the
//! bridge's own cost; a subscriber adds the sending (see the README's figure).
//!
//! `cargo bench -p ros2-bridge --bench bridge [-- STEPS]`

use std::sync::atomic::AtomicBool;
use std::time::Instant;

use ros2_bridge::{Bridge, Discovery, Params, RosArgs};
use stage_sim::World;
use worldfile::{LoadOptions, WorldSpec};

/// 100 robots on a 10 x 10 grid, 2 m apart, in a walled 24 m square.
fn world_text() -> String {
    let mut w = String::new();
    w.push_str("resolution 0.02\ninterval_sim 100\n");
    for (name, x, y, sx, sy) in [
        ("north", 0.0, 12.0, 24.0, 0.1),
        ("south", 0.0, -12.0, 24.0, 0.1),
        ("east", 12.0, 0.0, 0.1, 24.0),
        ("west", -12.0, 0.0, 0.1, 24.0),
    ] {
        w.push_str(&format!(
            "model ( name \"{name}\" pose [{x} {y} 0 0] size [{sx} {sy} 0.5] )\n"
        ));
    }
    for i in 0..10 {
        for j in 0..10 {
            let (x, y) = (-9.0 + 2.0 * i as f64, -9.0 + 2.0 * j as f64);
            w.push_str(&format!(
                "position ( name \"r{}\" pose [{x} {y} 0 {}] size [0.4 0.4 0.3] drive \"diff\" \
                 ranger ( sensor ( range [0 8] fov 180 samples 181 ) size [0.1 0.1 0.1] ) )\n",
                i * 10 + j,
                (i * 37 + j * 11) % 360
            ));
        }
    }
    w
}

fn load() -> World {
    let dir = std::env::temp_dir().join(format!("ros2-bridge-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("a temporary directory");
    let path = dir.join("fleet.world");
    std::fs::write(&path, world_text()).expect("writing the world");
    let spec = WorldSpec::load(&path, &LoadOptions::default()).expect("the bench world loads");
    let _ = std::fs::remove_dir_all(&dir);
    World::from_owned_spec(spec, 1).expect("the bench world builds")
}

fn main() {
    let steps: u64 = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(600);
    let quit = AtomicBool::new(false);

    // the rangers update only when subscribed: subscribe them as the bridge does
    let mut world = load();
    let models: Vec<_> = world.models().collect();
    for m in models {
        if matches!(
            world.model_type(m),
            Ok(stage_sim::ModelType::Position | stage_sim::ModelType::Ranger)
        ) {
            world.subscribe(m).expect("a model of the world");
        }
    }
    let start = Instant::now();
    stage_sim::on_sim_threads(|| {
        for _ in 0..steps {
            world.step();
        }
    });
    let alone = start.elapsed().as_secs_f64();
    let sim = world.sim_time() as f64 * 1e-6;

    let mut world = load();
    let vars = |k: &str| match k {
        "ROS_LOCALHOST_ONLY" => Some("1".to_string()),
        "ROS_DOMAIN_ID" => Some(std::env::var(k).unwrap_or_else(|_| "231".into())),
        _ => None,
    };
    let context = Discovery::from_vars(vars)
        .and_then(|d| d.context())
        .expect("a DDS participant");
    let params = Params {
        world_file: "fleet.world".into(),
        ..Params::default()
    };
    let mut bridge =
        Bridge::new(&context, &mut world, params, &RosArgs::default()).expect("the bridge starts");
    // run() paces nothing at speedup <= 0 and stops at quit_time: set one
    world.set_quit_time_us(world.config().interval_sim_us * steps);
    let start = Instant::now();
    let taken =
        stage_sim::on_sim_threads(|| ros2_bridge::run(&mut world, &mut bridge, -1.0, &quit));
    let bridged = start.elapsed().as_secs_f64();

    println!("100 robots x 181-ray lasers, {steps} steps ({sim:.0} s simulated)");
    println!(
        "  world alone:      {:8.1} steps/s  real-time factor {:7.1}x",
        steps as f64 / alone,
        sim / alone
    );
    println!(
        "  with the bridge:  {:8.1} steps/s  real-time factor {:7.1}x  ({taken} steps)",
        taken as f64 / bridged,
        sim / bridged
    );
    println!(
        "  bridge share of the run: {:.0}%  ({:.2} ms per step publishing 100 x (odom, ground_truth, \
         base_scan, tf) + /clock)",
        100.0 * (bridged - alone) / bridged,
        (bridged - alone) / steps as f64 * 1e3
    );
}
