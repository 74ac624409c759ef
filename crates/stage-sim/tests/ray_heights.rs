//! Which heights a ranger's rays see, against Stage 4.1.1's rules (`ModelRanger::Sensor::Update`,
//! `Model::GetGlobalPose`, `Block::Map`, `World::Raytrace`):
//!
//! - a ray starts at the ranger's global height (its parent's height plus, parents stacking
//!   their children, the parent's size z) and origin z, plus the transducer's pose z and half
//!   its size z;
//! - a block's heights are its `z` range scaled by the model's size z over the tallest block
//!   top of the model, raised by the model's global height and origin z;
//! - a block stops the ray when the ray's height lies in its range, both bounds included.
//!
//! And the Player/Stage manual's `bigbob7.world` (Ch5.2), where those rules make the "env"
//! laser see the juice cartons: on every update here, on every other one in Stage 4.1.1 (its
//! two-layer map holds blocks read from `block` entities in one layer until the model is
//! moved: README, differences from the original).

use stage_sim::World;
use std::path::Path;

fn world_of(text: &str) -> World {
    let opts = worldfile::LoadOptions::default();
    let spec = worldfile::WorldSpec::parse(Path::new("heights.world"), text, &opts)
        .expect("the test world parses");
    World::from_spec(&spec, 1).expect("the test world builds")
}

/// The ranges of the first update of ranger `name`, transducer by transducer.
fn first_scans(w: &mut World, name: &str) -> Vec<Vec<f64>> {
    let r = w.model_by_name(name).expect("the ranger exists");
    w.subscribe(r).unwrap();
    w.step();
    let data = w.ranger_scans(r).unwrap();
    (0..data.sensors.len())
        .map(|k| data.scan(k).unwrap().ranges.to_vec())
        .collect()
}

/// Models of one unit-square block each, of different `z` spans (before scaling).
const SLABS: &str = r#"
define slab model
(
  block ( points 4 point[0] [0 0] point[1] [1 0] point[2] [1 1] point[3] [0 1] z [0 1] )
  color "gray"
)
define low_slab model
(
  block ( points 4 point[0] [0 0] point[1] [1 0] point[2] [1 1] point[3] [0 1] z [0 0.25] )
)
define high_slab model
(
  block ( points 4 point[0] [0 0] point[1] [1 0] point[2] [1 1] point[3] [0 1] z [0.51 1] )
)
define from_half model
(
  block ( points 4 point[0] [0 0] point[1] [1 0] point[2] [1 1] point[3] [0 1] z [0.5 1] )
)
define lifted model
(
  block ( points 4 point[0] [0 0] point[1] [1 0] point[2] [1 1] point[3] [0 1] z [0.3 0.5] )
)
"#;

/// A robot 1 m tall whose transducers sit 0.75 m below its top and are 0.5 m tall: every ray
/// starts at exactly 1 - 0.75 + 0.25 = 0.5 m. One transducer looks along each axis.
const ROBOT: &str = r#"
define probe sensor ( size [0.1 0.1 0.5] range [0 8] fov 0 samples 1 )
position
(
  name "bot"
  size [0.2 0.2 1]
  ranger
  (
    probe( pose [0 0 -0.75 0] )
    probe( pose [0 0 -0.75 90] )
    probe( pose [0 0 -0.75 180] )
    probe( pose [0 0 -0.75 270] )
  )
)
"#;

#[test]
fn a_ray_sees_a_block_whose_heights_hold_its_own_bounds_included() {
    let text = format!(
        "{SLABS}{ROBOT}
# along +x: under the ray (0 to 0.49), over it (0.51 to 1), starting at its height (0.5 to 1)
low_slab ( name \"under\" pose [1.0 0 0 0] size [0.1 1 0.49] )
high_slab ( name \"over\" pose [2.0 0 0 0] size [0.1 1 1] )
from_half ( name \"floor_at_ray\" pose [3.0 0 0 0] size [0.1 1 1] )
# along +y: ending at its height (0 to 0.5)
slab ( name \"top_at_ray\" pose [0 2.0 0 0] size [1 0.1 0.5] )
"
    );
    let mut w = world_of(&text);
    let spans = |w: &World, name: &str, want: [f64; 2]| {
        let b = &w.body(w.model_by_name(name).unwrap()).unwrap().blocks[0];
        assert!(
            (b.zmin - want[0]).abs() < 1e-12 && (b.zmax - want[1]).abs() < 1e-12,
            "{name}: {} to {}",
            b.zmin,
            b.zmax
        );
    };
    spans(&w, "under", [0.0, 0.49]);
    spans(&w, "over", [0.51, 1.0]);
    spans(&w, "floor_at_ray", [0.5, 1.0]);
    spans(&w, "top_at_ray", [0.0, 0.5]);
    let scans = first_scans(&mut w, "bot.ranger:0");
    assert!((scans[0][0] - 2.95).abs() < 1e-9, "+x saw {}", scans[0][0]);
    assert!((scans[1][0] - 1.95).abs() < 1e-9, "+y saw {}", scans[1][0]);
}

#[test]
fn block_heights_scale_by_the_model_size_over_its_tallest_block() {
    let text = format!(
        "{SLABS}{ROBOT}
# along -x: z [0.3 0.5] of a model 2 m tall is 1.2 to 2 m, above the ray (unscaled it would be
# hit); a full-height wall behind it
lifted ( name \"lifted\" pose [-2.0 0 0 0] size [0.1 1 2] )
slab ( name \"back\" pose [-4.0 0 0 0] size [0.1 1 1] )
# along -y: z [0 0.25] of a model 1 m tall is 0 to 1 m (unscaled the ray would pass over it)
low_slab ( name \"stretched\" pose [0 -2.0 0 0] size [1 0.1 1] )
# a model 1.2 m tall of a unit block, as the manual's cartons, on a 0.5 m base
define two_high model
(
  block ( points 4 point[0] [0 0] point[1] [1 0] point[2] [1 1] point[3] [0 1] z [0 0.5] )
  block ( points 4 point[0] [0 0] point[1] [1 0] point[2] [1 1] point[3] [0 1] z [0.25 1] )
)
two_high ( name \"pair\" pose [5 5 0.5 0] size [0.1 0.2 1.2] )
"
    );
    let mut w = world_of(&text);
    let pair = w.body(w.model_by_name("pair").unwrap()).unwrap();
    let spans: Vec<[f64; 2]> = pair.blocks.iter().map(|b| [b.zmin, b.zmax]).collect();
    // scale 1.2 / 1 (the taller block's top), raised by the model's 0.5 m
    let expect = [[0.5, 0.5 + 0.6], [0.5 + 0.3, 0.5 + 1.2]];
    for (got, want) in spans.iter().zip(expect) {
        assert!(
            (got[0] - want[0]).abs() < 1e-12 && (got[1] - want[1]).abs() < 1e-12,
            "{spans:?}"
        );
    }
    let scans = first_scans(&mut w, "bot.ranger:0");
    assert!((scans[2][0] - 3.95).abs() < 1e-9, "-x saw {}", scans[2][0]);
    assert!((scans[3][0] - 1.95).abs() < 1e-9, "-y saw {}", scans[3][0]);
}

/// The manual's Ch5.2 `bigbob7.world` as far as the env laser is concerned: bob1, its env
/// laser (the manual's `bigbobs_env_laser_unit`), four oranges and four cartons. The oranges
/// are octagons (as in `worlds/bigbob.inc`) rather than the manual's `circle.png` bitmap.
const BIGBOB7: &str = r#"
define bigbobs_env_laser sensor ( size [0.025 0.025 0.025] range [0.25 8] fov 180 samples 180 )
define bigbobs_env_laser_unit ranger ( bigbobs_env_laser( pose [ 0.5 0 -0.975 0 ] ) )
define bigbob position
(
  size [1.25 1 1]
  origin [0.125 0 0 0]
  block ( points 6 point[5] [0 0] point[4] [0 1] point[3] [0.75 1] point[2] [1 0.75]
          point[1] [1 0.25] point[0] [0.75 0] z [0 1] )
  block ( points 4 point[3] [1 0.75] point[2] [1.25 0.75] point[1] [1.25 0.625] point[0] [1 0.625] z [0 0.5] )
  block ( points 4 point[3] [1 0.375] point[2] [1.25 0.375] point[1] [1.25 0.25] point[0] [1 0.25] z [0 0.5] )
  drive "diff"
  bigbobs_env_laser_unit( )
)
bigbob ( name "bob1" pose [ 0 -2.6 0 -128 ] color "green" )
define orange model
(
  block ( points 8 point[0] [0.3 0] point[1] [0.7 0] point[2] [1 0.3] point[3] [1 0.7]
          point[4] [0.7 1] point[5] [0.3 1] point[6] [0 0.7] point[7] [0 0.3] z [0 1] )
  size [0.150 0.150 1.150]
  color "orange"
  ranger_return 1
)
define carton model
(
  block ( points 4 point[0] [1 0] point[1] [1 1] point[2] [0 1] point[3] [0 0] z [0 1] )
  size [0.100 0.200 1.200]
  color "DarkBlue"
)
orange( name "orange1" pose [-1 -5 0 0] )
orange( name "orange2" pose [-2.000 -5.000 0 0] )
orange( name "orange3" pose [-3.000 -5.000 0 0] )
orange( name "orange4" pose [-4.000 -5.000 0 0] )
carton( name "carton1" pose [-2 -4 0 0] )
carton( name "carton2" pose [-2.000 -3.000 0 0] )
carton( name "carton3" pose [-2.000 -2.000 0 0] )
carton( name "carton4" pose [-2.000 -1.000 0 0] )
"#;

/// Where a ray from `o` along `d` (unit) first crosses the closed polygon `poly`, if at all.
fn first_crossing(o: [f64; 2], d: [f64; 2], poly: &[[f64; 2]]) -> Option<f64> {
    let mut best: Option<f64> = None;
    for (i, p) in poly.iter().enumerate() {
        let q = poly[(i + 1) % poly.len()];
        let e = [q[0] - p[0], q[1] - p[1]];
        let den = d[0] * e[1] - d[1] * e[0];
        if den.abs() < 1e-15 {
            continue;
        }
        let w = [p[0] - o[0], p[1] - o[1]];
        let t = (w[0] * e[1] - w[1] * e[0]) / den;
        let s = (w[0] * d[1] - w[1] * d[0]) / den;
        if t >= 0.0 && (0.0..=1.0).contains(&s) {
            best = Some(best.map_or(t, |b: f64| b.min(t)));
        }
    }
    best
}

#[test]
fn the_manual_bigbob7_env_laser_sees_the_cartons_on_every_update() {
    // The rules, applied by hand. The ray's height: bob1's top (its size z; the ranger stacks
    // on it at pose z 0), the transducer's pose z, half its size z.
    let ray_z = 1.0 + -0.975 + 0.025 / 2.0;
    // A block `z [0 1]` of a model of size z `h` spans 0..h: the cartons 0..1.2, the oranges
    // 0..1.15; both hold the ray's 0.0375 m.
    let seen = |h: f64| (0.0..=h).contains(&ray_z);
    assert!(seen(1.2) && seen(1.15));
    // The footprints: a block over the unit square scaled to the model's size x and y, centred
    // on its pose.
    let carton = |cx: f64, cy: f64| {
        vec![
            [cx - 0.05, cy - 0.1],
            [cx + 0.05, cy - 0.1],
            [cx + 0.05, cy + 0.1],
            [cx - 0.05, cy + 0.1],
        ]
    };
    let octagon = [
        [0.3, 0.0],
        [0.7, 0.0],
        [1.0, 0.3],
        [1.0, 0.7],
        [0.7, 1.0],
        [0.3, 1.0],
        [0.0, 0.7],
        [0.0, 0.3],
    ];
    let orange = |cx: f64, cy: f64| -> Vec<[f64; 2]> {
        octagon
            .iter()
            .map(|p| [cx + (p[0] - 0.5) * 0.15, cy + (p[1] - 0.5) * 0.15])
            .collect()
    };
    let cartons: Vec<_> = (1..=4).map(|i| carton(-2.0, -5.0 + i as f64)).collect();
    let oranges: Vec<_> = (1..=4).map(|i| orange(-(i as f64), -5.0)).collect();
    // The laser: bob1's pose (a child is placed from its parent's pose, not from its origin),
    // then the transducer 0.5 m ahead; 180 rays over 180°, first and last at the edges.
    let a0 = (-128f64).to_radians();
    let o = [0.5 * a0.cos(), -2.6 + 0.5 * a0.sin()];
    let mut expected = Vec::new();
    let mut carton_beams = Vec::new();
    for i in 0..180 {
        let a = a0 - std::f64::consts::FRAC_PI_2 + i as f64 * std::f64::consts::PI / 179.0;
        let d = [a.cos(), a.sin()];
        let near = |polys: &[Vec<[f64; 2]>]| {
            polys
                .iter()
                .filter_map(|p| first_crossing(o, d, p))
                .fold(f64::INFINITY, f64::min)
        };
        let (c, r) = (near(&cartons), near(&oranges));
        if c < r && c <= 8.0 {
            carton_beams.push(i);
        }
        expected.push(c.min(r).min(8.0));
    }
    assert!(
        !carton_beams.is_empty(),
        "the cartons are in the laser's view"
    );

    let mut w = world_of(BIGBOB7);
    let laser = w.model_by_name("bob1.ranger:0").unwrap();
    w.subscribe(laser).unwrap();
    for update in 0..4 {
        w.step();
        let ranges = w.ranger_scans(laser).unwrap().scan(0).unwrap().ranges;
        assert_eq!(ranges.len(), 180);
        for (i, (&got, &want)) in ranges.iter().zip(&expected).enumerate() {
            assert!(
                (got - want).abs() < 1e-9,
                "update {update}, beam {i}: {got} against {want}"
            );
        }
        let hits = ranges.iter().filter(|&&r| r < 8.0).count();
        let on_cartons = carton_beams.iter().filter(|&&i| ranges[i] < 8.0).count();
        eprintln!("update {update}: {hits} of 180 beams hit, {on_cartons} of them on the cartons");
        assert_eq!(on_cartons, carton_beams.len());
    }
    // Nothing here moved the cartons: they are static, and seen all the same.
    assert!(w.is_static(w.model_by_name("carton1").unwrap()).unwrap());
}
