//! Generated worlds for benchmarks and scaling tests: `n` swarm robots (hospital.world's
//! `swarmbot`: 0.1 m, 12 IR rangers of 2 m, `expand_swarm`) spread over a walled arena with
//! obstacles, at a constant density so the work per robot does not change with `n`.

use crate::desc::{BlockDesc, Color, KindDesc, ModelDesc, PositionDesc, SensorDesc, WorldDesc};
use crate::pose::Pose;
use crate::rng::SimRng;

/// A world of `n` swarm robots (about 1 m² of floor each) in a square walled arena.
pub fn swarm_world(n: usize, seed: u64) -> WorldDesc {
    let mut d = WorldDesc::default();
    d.config.name = format!("swarm{n}");
    d.config.speedup = -1.0;
    let side = ((n as f64).sqrt().ceil() * 1.0).max(2.0);
    let half = side / 2.0 + 0.5;
    // arena walls as one static floorplan-like model with four blocks
    let mut arena = ModelDesc::new("arena", KindDesc::Model);
    arena.size = [2.0 * half, 2.0 * half, 0.5];
    arena.color = Color::rgb(0.0, 0.0, 0.0);
    let (t, w) = (0.05, 2.0 * half);
    arena.default_body = false;
    arena.blocks = vec![
        BlockDesc::rect(-half, -half, w, t, 0.5),
        BlockDesc::rect(-half, half - t, w, t, 0.5),
        BlockDesc::rect(-half, -half, t, w, 0.5),
        BlockDesc::rect(half - t, -half, t, w, 0.5),
    ];
    d.add(arena, None);
    let mut rng = SimRng::new(seed, u64::MAX);
    // one small obstacle per 4 robots
    for i in 0..n / 4 {
        let mut o = ModelDesc::new(&format!("obstacle{i}"), KindDesc::Model);
        o.size = [0.3, 0.3, 0.5];
        o.pose = Pose::new(
            rng.uniform(-half + 0.5, half - 0.5),
            rng.uniform(-half + 0.5, half - 0.5),
            0.0,
            rng.uniform(-3.0, 3.0),
        );
        o.color = Color::rgb(0.5, 0.5, 0.5);
        d.add(o, None);
    }
    let per_row = side as usize;
    for i in 0..n {
        let mut r = ModelDesc::new(
            &format!("r{i}"),
            KindDesc::Position(PositionDesc::default()),
        );
        r.size = [0.1, 0.1, 0.1];
        let (gx, gy) = ((i % per_row) as f64, (i / per_row) as f64);
        r.pose = Pose::new(
            -side / 2.0 + 0.5 + gx,
            -side / 2.0 + 0.5 + gy,
            0.0,
            rng.uniform(-3.0, 3.0),
        );
        r.color = Color::rgb(rng.next_f64(), rng.next_f64(), 1.0);
        r.ctrl = vec!["expand_swarm".into()];
        let ri = d.add(r, None);
        let sensors = (0..12)
            .map(|k| SensorDesc {
                pose: Pose::new(0.0, 0.0, 0.0, (30.0 * k as f64).to_radians()),
                range: [0.0, 2.0],
                fov: 30f64.to_radians(),
                samples: 1,
                ..SensorDesc::default()
            })
            .collect();
        let mut ranger = ModelDesc::new(&format!("r{i}.ranger:0"), KindDesc::Ranger(sensors));
        ranger.pose = Pose::new(0.0, 0.0, -0.05, 0.0);
        d.add(ranger, Some(ri));
    }
    d
}
