//! The models that move and weigh particles: odometry (the action model), and range sensors
//! (laser and sonar) compared against the map by ray casting.
//!
//! The odometry model is Player 3.0.2's `amcl_odom.cc`: the measured step, with independent
//! Gaussian noise on x, y and heading whose spread grows with the step (the `odom_drift`
//! matrix). The laser model is 3.0.2's `amcl_laser.cc`: a few beams spread evenly over the
//! scan, each scored by how far its range is from the range the map predicts, with a floor
//! for unexplained readings. The sonar model is the same beam model over every transducer, as
//! Player 2.0's sonar sensor (`scount`/`spose` options; 3.0.2 dropped it).

use std::sync::Arc;

use nalgebra::Matrix3;
use player_proto::LaserDataScan;

use super::map::OccupancyMap;
use super::pdf::Gaussian;
use super::pf::ParticleFilter;
use super::pose::{Pose, compose};

/// Odometric drift: how much noise a step of odometry adds.
#[derive(Clone, Debug, PartialEq)]
pub struct OdometryModel {
    /// Rows of `odom_drift`: x noise per metre of x (`[0][0]`), y noise per metre of y
    /// (`[1][1]`), heading noise per metre of x, per metre of y and per radian of turn
    /// (`[2][0..3]`); other entries are unused, as upstream.
    pub drift: Matrix3<f64>,
}

impl OdometryModel {
    /// The distribution of the true step given the measured one (`delta`, in the frame of the
    /// pose before the step).
    pub fn step_pdf(&self, delta: &Pose) -> Gaussian {
        let d = &self.drift;
        let ux = d[(0, 0)] * delta.x;
        let uy = d[(1, 1)] * delta.y;
        let ua = d[(2, 0)] * delta.x.abs() + d[(2, 1)] * delta.y.abs() + d[(2, 2)] * delta.z.abs();
        let cov = Matrix3::from_diagonal(&Pose::new(ux * ux, uy * uy, ua * ua));
        Gaussian::new(*delta, cov)
    }

    /// Moves every particle by its own draw of the step, applied in the particle's frame.
    pub fn apply(&self, pf: &mut ParticleFilter, delta: &Pose) {
        let pdf = self.step_pdf(delta);
        pf.update_action(|rng, pose| compose(pose, &pdf.sample(rng)));
    }
}

/// Exponents below which `f64::exp` rounds to exactly 0 (`exp(-745.2)` is below half the
/// smallest subnormal).
const EXP_IS_ZERO: f64 = -745.2;

/// The likelihood of one range reading given the range the map predicts: a Gaussian of
/// standard deviation `sigma` around the prediction on top of a floor `bad` for readings the
/// map cannot explain; a reading and a prediction both at or past `range_max` agree fully.
pub fn beam_likelihood(obs: f64, predicted: f64, range_max: f64, sigma: f64, bad: f64) -> f64 {
    if obs >= range_max && predicted >= range_max {
        return 1.0;
    }
    let z = obs - predicted;
    let exponent = -(z * z) / (2.0 * sigma * sigma);
    // Below this `exp` is exactly 0 (its slow underflow path, taken for every beam of a
    // badly placed particle, is skipped; the result is the same).
    if exponent < EXP_IS_ZERO {
        return bad + (1.0 - bad) * 0.0;
    }
    bad + (1.0 - bad) * exponent.exp()
}

/// A laser scan as the model uses it: (range, bearing) pairs and the laser's maximum range.
#[derive(Clone, Debug, PartialEq)]
pub struct LaserScan {
    /// Readings at or past this count as "nothing seen".
    pub range_max: f64,
    /// (range m, bearing rad in the laser's frame), in scan order.
    pub beams: Vec<(f64, f64)>,
}

impl LaserScan {
    /// The beams of a SCAN: bearings from `min_angle` in steps of `resolution`.
    pub fn from_data(scan: &LaserDataScan) -> LaserScan {
        let (start, step) = (f64::from(scan.min_angle), f64::from(scan.resolution));
        LaserScan {
            range_max: f64::from(scan.max_range),
            beams: scan
                .ranges
                .iter()
                .enumerate()
                .map(|(i, &r)| (f64::from(r), start + i as f64 * step))
                .collect(),
        }
    }
}

/// The laser beam model.
#[derive(Clone, Debug)]
pub struct LaserModel {
    /// The map rays are cast in.
    pub map: Arc<OccupancyMap>,
    /// Where the laser sits on the robot (from the laser's geometry).
    pub laser_pose: Pose,
    /// How many beams of a scan are used (fewer than 2: the laser is ignored).
    pub max_beams: usize,
    /// Standard deviation of a range reading (m); upstream calls it `laser_range_var`.
    pub range_sigma: f64,
    /// Likelihood floor for readings the map does not explain.
    pub range_bad: f64,
}

impl LaserModel {
    /// The beams scored: every `step`-th from the first, `step = (n - 1) / (max_beams - 1)`
    /// (at least 1), as upstream picks them.
    pub fn beam_step(&self, n: usize) -> usize {
        (n.saturating_sub(1) / self.max_beams.saturating_sub(1).max(1)).max(1)
    }

    /// The likelihood of `scan` taken from a robot at `robot`.
    pub fn likelihood(&self, scan: &LaserScan, robot: &Pose) -> f64 {
        self.likelihood_of(&self.beams_used(scan), scan.range_max, robot)
    }

    /// The beams of `scan` that are scored, as (range, sine and cosine of the bearing): the
    /// same for every particle, so their trigonometry is done once per scan.
    fn beams_used(&self, scan: &LaserScan) -> Vec<(f64, f64, f64)> {
        scan.beams
            .iter()
            .step_by(self.beam_step(scan.beams.len()))
            .map(|&(obs, bearing)| {
                let (s, c) = bearing.sin_cos();
                (obs, s, c)
            })
            .collect()
    }

    /// [`LaserModel::likelihood`] of the beams [`LaserModel::beams_used`] picked. Each beam's
    /// direction in the map is the laser's heading turned by the bearing, by the angle-sum
    /// formulas (which agree with the sine and cosine of the summed angle to a few units in
    /// the last place).
    fn likelihood_of(&self, beams: &[(f64, f64, f64)], range_max: f64, robot: &Pose) -> f64 {
        let pose = compose(robot, &self.laser_pose);
        let cast_to = range_max + 1.0;
        let origin = self.map.ray_origin(pose.x, pose.y);
        let (sh, ch) = pose.z.sin_cos();
        beams
            .iter()
            .map(|&(obs, sb, cb)| {
                let (s, c) = (sh * cb + ch * sb, ch * cb - sh * sb);
                let predicted = self.map.calc_range_along(&origin, s, c, cast_to);
                beam_likelihood(obs, predicted, range_max, self.range_sigma, self.range_bad)
            })
            .product()
    }

    /// Weighs the particles by `scan`; `false` (nothing done) when fewer than two beams are
    /// configured, as upstream.
    pub fn update(&self, pf: &mut ParticleFilter, scan: &LaserScan) -> bool {
        if self.max_beams < 2 {
            return false;
        }
        let beams = self.beams_used(scan);
        pf.update_sensor(|p| self.likelihood_of(&beams, scan.range_max, p));
        true
    }
}

/// The sonar beam model: one beam per transducer, along the transducer's own heading.
#[derive(Clone, Debug)]
pub struct SonarModel {
    /// The map rays are cast in.
    pub map: Arc<OccupancyMap>,
    /// Where each transducer sits on the robot.
    pub poses: Vec<Pose>,
    /// Readings at or past this count as "nothing seen".
    pub range_max: f64,
    /// Standard deviation of a range reading (m); upstream calls it `sonar_range_var`.
    pub range_sigma: f64,
    /// Likelihood floor for readings the map does not explain.
    pub range_bad: f64,
}

impl SonarModel {
    /// The likelihood of `ranges` (one per transducer, in order) taken from `robot`. Readings
    /// beyond the known transducers are ignored.
    pub fn likelihood(&self, ranges: &[f64], robot: &Pose) -> f64 {
        let cast_to = self.range_max + 1.0;
        self.poses
            .iter()
            .zip(ranges)
            .map(|(mount, &obs)| {
                let p = compose(robot, mount);
                let predicted = self.map.calc_range(p.x, p.y, p.z, cast_to);
                beam_likelihood(
                    obs,
                    predicted,
                    self.range_max,
                    self.range_sigma,
                    self.range_bad,
                )
            })
            .product()
    }

    /// Weighs the particles by one set of readings.
    pub fn update(&self, pf: &mut ParticleFilter, ranges: &[f64]) -> bool {
        pf.update_sensor(|p| self.likelihood(ranges, p));
        true
    }
}

#[cfg(test)]
mod tests {
    use super::super::map::tests::room_grid;
    use super::super::pf::Population;
    use super::*;
    use player_server::map::OccupancyGrid;
    use std::f64::consts::FRAC_PI_2;

    fn filter(n: usize) -> ParticleFilter {
        ParticleFilter::new(
            Population {
                min_samples: n,
                max_samples: n,
                err: 0.01,
                z: 3.0,
            },
            1,
        )
    }

    #[test]
    fn zero_drift_moves_every_particle_exactly_by_the_step() {
        let mut pf = filter(50);
        let spread = Matrix3::from_diagonal(&Pose::new(1.0, 1.0, 1.0));
        pf.init_gaussian(Pose::new(1.0, 1.0, 0.0), spread);
        let before: Vec<Pose> = pf.samples().iter().map(|s| s.pose).collect();
        let odom = OdometryModel {
            drift: Matrix3::zeros(),
        };
        let step = Pose::new(0.5, 0.1, 0.2);
        odom.apply(&mut pf, &step);
        for (b, a) in before.iter().zip(pf.samples()) {
            // Exactly the composition: the step taken in each particle's own frame.
            assert_eq!(a.pose, compose(b, &step));
            assert_eq!(a.weight, 1.0 / 50.0);
        }
    }

    #[test]
    fn drift_spreads_particles_in_proportion_to_the_step() {
        let odom = OdometryModel {
            drift: Matrix3::new(0.2, 0.0, 0.0, 0.0, 0.2, 0.0, 0.2, 0.0, 0.2),
        };
        let pdf = odom.step_pdf(&Pose::new(1.0, 0.0, 0.5));
        let mut rng = <rand_chacha::ChaCha8Rng as rand::SeedableRng>::seed_from_u64(2);
        let n = 20_000;
        let draws: Vec<Pose> = (0..n).map(|_| pdf.sample(&mut rng)).collect();
        let sd = |f: fn(&Pose) -> f64, mean: f64| {
            (draws.iter().map(|d| (f(d) - mean).powi(2)).sum::<f64>() / n as f64).sqrt()
        };
        // x: 0.2 per metre; y: no y motion, no noise; heading: 0.2 * 1 m + 0.2 * 0.5 rad.
        assert!((sd(|d| d.x, 1.0) - 0.2).abs() < 0.01);
        assert_eq!(sd(|d| d.y, 0.0), 0.0);
        assert!((sd(|d| d.z, 0.5) - 0.3).abs() < 0.01);
    }

    /// A 6 x 4 m room (not square, so headings are told apart) with a pillar, and a scan
    /// simulated on the same map from `truth`.
    fn scene(truth: Pose) -> (LaserModel, LaserScan) {
        let mut grid = room_grid(6.0, 0.05);
        let n = i64::from(grid.width());
        let centre = |k: i64| (k as f64 + 0.5) * 0.05 - 3.0;
        for j in 0..n {
            for i in 0..n {
                let (x, y) = (centre(i), centre(j));
                // Close the room to 4 m in y, and put a 0.4 m pillar at (1.5, 0.5).
                let pillar = (x - 1.5).abs() < 0.2 && (y - 0.5).abs() < 0.2;
                if y.abs() >= 2.0 || pillar {
                    grid.set(i, j, OccupancyGrid::OCCUPIED);
                }
            }
        }
        let map = OccupancyMap::new(grid).unwrap();
        let model = LaserModel {
            map: Arc::new(map),
            laser_pose: Pose::new(0.1, 0.0, 0.0),
            max_beams: 19,
            range_sigma: 0.1,
            range_bad: 0.1,
        };
        let laser = compose(&truth, &model.laser_pose);
        let beams = (0..181)
            .map(|k| {
                let b = -FRAC_PI_2 + k as f64 * std::f64::consts::PI / 180.0;
                let r = model.map.calc_range(laser.x, laser.y, laser.z + b, 8.0);
                (r, b)
            })
            .collect();
        let scan = LaserScan {
            range_max: 8.0,
            beams,
        };
        (model, scan)
    }

    #[test]
    fn the_true_pose_scores_higher_than_wrong_ones() {
        let truth = Pose::new(-1.0, -0.5, 0.4);
        let (model, scan) = scene(truth);
        let at_truth = model.likelihood(&scan, &truth);
        assert!(at_truth > 0.9, "a perfect scan fits: {at_truth}");
        for wrong in [
            Pose::new(-0.7, -0.5, 0.4),
            Pose::new(-1.0, -0.2, 0.4),
            Pose::new(-1.0, -0.5, 0.6),
            Pose::new(1.0, 0.5, 0.4 + std::f64::consts::PI),
        ] {
            let l = model.likelihood(&scan, &wrong);
            assert!(l < 0.1 * at_truth, "{wrong:?}: {l} vs {at_truth}");
        }
    }

    #[test]
    fn beams_are_picked_evenly_and_max_range_readings_agree_with_open_space() {
        let (mut model, _) = scene(Pose::zeros());
        assert_eq!(model.beam_step(181), 10);
        model.max_beams = 6;
        assert_eq!(model.beam_step(181), 36);
        assert_eq!(model.beam_step(3), 1, "more beams wanted than there are");
        assert_eq!(beam_likelihood(8.0, 9.0, 8.0, 0.1, 0.1), 1.0);
        assert!((beam_likelihood(8.0, 2.0, 8.0, 0.1, 0.1) - 0.1).abs() < 1e-12);
        assert_eq!(beam_likelihood(2.0, 2.0, 8.0, 0.1, 0.1), 1.0);
        // Far off: exactly the floor, as `exp` gives it, on both sides of the short cut.
        assert_eq!(EXP_IS_ZERO.exp(), 0.0);
        for z in [3.0, 3.8, 3.9, 4.0, 50.0] {
            let want = 0.1 + 0.9 * (-(z * z) / (2.0 * 0.1 * 0.1f64)).exp();
            assert_eq!(beam_likelihood(2.0 + z, 2.0, 80.0, 0.1, 0.1), want, "{z}");
        }
        // Fewer than two beams: the laser does nothing.
        model.max_beams = 1;
        let mut pf = filter(10);
        assert!(!model.update(
            &mut pf,
            &LaserScan {
                range_max: 8.0,
                beams: vec![]
            }
        ));
    }

    #[test]
    fn sonar_readings_along_each_transducer_locate_the_robot() {
        let truth = Pose::new(0.5, 0.0, 0.0);
        let (laser, _) = scene(truth);
        let sonar = SonarModel {
            map: laser.map.clone(),
            poses: (0..8)
                .map(|k| {
                    let a = k as f64 * std::f64::consts::FRAC_PI_4;
                    Pose::new(0.2 * a.cos(), 0.2 * a.sin(), a)
                })
                .collect(),
            range_max: 5.0,
            range_sigma: 0.2,
            range_bad: 0.2,
        };
        let ranges: Vec<f64> = sonar
            .poses
            .iter()
            .map(|m| {
                let p = compose(&truth, m);
                sonar.map.calc_range(p.x, p.y, p.z, 5.0)
            })
            .collect();
        let at_truth = sonar.likelihood(&ranges, &truth);
        assert!(at_truth > 0.99);
        let off = sonar.likelihood(&ranges, &Pose::new(0.0, 0.5, 0.0));
        assert!(off < 0.2 * at_truth, "{off} vs {at_truth}");
    }
}
