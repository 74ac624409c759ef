//! How long one `amcl` filter update takes: the odometry step, the laser weighting and the
//! KLD resampling (with clustering), at Player's default `pf_max_samples` (10,000) and more,
//! on a 20 m x 20 m map of four rooms at 5 cm cells with a 181-beam scan.
//!
//! `cargo bench -p player-drivers --bench amcl` prints milliseconds per update (mean and
//! fastest of 10, the fastest being the figure least disturbed by other work on the machine)
//! and per phase.
//! Every timed update starts from `pf_max_samples` particles (as after initialisation or a
//! SET_POSE); how many the resampling keeps depends on how spread the belief is.

use std::sync::Arc;
use std::time::Instant;

use nalgebra::Matrix3;
use player_drivers::localization::amcl::map::OccupancyMap;
use player_drivers::localization::amcl::models::{LaserModel, LaserScan, OdometryModel};
use player_drivers::localization::amcl::pf::{ParticleFilter, Population};
use player_drivers::localization::amcl::pose::{Pose, compose};
use player_proto::Pose2d;
use player_server::map::OccupancyGrid;

const SCALE: f64 = 0.05;
const SIZE: f64 = 20.0;

/// Four 10 m rooms with doorways, walls 10 cm thick.
fn map() -> OccupancyMap {
    let n = (SIZE / SCALE) as u32;
    let origin = Pose2d {
        px: -SIZE / 2.0,
        py: -SIZE / 2.0,
        pa: 0.0,
    };
    let mut g = OccupancyGrid::new(n, n, SCALE as f32, origin, OccupancyGrid::FREE).unwrap();
    for j in 0..i64::from(n) {
        for i in 0..i64::from(n) {
            let x = (i as f64 + 0.5) * SCALE - SIZE / 2.0;
            let y = (j as f64 + 0.5) * SCALE - SIZE / 2.0;
            let outer = x.abs() > 9.9 || y.abs() > 9.9;
            let inner = (x.abs() < 0.05 && (y - 5.0).abs() > 0.5 && (y + 5.0).abs() > 0.5)
                || (y.abs() < 0.05 && (x - 5.0).abs() > 0.5 && (x + 5.0).abs() > 0.5);
            if outer || inner {
                g.set(i, j, OccupancyGrid::OCCUPIED);
            }
        }
    }
    OccupancyMap::new(g).unwrap()
}

fn scan(model: &LaserModel, robot: &Pose) -> LaserScan {
    let laser = compose(robot, &model.laser_pose);
    let beams = (0..181)
        .map(|k| {
            let b = (k as f64 - 90.0).to_radians();
            (model.map.calc_range(laser.x, laser.y, laser.z + b, 8.0), b)
        })
        .collect();
    LaserScan {
        range_max: 8.0,
        beams,
    }
}

/// Times `rounds` updates, each from a fresh belief drawn from `init_cov` around the robot, so
/// every update starts with `max_samples` particles (the filter's worst case: a spread belief).
fn bench(label: &str, max_samples: usize, beams: usize, init_cov: Matrix3<f64>) {
    let model = LaserModel {
        map: Arc::new(map()),
        laser_pose: Pose::new(0.1, 0.0, 0.0),
        max_beams: beams,
        range_sigma: 0.1,
        range_bad: 0.1,
    };
    let odom = OdometryModel {
        drift: Matrix3::new(0.2, 0.0, 0.0, 0.0, 0.2, 0.0, 0.2, 0.0, 0.2),
    };
    let population = Population {
        min_samples: 100,
        max_samples,
        err: 0.01,
        z: 3.0,
    };
    let mut pf = ParticleFilter::new(population, 1);
    let mut robot = Pose::new(-5.0, -5.0, 0.3);
    let step = Pose::new(0.2, 0.0, 0.05);
    let rounds = 10;
    let (mut t_action, mut t_sensor, mut t_resample) = (0.0, 0.0, 0.0);
    let mut fastest = f64::INFINITY;
    let mut kept = 0;
    for _ in 0..rounds {
        pf.init_gaussian(robot, init_cov);
        robot = compose(&robot, &step);
        let s = scan(&model, &robot);
        let t0 = Instant::now();
        odom.apply(&mut pf, &step);
        let t1 = Instant::now();
        model.update(&mut pf, &s);
        let t2 = Instant::now();
        pf.resample();
        let t3 = Instant::now();
        kept += pf.samples().len();
        t_action += (t1 - t0).as_secs_f64();
        t_sensor += (t2 - t1).as_secs_f64();
        t_resample += (t3 - t2).as_secs_f64();
        fastest = fastest.min((t3 - t0).as_secs_f64());
    }
    let per = |t: f64| t * 1000.0 / rounds as f64;
    println!(
        "{label:<34} {max_samples:>7} particles {beams:>3} beams {:>8.2} ms/update, fastest \
         {:.2} (action {:.2}, laser {:.2}, resample {:.2}; {} kept)",
        per(t_action + t_sensor + t_resample),
        fastest * 1000.0,
        per(t_action),
        per(t_sensor),
        per(t_resample),
        kept / rounds
    );
}

fn main() {
    let tight = Matrix3::from_diagonal(&Pose::new(0.01, 0.01, 0.01));
    let wide = Matrix3::from_diagonal(&Pose::new(25.0, 25.0, 10.0));
    bench("tight belief (sd 0.1 m, 0.1 rad)", 10_000, 6, tight);
    bench("belief over the whole map", 10_000, 6, wide);
    bench("belief over the whole map", 10_000, 30, wide);
    bench("belief over the whole map", 100_000, 6, wide);
}
