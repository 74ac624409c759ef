//! Benchmark of CPU fan coverage counting ([`viewer::coverage`]): 1,000 laser footprints
//! (180 rays over 180 degrees, up to 8 m) and 12,000 sonar cones (15 degrees, up to 5 m) around
//! robots packed in a 60 x 34 m arena, counted for a 1280x720 view of the whole arena, which is
//! how the world window draws them on a software rasteriser. Prints the median time per frame
//! with one thread and with all of them.
//! Run: `cargo bench -p viewer --bench coverage` (`-- --robots N` for another count).

mod common;

use std::time::{Duration, Instant};

use stage_sim::SimRng;
use viewer::View;
use viewer::coverage::{Coverage, PixelMap};

/// A fan ring: centre, then `rays` ends over `fov` from `heading`, each at `reach` but where
/// something closer blocks a run of rays (runs of 10 rays on average, as robots and walls in a
/// crowd do).
fn fan(
    rng: &mut SimRng,
    c: [f64; 2],
    heading: f64,
    fov: f64,
    rays: usize,
    reach: f64,
) -> Vec<[f32; 2]> {
    let mut ring = vec![[c[0] as f32, c[1] as f32]];
    let mut r = reach;
    for i in 0..rays {
        if rng.next_f64() < 0.1 {
            r = if rng.next_f64() < 0.5 {
                reach
            } else {
                reach * rng.next_f64()
            };
        }
        let a = heading - fov / 2.0 + fov * i as f64 / (rays - 1).max(1) as f64;
        ring.push([(c[0] + r * a.cos()) as f32, (c[1] + r * a.sin()) as f32]);
    }
    ring
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let robots = common::value(&args, "--robots").unwrap_or(1000);
    let mut rng = SimRng::new(1, 0);
    let (w, h) = (60.0, 34.0);
    let mut lasers = Vec::new();
    let mut sonars = Vec::new();
    for _ in 0..robots {
        let c = [rng.next_f64() * w - w / 2.0, rng.next_f64() * h - h / 2.0];
        let heading = rng.next_f64() * std::f64::consts::TAU;
        lasers.push(fan(&mut rng, c, heading, std::f64::consts::PI, 180, 8.0));
        for k in 0..12 {
            let a = heading + k as f64 * std::f64::consts::TAU / 12.0;
            // a cone as Stage's sonar is drawn: its arc in 8 chords
            let r = 5.0 * rng.next_f64();
            let ring: Vec<[f32; 2]> = std::iter::once([c[0] as f32, c[1] as f32])
                .chain((0..=8).map(|i| {
                    let b = a - 0.13 + 0.26 * i as f64 / 8.0;
                    [(c[0] + r * b.cos()) as f32, (c[1] + r * b.sin()) as f32]
                }))
                .collect();
            sonars.push(ring);
        }
    }
    let view = View {
        center: [0.0, 0.0],
        scale: 1280.0 / w,
        yaw: 0.0,
        size: [1280.0, 720.0],
    };
    let map = PixelMap::of(&view);
    let tables = [std::array::from_fn::<u8, 256, _>(|i| i as u8); 2];
    let all = std::thread::available_parallelism().map_or(1, |n| n.get());
    println!(
        "coverage benchmark: {} laser fans and {} sonar cones, 1280x720",
        lasers.len(),
        sonars.len()
    );
    let mut cov = Coverage::default();
    let mut out = Vec::new();
    for threads in [1, all] {
        let mut times: Vec<Duration> = (0..25)
            .map(|_| {
                let t = Instant::now();
                let rings = sonars
                    .iter()
                    .map(|r| (0, r.as_slice()))
                    .chain(lasers.iter().map(|r| (1, r.as_slice())));
                cov.count(1280, 720, &map, rings, &tables, threads, &mut out);
                t.elapsed()
            })
            .collect();
        times.sort();
        let covered = out.iter().filter(|&&v| v > 0).count();
        println!(
            "  {threads} thread(s): {:.2} ms per frame (median of 25), {covered} channel-pixels covered",
            times[times.len() / 2].as_secs_f64() * 1e3
        );
    }
}
