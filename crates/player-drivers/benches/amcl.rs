//! How long one `amcl` filter update takes: the odometry step, the laser weighting and the
//! KLD resampling (with clustering), at Player's default `pf_max_samples` (10,000) and more,
//! on a 20 m x 20 m map of four rooms at 5 cm cells with a 181-beam scan.
//!
//! `cargo bench -p player-drivers --bench amcl` prints milliseconds per update (mean and
//! fastest of 10, the fastest being the figure least disturbed by other work on the machine)
//! and per phase.
//! Every timed update starts from `pf_max_samples` particles (as after initialisation or a
//! SET_POSE); how many the resampling keeps depends on how spread the belief is.
//!
//! The second part runs fixed populations (`pf_min_samples` = `pf_max_samples` = 500 and
//! 5,000, so every update weighs and keeps exactly that many) with a 180-beam scan and
//! `laser_max_beams` 180 (every beam used), on the synthetic map and on Stage's
//! `bitmaps/cave.png` loaded through the `mapfile` code at 0.032 m per pixel (the resolution
//! of Stage's `amcl-sonar.cfg`). With `NAVBENCH_DUMP=<dir>` set these runs also write their
//! inputs (map cells, model settings, each round's robot pose and scan) to `<dir>` as
//! `amcl.<map>.{txt,cells}` and `amcl.<map>.<n>.<belief>.rounds`, so another implementation
//! can be timed on identical inputs.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use nalgebra::Matrix3;
use player_drivers::localization::amcl::map::OccupancyMap;
use player_drivers::localization::amcl::models::{LaserModel, LaserScan, OdometryModel};
use player_drivers::localization::amcl::pf::{ParticleFilter, Population};
use player_drivers::localization::amcl::pose::{Pose, compose};
use player_drivers::map::mapfile::MapFileOptions;
use player_proto::Pose2d;
use player_server::map::OccupancyGrid;

const SCALE: f64 = 0.05;
const SIZE: f64 = 20.0;

/// The timed filter updates of one run: seconds per phase summed, the fastest whole update
/// and the particles kept, over every round.
#[derive(Default)]
struct UpdateTimes {
    rounds: usize,
    action: f64,
    sensor: f64,
    resample: f64,
    fastest: Option<f64>,
    kept: usize,
}

impl UpdateTimes {
    /// One update, timed phase by phase: odometry step, laser weighting, resampling.
    fn update(
        &mut self,
        odom: &OdometryModel,
        model: &LaserModel,
        pf: &mut ParticleFilter,
        step: &Pose,
        scan: &LaserScan,
    ) {
        let t0 = Instant::now();
        odom.apply(pf, step);
        let t1 = Instant::now();
        model.update(pf, scan);
        let t2 = Instant::now();
        pf.resample();
        let t3 = Instant::now();
        self.rounds += 1;
        self.kept += pf.samples().len();
        self.action += (t1 - t0).as_secs_f64();
        self.sensor += (t2 - t1).as_secs_f64();
        self.resample += (t3 - t2).as_secs_f64();
        let whole = (t3 - t0).as_secs_f64();
        self.fastest = Some(self.fastest.map_or(whole, |f| f.min(whole)));
    }

    /// `ms/update` (mean), the fastest, the mean per phase and the particles kept per round.
    fn report(&self) -> String {
        let rounds = self.rounds.max(1);
        let per = |t: f64| t * 1000.0 / rounds as f64;
        format!(
            "{:>8.2} ms/update, fastest {:.2} (action {:.2}, laser {:.2}, resample {:.2}; {} kept)",
            per(self.action + self.sensor + self.resample),
            self.fastest.unwrap_or(f64::NAN) * 1000.0,
            per(self.action),
            per(self.sensor),
            per(self.resample),
            self.kept / rounds
        )
    }
}

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
    let mut times = UpdateTimes::default();
    for _ in 0..rounds {
        pf.init_gaussian(robot, init_cov);
        robot = compose(&robot, &step);
        let s = scan(&model, &robot);
        times.update(&odom, &model, &mut pf, &step, &s);
    }
    println!(
        "{label:<34} {max_samples:>7} particles {beams:>3} beams {}",
        times.report()
    );
}

/// A bitmap of Stage's suite in the shared reference folder (`test_support`).
fn stage_bitmap(name: &str) -> PathBuf {
    // where it would be, so that the caller's read reports the path when it is absent
    test_support::shared_dir()
        .unwrap_or_else(|| test_support::workspace_root().join("../shared"))
        .join("stage-worlds/bitmaps")
        .join(name)
}

/// Beams of the fixed-population runs: a 180-degree laser of 180 beams, all weighed.
const BEAMS_180: usize = 180;

/// A scan of `BEAMS_180` beams over the front half-plane, cast on the model's map.
fn scan_180(model: &LaserModel, robot: &Pose, range_max: f64) -> LaserScan {
    let laser = compose(robot, &model.laser_pose);
    let step = std::f64::consts::PI / (BEAMS_180 - 1) as f64;
    let beams = (0..BEAMS_180)
        .map(|k| {
            let b = -std::f64::consts::FRAC_PI_2 + k as f64 * step;
            (
                model
                    .map
                    .calc_range(laser.x, laser.y, laser.z + b, range_max),
                b,
            )
        })
        .collect();
    LaserScan { range_max, beams }
}

/// The inputs of one fixed-population run, written for another implementation to replay.
struct Dump {
    /// `<dir>/amcl.<map>`: prefix of every file of this map.
    prefix: String,
}

impl Dump {
    /// Writes the map's cells and placement once per map.
    fn new(dir: &Path, name: &str, grid: &player_server::map::OccupancyGrid) -> Dump {
        let prefix = dir.join(format!("amcl.{name}")).display().to_string();
        std::fs::create_dir_all(dir).expect("dump folder");
        let o = grid.origin();
        std::fs::write(
            format!("{prefix}.txt"),
            format!(
                "{} {} {:.17} {:.17} {:.17}\n",
                grid.width(),
                grid.height(),
                f64::from(grid.scale()),
                o.px,
                o.py
            ),
        )
        .expect("dump map header");
        let bytes: Vec<u8> = grid.cells().iter().map(|&c| c as u8).collect();
        std::fs::write(format!("{prefix}.cells"), bytes).expect("dump map cells");
        Dump { prefix }
    }
}

/// The model settings of the fixed-population runs (Player's defaults but for the beams).
fn model_on(map: Arc<OccupancyMap>) -> (LaserModel, OdometryModel) {
    (
        LaserModel {
            map,
            laser_pose: Pose::new(0.1, 0.0, 0.0),
            max_beams: BEAMS_180,
            range_sigma: 0.1,
            range_bad: 0.1,
        },
        OdometryModel {
            drift: Matrix3::new(0.2, 0.0, 0.0, 0.0, 0.2, 0.0, 0.2, 0.0, 0.2),
        },
    )
}

/// Times `ROUNDS_FIXED` updates of exactly `n` particles (`pf_min_samples` =
/// `pf_max_samples` = `n`), each from a fresh belief of standard deviation `sd` (m, m, rad)
/// around the robot, which steps 0.2 m and turns 0.05 rad between rounds.
fn bench_fixed(
    map_name: &str,
    map: &Arc<OccupancyMap>,
    start: Pose,
    n: usize,
    (belief, sd): (&str, Pose),
    range_max: f64,
    dump: Option<&Dump>,
) {
    const ROUNDS_FIXED: usize = 10;
    let (model, odom) = model_on(Arc::clone(map));
    let population = Population {
        min_samples: n,
        max_samples: n,
        err: 0.01,
        z: 3.0,
    };
    let cov = Matrix3::from_diagonal(&sd.component_mul(&sd));
    let mut pf = ParticleFilter::new(population, 1);
    let mut robot = start;
    let step = Pose::new(0.2, 0.0, 0.05);
    let mut out = dump.map(|d| {
        let path = format!("{}.{n}.{belief}.rounds", d.prefix);
        let mut f = std::io::BufWriter::new(std::fs::File::create(path).expect("dump rounds"));
        let lp = &model.laser_pose;
        let dr = &odom.drift;
        writeln!(
            f,
            "{n} {ROUNDS_FIXED} {} {} {} {} {} {} {} {}",
            model.max_beams,
            model.range_sigma,
            model.range_bad,
            lp.x,
            lp.y,
            lp.z,
            range_max,
            BEAMS_180
        )
        .and_then(|()| {
            writeln!(
                f,
                "{} {} {} {} {} {} {} {} {}",
                dr[(0, 0)],
                dr[(0, 1)],
                dr[(0, 2)],
                dr[(1, 0)],
                dr[(1, 1)],
                dr[(1, 2)],
                dr[(2, 0)],
                dr[(2, 1)],
                dr[(2, 2)]
            )
        })
        .and_then(|()| {
            writeln!(
                f,
                "{:.17} {:.17} {:.17} {:.17} {:.17} {:.17}",
                step.x,
                step.y,
                step.z,
                cov[(0, 0)],
                cov[(1, 1)],
                cov[(2, 2)]
            )
        })
        .expect("dump rounds header");
        f
    });
    let mut times = UpdateTimes::default();
    for _ in 0..ROUNDS_FIXED {
        pf.init_gaussian(robot, cov);
        let before = robot;
        robot = compose(&robot, &step);
        let s = scan_180(&model, &robot, range_max);
        if let Some(f) = out.as_mut() {
            let mut line = format!("{:.17} {:.17} {:.17}", before.x, before.y, before.z);
            for (r, b) in &s.beams {
                line.push_str(&format!(" {r:.17} {b:.17}"));
            }
            writeln!(f, "{line}").expect("dump round");
        }
        times.update(&odom, &model, &mut pf, &step, &s);
    }
    println!(
        "{map_name:<6} {belief:<8} {n:>6} particles {BEAMS_180} beams {}",
        times.report()
    );
}

/// The fixed-population runs on the synthetic map and on Stage's cave.
fn fixed_populations() {
    let dump_dir = std::env::var_os("NAVBENCH_DUMP").map(PathBuf::from);
    let beliefs = [
        ("tracking", Pose::new(0.1, 0.1, 0.1)),
        ("initial", Pose::new(1.0, 1.0, 0.5)),
    ];
    let rooms = Arc::new(map());
    let rooms_dump = dump_dir
        .as_deref()
        .map(|d| Dump::new(d, "rooms", rooms.grid()));
    let cave_path = stage_bitmap("cave.png");
    let cave_grid = MapFileOptions {
        filename: cave_path.clone(),
        resolution: 0.032,
        negate: false,
        origin: None,
    }
    .load();
    let mut maps = vec![("rooms", rooms, Pose::new(-5.0, -5.0, 0.3), rooms_dump)];
    match cave_grid {
        Ok(grid) => {
            let dump = dump_dir.as_deref().map(|d| Dump::new(d, "cave", &grid));
            let cave = Arc::new(OccupancyMap::new(grid).expect("cave's scale is positive"));
            maps.push(("cave", cave, Pose::new(-2.24, 0.0, 0.3), dump));
        }
        Err(e) => println!("cave runs skipped: {} ({e})", cave_path.display()),
    }
    for (name, map, start, dump) in &maps {
        for n in [500, 5_000] {
            for belief in beliefs {
                bench_fixed(name, map, *start, n, belief, 8.0, dump.as_ref());
            }
        }
    }
}

fn main() {
    fixed_populations();
    let tight = Matrix3::from_diagonal(&Pose::new(0.01, 0.01, 0.01));
    let wide = Matrix3::from_diagonal(&Pose::new(25.0, 25.0, 10.0));
    bench("tight belief (sd 0.1 m, 0.1 rad)", 10_000, 6, tight);
    bench("belief over the whole map", 10_000, 6, wide);
    bench("belief over the whole map", 10_000, 30, wide);
    bench("belief over the whole map", 100_000, 6, wide);
}
