//! Frame-time benchmark of the world window's drawing path: a generated world of 1,000 swarm
//! robots, each carrying a 180-ray laser, with the lasers visualised, drawn offscreen at
//! 1280x720 (wgpu on whatever adapter exists: Mesa's lavapipe on a machine without a GPU).
//! Prints the scene-build time, render without and with read-back, and frames per second.
//! Run: `cargo bench -p viewer --bench frame` (`-- --robots N` for another count,
//! `--no-footprints` / `--no-bodies` to leave those out and see what they cost, `--no-cache`
//! to draw the grid and static bodies every frame instead of reusing them, `--world FILE`
//! for a worldfile instead, drawn with its `window` settings and data on, `--zoom F` to magnify
//! the whole-world view F times about its centre, `--window-view` to draw exactly the view the
//! worldfile's `window` asks for: its size, scale, centre and rotation, `--steps N` to step the
//! world N times (default 5) before measuring, e.g. until a swarm has spread out),
//! `--lasers-only` to leave the swarm robots' sonar rings out, `--fan-triangles` to draw ranger footprints as triangle fans even on a software rasteriser
//! instead of counting their coverage per pixel.

mod common;

use std::time::{Duration, Instant};

use stage_sim::generate::swarm_world;
use stage_sim::{Color, KindDesc, ModelDesc, SensorDesc, World};
use viewer::View;
use viewer::offscreen::Offscreen;
use viewer::scene::Scene;
use viewer::world_scene::{self, VisOptions, WorldGui};

/// The generated swarm world (each robot with a ring of 12 sonars) with a laser on every robot
/// (Stage's sicklaser: 180 rays over 180 degrees, 8 m); without the sonars if `lasers_only`.
fn swarm_with_lasers(robots: usize, lasers_only: bool) -> (World, WorldGui) {
    let mut desc = swarm_world(robots, 1);
    if lasers_only {
        for m in &mut desc.models {
            if let KindDesc::Ranger(sensors) = &mut m.kind {
                sensors.clear();
            }
        }
    }
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
    let world = World::from_desc(&desc, 1).expect("the generated world builds");
    (world, gui)
}

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
    let robots = common::value::<usize>(&args, "--robots").unwrap_or(1000);
    let frames = 30;
    // parts can be switched off to see where the frame time goes
    let no_footprints = args.iter().any(|a| a == "--no-footprints");
    let no_bodies = args.iter().any(|a| a == "--no-bodies");
    let no_cache = args.iter().any(|a| a == "--no-cache");
    let window_view = args.iter().any(|a| a == "--window-view");
    let lasers_only = args.iter().any(|a| a == "--lasers-only");
    let warm: u64 = common::value(&args, "--steps").unwrap_or(5);

    let world_file = common::value::<String>(&args, "--world");
    let zoom = common::value::<f64>(&args, "--zoom").unwrap_or(1.0);
    let mut file_view = None;
    let (mut world, gui, window_vis, what) = match &world_file {
        Some(f) => {
            let spec = match worldfile::WorldSpec::load(
                std::path::Path::new(f),
                &worldfile::LoadOptions::from_env(),
            ) {
                Ok(s) => s,
                Err(e) => {
                    println!("skipping the frame benchmark: {e}");
                    return;
                }
            };
            let world = World::from_spec(&spec, 1).expect("the world builds");
            file_view = spec.window.as_ref().map(View::from_window);
            let n = world.model_count();
            (
                world,
                WorldGui::from_spec(&spec),
                VisOptions::from_window(&spec.window.clone().unwrap_or_default()),
                format!("{f} ({n} models)"),
            )
        }
        None => {
            let (world, gui) = swarm_with_lasers(robots, lasers_only);
            (
                world,
                gui,
                VisOptions::default(),
                format!(
                    "{robots} robots with 180-ray lasers{}",
                    if lasers_only {
                        ""
                    } else {
                        " and 12 sonars each"
                    }
                ),
            )
        }
    };
    let vis = VisOptions {
        data: true,
        ranger_ranges: window_vis.ranger_ranges && !no_footprints,
        blocks: !no_bodies,
        ..window_vis
    };
    for m in world_scene::visualised_sensors(&world, &vis) {
        world
            .subscribe(m)
            .expect("visualised_sensors lists this world's models");
    }
    for _ in 0..warm {
        world.step();
    }

    let mut off = match Offscreen::new() {
        Ok(o) => o,
        Err(e) => {
            println!("skipping the frame benchmark: {e}");
            return;
        }
    };
    off.renderer_mut().set_layer_cache(!no_cache);
    let fan_triangles = args.iter().any(|a| a == "--fan-triangles");
    let coverage =
        !fan_triangles && viewer::render::fan_coverage_for(off.adapter_info().device_type);
    off.renderer_mut().set_fan_coverage(coverage);
    let (min, max) = world_scene::world_extent(&world);
    let mut view = View {
        size: [1280.0, 720.0],
        ..View::default()
    };
    view.fit(min, max);
    view.scale *= zoom;
    if let (true, Some(v)) = (window_view, file_view) {
        view = v;
    }
    let (w, h) = (view.size[0] as u32, view.size[1] as u32);
    println!(
        "frame benchmark: {what}, {w}x{h}, scale {:.2} px/m, yaw {:.2} rad, adapter {:?} ({:?})",
        view.scale,
        view.yaw,
        off.adapter_info().name,
        off.adapter_info().device_type
    );

    let mut scene = Scene::default();
    let (mut build, mut render, mut readback) = (Vec::new(), Vec::new(), Vec::new());
    let mut counting = Vec::new();
    for i in 0..frames + 2 {
        world.step();
        let t = Instant::now();
        world_scene::build(&world, &gui, &vis, &view, &[], &mut scene);
        let tb = t.elapsed();
        let t = Instant::now();
        off.render_only(&scene, &view).expect("render");
        let tr = t.elapsed();
        let tc = off.renderer_mut().coverage_time();
        let t = Instant::now();
        let px = off.render(&scene, &view).expect("render and read back");
        let trb = t.elapsed();
        assert_eq!((px.width, px.height), (w, h));
        if i >= 2 {
            // the first frames compile pipelines and grow buffers
            build.push(tb);
            render.push(tr);
            counting.push(tc);
            readback.push(trb);
        }
    }
    let (b, r, rb) = (
        median(&mut build),
        median(&mut render),
        median(&mut readback),
    );
    let segments: usize = scene.layers.iter().map(|l| l.segments.len()).sum();
    let triangles = scene.triangle_count();
    println!("  per frame: {segments} segments, {triangles} triangles");
    let names = ["grid", "static", "footprints", "bodies", "data", "overlay"];
    let per_layer: Vec<String> = scene
        .layers
        .iter()
        .zip(names)
        .map(|(l, n)| format!("{n} {}+{}", l.triangle_count(), l.segments.len()))
        .collect();
    println!("  triangles+segments by layer: {}", per_layer.join(", "));
    let fans: usize = scene.layers.iter().map(|l| l.fans.len()).sum();
    let fill = viewer::render::fan_fill(scene.layer(viewer::scene::Layer::Footprints), &view);
    let counted = off.renderer_mut().counted_fans();
    println!(
        "  {fans} fans covering {fill:.1} views drawn {}",
        if counted {
            "by counting their coverage per pixel on the CPU"
        } else {
            "as triangle fans"
        }
    );
    println!(
        "  scene build            {:8.2} ms (median of {frames})",
        ms(b)
    );
    println!("  render (no read-back)  {:8.2} ms", ms(r));
    if counted {
        println!(
            "    of which counting fan coverage {:8.2} ms",
            ms(median(&mut counting))
        );
    }
    println!("  render + read-back     {:8.2} ms", ms(rb));
    println!(
        "  window frame (build + render) {:8.2} ms = {:.1} frames/s",
        ms(b + r),
        1.0 / (b + r).as_secs_f64()
    );
}
