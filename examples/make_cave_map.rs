//! Generates `bitmaps/bigbob_cave.png`, the cave the Bigbob world is set in: a deterministic
//! cellular-automaton cave (fixed seed) with open rooms carved around the places
//! `worlds/bigbob.world` puts robots and things, joined by tunnels so that every orange can be
//! reached.
//!
//! `cargo run --example make_cave_map [OUTPUT.png]` (default `bitmaps/bigbob_cave.png`). Black
//! pixels are rock (Stage fills dark pixels), white is floor.

use std::path::PathBuf;

/// Pixels per side; the world stretches the image over [`MAP_METRES`].
const SIDE: usize = 128;
/// The floorplan's size in `worlds/bigbob.world`.
const MAP_METRES: f64 = 16.0;
/// The generator's seed: another seed, another cave (and the world must be checked again).
const SEED: u64 = 20_091_964;
/// Share of rock in the initial noise.
const ROCK_SHARE: f64 = 0.52;
/// Smoothing rounds of the automaton.
const ROUNDS: usize = 5;
/// Radius (m) of the room carved around each place.
const ROOM_RADIUS: f64 = 1.5;
/// Half width (m) of the tunnels joining the rooms.
const TUNNEL_HALF_WIDTH: f64 = 0.8;

/// Places (world metres, origin in the middle) that must be open floor, in tunnel order: the
/// robots and the things of `worlds/bigbob.world`.
const PLACES: &[(f64, f64)] = &[
    (-5.0, -5.0), // bob1
    (-3.0, -3.5), // orange1
    (-1.0, -5.5), // orange2
    (1.5, -3.0),  // carton1
    (5.0, -5.0),  // bob2
    (5.0, -1.0),  // orange3
    (3.0, 2.0),   // carton2
    (5.0, 5.0),   // orange4
    (0.5, 5.0),   // orange5
    (-3.0, 2.5),  // carton3
    (-5.5, 5.5),  // orange6
    (-5.0, 0.0),  // carton4
    (-5.0, -5.0), // back to bob1: a loop
];

/// splitmix64: a tiny, well-mixed deterministic generator (no dependency needed).
struct SplitMix(u64);

impl SplitMix {
    fn next_f64(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// The cave as rows of cells, `true` = rock; row 0 is the top of the image (north).
fn cave() -> Vec<Vec<bool>> {
    let mut rng = SplitMix(SEED);
    let border = |x: usize, y: usize| x < 2 || y < 2 || x >= SIDE - 2 || y >= SIDE - 2;
    let mut rock: Vec<Vec<bool>> = (0..SIDE)
        .map(|y| {
            (0..SIDE)
                .map(|x| border(x, y) || rng.next_f64() < ROCK_SHARE)
                .collect()
        })
        .collect();
    for _ in 0..ROUNDS {
        let prev = rock.clone();
        for (y, row) in rock.iter_mut().enumerate() {
            for (x, cell) in row.iter_mut().enumerate() {
                if border(x, y) {
                    continue;
                }
                let walls = (y - 1..=y + 1)
                    .flat_map(|yy| (x - 1..=x + 1).map(move |xx| (xx, yy)))
                    .filter(|&(xx, yy)| (xx, yy) != (x, y) && prev[yy][xx])
                    .count();
                *cell = walls >= 5 || (walls >= 4 && prev[y][x]);
            }
        }
    }
    let metres_per_px = MAP_METRES / SIDE as f64;
    let centre = |x: usize, y: usize| {
        (
            (x as f64 + 0.5) * metres_per_px - MAP_METRES / 2.0,
            MAP_METRES / 2.0 - (y as f64 + 0.5) * metres_per_px,
        )
    };
    for (y, row) in rock.iter_mut().enumerate() {
        for (x, cell) in row.iter_mut().enumerate() {
            if border(x, y) {
                continue;
            }
            let p = centre(x, y);
            let in_room = PLACES
                .iter()
                .any(|q| (p.0 - q.0).hypot(p.1 - q.1) <= ROOM_RADIUS);
            let in_tunnel = PLACES
                .windows(2)
                .any(|w| segment_distance(p, w[0], w[1]) <= TUNNEL_HALF_WIDTH);
            if in_room || in_tunnel {
                *cell = false;
            }
        }
    }
    rock
}

/// Distance from `p` to the segment `a`–`b`.
fn segment_distance(p: (f64, f64), a: (f64, f64), b: (f64, f64)) -> f64 {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let len2 = dx * dx + dy * dy;
    let t = if len2 > 0.0 {
        (((p.0 - a.0) * dx + (p.1 - a.1) * dy) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p.0 - a.0 - t * dx).hypot(p.1 - a.1 - t * dy)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args_os()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("bitmaps/bigbob_cave.png"));
    let rock = cave();
    let img = image::GrayImage::from_fn(SIDE as u32, SIDE as u32, |x, y| {
        image::Luma([if rock[y as usize][x as usize] { 0 } else { 255 }])
    });
    img.save(&out)?;
    let share = rock.iter().flatten().filter(|&&r| r).count() as f64 / (SIDE * SIDE) as f64;
    println!(
        "{}: {SIDE}x{SIDE} px, {:.0}% rock",
        out.display(),
        share * 100.0
    );
    Ok(())
}
