//! Frame time of playerv on a navigation stack: a 1,000 x 1,000-cell map (50 m at 5 cm, rooms
//! with doorways and scattered furniture), a planner's path of 60 waypoints, a localiser's
//! hypothesis and its 5,000 particles, drawn offscreen at 1280x720 (wgpu on whatever adapter
//! exists: Mesa's lavapipe on a machine without a GPU).
//!
//! Prints, for the map alone and with the particles, the scene-build time and the render time
//! (median of 30 frames), first frame included separately (it builds the map's runs into the
//! cached static layer). Run: `cargo bench -p viewer --bench playerv_nav`.

use std::sync::Arc;
use std::time::{Duration, Instant};

use viewer::View;
use viewer::offscreen::Offscreen;
use viewer::playerv::scene::build;
use viewer::playerv::state::{
    DeviceData, DeviceKey, Hypothesis, MapGrid, PlannerView, PlayervState, Pose2, Subscribed,
};
use viewer::scene::Scene;

const CELLS: u32 = 1000;
const SCALE: f64 = 0.05;

/// Rooms of 5 m with 1 m doorways, and a box of furniture in most rooms.
fn map() -> MapGrid {
    let mut cells = vec![-1i8; (CELLS * CELLS) as usize];
    let mut seed = 12345u64;
    let mut rnd = move || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 33) as u32
    };
    for j in 0..CELLS {
        for i in 0..CELLS {
            let (ri, rj) = (i % 100, j % 100);
            let wall_x = ri < 2 && !(45..55).contains(&rj);
            let wall_y = rj < 2 && !(45..55).contains(&ri);
            if wall_x || wall_y || i >= CELLS - 2 || j >= CELLS - 2 {
                cells[(i + j * CELLS) as usize] = 100;
            }
        }
    }
    for room in 0..100 {
        if rnd() % 4 == 0 {
            continue;
        }
        let (ox, oy) = ((room % 10) * 100, (room / 10) * 100);
        let (x0, y0) = (ox + 10 + rnd() % 60, oy + 10 + rnd() % 60);
        let (w, h) = (5 + rnd() % 20, 5 + rnd() % 20);
        for j in y0..y0 + h {
            for i in x0..x0 + w {
                cells[(i + j * CELLS) as usize] = if rnd() % 10 == 0 { 0 } else { 100 };
            }
        }
    }
    MapGrid::new(CELLS, CELLS, SCALE, [-25.0, -25.0], &cells).expect("sized")
}

fn state(particles: usize) -> PlayervState {
    let mut st = PlayervState::new("bench:6665", player_client::DataMode::Push, 10.0);
    let sub = |data| Subscribed {
        driver: "bench".into(),
        data,
        datatime: 1.0,
    };
    let robot = Pose2 {
        x: -20.0,
        y: -20.0,
        a: 0.7,
    };
    st.subscribed.insert(
        DeviceKey::parse("map:0").unwrap(),
        sub(DeviceData::Map(Arc::new(map()))),
    );
    let waypoints: Vec<[f64; 2]> = (0..60)
        .map(|k| {
            let t = f64::from(k) / 59.0;
            [-20.0 + 40.0 * t, -20.0 + 40.0 * t * t]
        })
        .collect();
    st.subscribed.insert(
        DeviceKey::parse("planner:0").unwrap(),
        sub(DeviceData::Planner(PlannerView {
            valid: true,
            done: false,
            pos: robot,
            goal: Pose2 {
                x: 20.0,
                y: 20.0,
                a: 0.0,
            },
            waypoint: Pose2 {
                x: waypoints[1][0],
                y: waypoints[1][1],
                a: 0.0,
            },
            waypoint_idx: 1,
            waypoints,
        })),
    );
    let mut seed = 7u64;
    let mut unit = move || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    st.subscribed.insert(
        DeviceKey::parse("localize:0").unwrap(),
        sub(DeviceData::Localize {
            hypotheses: vec![Hypothesis {
                mean: robot,
                cov: [0.3, 0.2, 0.05],
                weight: 1.0,
            }],
            particles: (0..particles)
                .map(|_| {
                    (
                        Pose2 {
                            x: robot.x + 4.0 * unit(),
                            y: robot.y + 4.0 * unit(),
                            a: unit(),
                        },
                        1.0 / particles as f64,
                    )
                })
                .collect(),
        }),
    );
    st
}

fn median(v: &mut [Duration]) -> Duration {
    v.sort();
    v[v.len() / 2]
}

fn main() {
    let mut gpu = match Offscreen::new() {
        Ok(g) => g,
        Err(e) => {
            println!("skipping the playerv frame benchmark: no adapter ({e})");
            return;
        }
    };
    println!("adapter: {}", gpu.adapter_info().name);
    let mut view = View {
        center: [0.0, 0.0],
        scale: 1.0,
        yaw: 0.0,
        size: [1280.0, 720.0],
    };
    view.fit([-25.0, -25.0], [25.0, 25.0]);
    for particles in [0, 5000] {
        let st = state(particles);
        let runs = match &st.subscribed[&DeviceKey::parse("map:0").unwrap()].data {
            DeviceData::Map(m) => m.runs.len(),
            _ => 0,
        };
        let mut scene = Scene::default();
        let t = Instant::now();
        build(&st, None, &view, &mut scene);
        gpu.render_only(&scene, &view).expect("render");
        let first = t.elapsed();
        let (mut builds, mut renders) = (Vec::new(), Vec::new());
        for _ in 0..30 {
            let t = Instant::now();
            build(&st, None, &view, &mut scene);
            builds.push(t.elapsed());
            let t = Instant::now();
            gpu.render_only(&scene, &view).expect("render");
            renders.push(t.elapsed());
        }
        let (b, r) = (median(&mut builds), median(&mut renders));
        println!(
            "1000x1000 map ({runs} runs), {particles} particles: first frame {:.1} ms; then build {:.2} ms + render {:.2} ms = {:.1} fps",
            first.as_secs_f64() * 1e3,
            b.as_secs_f64() * 1e3,
            r.as_secs_f64() * 1e3,
            1.0 / (b + r).as_secs_f64()
        );
    }
}
