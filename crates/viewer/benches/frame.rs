//! Frame-time benchmark of the world window's drawing path: a generated world of 1,000 swarm
//! robots, each carrying a 180-ray laser, with the lasers visualised, drawn offscreen at
//! 1280x720 (wgpu on whatever adapter exists: Mesa's lavapipe on a machine without a GPU).
//! Prints the scene-build time, render without and with read-back, and frames per second.
//! Run: `cargo bench -p viewer --bench frame` (`-- --robots N` for another count).

use std::time::{Duration, Instant};

use stage_sim::generate::swarm_world;
use stage_sim::{Color, KindDesc, ModelDesc, SensorDesc, World};
use viewer::View;
use viewer::offscreen::Offscreen;
use viewer::scene::Scene;
use viewer::world_scene::{self, VisOptions, WorldGui};

/// Median of `samples` (sorted in place).
fn median(samples: &mut [Duration]) -> Duration {
    samples.sort();
    samples[samples.len() / 2]
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let robots = args
        .iter()
        .position(|a| a == "--robots")
        .and_then(|i| args.get(i + 1)?.parse::<usize>().ok())
        .unwrap_or(1000);
    let frames = 30;

    // the swarm world, with a laser on every robot (Stage's sicklaser: 180 rays over 180°)
    let mut desc = swarm_world(robots, 1);
    let bots: Vec<usize> = (0..desc.models.len())
        .filter(|&i| matches!(desc.models[i].kind, KindDesc::Position(_)))
        .collect();
    for (n, &b) in bots.iter().enumerate() {
        let laser = SensorDesc {
            range: [0.0, 8.0],
            fov: std::f64::consts::PI,
            samples: 180,
            color: Color::rgb(0.0, 0.0, 1.0),
            ..SensorDesc::default()
        };
        let mut m = ModelDesc::new(&format!("laser{n}"), KindDesc::Ranger(vec![laser]));
        m.size = [0.05, 0.05, 0.05];
        desc.add(m, Some(b));
    }
    let gui = WorldGui::from_desc(&desc);
    let mut world = World::from_desc(&desc, 1).expect("the generated world builds");
    let vis = VisOptions {
        data: true,
        ..VisOptions::default()
    };
    for m in world_scene::visualised_sensors(&world, &vis) {
        world.subscribe(m);
    }
    for _ in 0..5 {
        world.step();
    }

    let mut off = match Offscreen::new() {
        Ok(o) => o,
        Err(e) => {
            println!("skipping the frame benchmark: {e}");
            return;
        }
    };
    let (min, max) = world_scene::world_extent(&world);
    let mut view = View {
        size: [1280.0, 720.0],
        ..View::default()
    };
    view.fit(min, max);
    println!(
        "frame benchmark: {robots} robots with 180-ray lasers, 1280x720, adapter {:?} ({:?})",
        off.adapter_info().name,
        off.adapter_info().device_type
    );

    let mut scene = Scene::default();
    let (mut build, mut render, mut readback) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..frames + 2 {
        world.step();
        let t = Instant::now();
        world_scene::build(&world, &gui, &vis, &view, &[], &mut scene);
        let tb = t.elapsed();
        let t = Instant::now();
        off.render_only(&scene, &view).expect("render");
        let tr = t.elapsed();
        let t = Instant::now();
        let px = off.render(&scene, &view).expect("render and read back");
        let trb = t.elapsed();
        assert_eq!((px.width, px.height), (1280, 720));
        if i >= 2 {
            // the first frames compile pipelines and grow buffers
            build.push(tb);
            render.push(tr);
            readback.push(trb);
        }
    }
    let (b, r, rb) = (
        median(&mut build),
        median(&mut render),
        median(&mut readback),
    );
    let segments: usize = scene.layers.iter().map(|l| l.segments.len()).sum();
    let triangles: usize = scene.layers.iter().map(|l| l.triangles.len() / 3).sum();
    println!("  per frame: {segments} segments, {triangles} triangles");
    println!(
        "  scene build            {:8.2} ms (median of {frames})",
        ms(b)
    );
    println!("  render (no read-back)  {:8.2} ms", ms(r));
    println!("  render + read-back     {:8.2} ms", ms(rb));
    println!(
        "  window frame (build + render) {:8.2} ms = {:.1} frames/s",
        ms(b + r),
        1.0 / (b + r).as_secs_f64()
    );
}
