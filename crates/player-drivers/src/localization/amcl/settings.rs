//! The driver's cfg options, with Player 3.0.2's names and defaults (`amcl.cc`,
//! `amcl_odom.cc`, `amcl_laser.cc`) and Player 2.0's sonar options (`amcl_sonar.cc`).
//!
//! Lengths are metres and angles degrees, as Player reads cfg lengths and angles by default.

use nalgebra::Matrix3;
use player_server::{DriverBlock, DriverError};

use super::pose::Pose;
use crate::options;

/// Most particles accepted for `pf_max_samples`: a GET_PARTICLES answer of this many (32
/// bytes each) stays within Player's 32 MiB message bound.
pub const MAX_SAMPLES_LIMIT: usize = 500_000;

/// Every option the driver reads.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// `pf_min_samples` (100): fewest particles kept.
    pub pf_min_samples: usize,
    /// `pf_max_samples` (10000): most particles kept, and how many the filter starts with.
    pub pf_max_samples: usize,
    /// `pf_err` (0.01): KLD bound on the error between sampled and true belief.
    pub pf_err: f64,
    /// `pf_z` (3): upper standard normal quantile for that bound.
    pub pf_z: f64,
    /// `init_pose [x y a]` ([0 0 0]): initial pose estimate.
    pub init_pose: Pose,
    /// `init_pose_var [x y a]` ([1 1 360 deg]): standard deviations of the initial estimate
    /// (the covariance is their squares).
    pub init_pose_var: Pose,
    /// `update_thresh [d a]` first element (0.2 m): odometry move that triggers an update.
    pub update_dist: f64,
    /// `update_thresh` second element (30 deg): odometry turn that triggers an update.
    pub update_angle: f64,
    /// `odom_drift[0]`, `odom_drift[1]`, `odom_drift[2]` (rows [0.2 0 0], [0 0.2 0],
    /// [0.2 0 0.2]): the odometry noise model.
    pub odom_drift: Matrix3<f64>,
    /// `laser_max_beams` (6): beams of each scan used; below 2 the laser is ignored.
    pub laser_max_beams: usize,
    /// `laser_range_var` (0.1 m): standard deviation of a laser range.
    pub laser_range_var: f64,
    /// `laser_range_bad` (0.1): likelihood floor for unexplained laser ranges.
    pub laser_range_bad: f64,
    /// `scount` and `spose[i] [x y a]`: sonar transducer poses; absent, the sonar's geometry
    /// is asked for.
    pub sonar_poses: Option<Vec<Pose>>,
    /// `sonar_range_max` (4 m): sonar readings at or past this mean nothing seen.
    pub sonar_range_max: f64,
    /// `sonar_range_var` (0.5 m): standard deviation of a sonar range.
    pub sonar_range_var: f64,
    /// `sonar_range_bad` (0.3): likelihood floor for unexplained sonar ranges.
    pub sonar_range_bad: f64,
    /// `seed` (0): seed of the filter's random generator (ours: a run repeats exactly).
    pub seed: u64,
}

impl Default for Settings {
    fn default() -> Settings {
        Settings {
            pf_min_samples: 100,
            pf_max_samples: 10_000,
            pf_err: 0.01,
            pf_z: 3.0,
            init_pose: Pose::zeros(),
            init_pose_var: Pose::new(1.0, 1.0, 2.0 * std::f64::consts::PI),
            update_dist: 0.2,
            update_angle: std::f64::consts::PI / 6.0,
            odom_drift: Matrix3::new(0.2, 0.0, 0.0, 0.0, 0.2, 0.0, 0.2, 0.0, 0.2),
            laser_max_beams: 6,
            laser_range_var: 0.1,
            laser_range_bad: 0.1,
            sonar_poses: None,
            sonar_range_max: 4.0,
            sonar_range_var: 0.5,
            sonar_range_bad: 0.3,
            seed: 0,
        }
    }
}

/// A count option: a non-negative integer.
fn count(block: &DriverBlock, key: &str, default: usize) -> Result<usize, DriverError> {
    match options::int(block, key)? {
        None => Ok(default),
        Some(n) if n >= 0 => Ok(n as usize),
        Some(n) => Err(DriverError::new(format!(
            "option `{key}` must not be negative, not {n}"
        ))),
    }
}

/// A pose tuple `[x y a]`: lengths, then an angle (in the cfg's units: metres and degrees
/// unless it says otherwise); absent elements keep `default`.
fn pose(block: &DriverBlock, key: &str, default: Pose) -> Result<Pose, DriverError> {
    Ok(Pose::new(
        options::tuple_length(block, key, 0)?.unwrap_or(default.x),
        options::tuple_length(block, key, 1)?.unwrap_or(default.y),
        options::tuple_angle(block, key, 2)?.unwrap_or(default.z),
    ))
}

impl Settings {
    /// Reads a cfg block; absent options keep Player's defaults, bad values are errors
    /// naming the option.
    pub fn from_block(block: &DriverBlock) -> Result<Settings, DriverError> {
        let d = Settings::default();
        let pf_min_samples = count(block, "pf_min_samples", d.pf_min_samples)?;
        let pf_max_samples = count(block, "pf_max_samples", d.pf_max_samples)?;
        if pf_max_samples == 0 || pf_max_samples > MAX_SAMPLES_LIMIT {
            return Err(DriverError::new(format!(
                "option `pf_max_samples` must be between 1 and {MAX_SAMPLES_LIMIT}, not {pf_max_samples}"
            )));
        }
        if pf_min_samples > pf_max_samples {
            return Err(DriverError::new(format!(
                "option `pf_min_samples` ({pf_min_samples}) exceeds `pf_max_samples` ({pf_max_samples})"
            )));
        }
        let pf_err = options::float(block, "pf_err")?.unwrap_or(d.pf_err);
        let pf_z = options::float(block, "pf_z")?.unwrap_or(d.pf_z);
        if !(pf_err > 0.0 && pf_err.is_finite() && pf_z.is_finite()) {
            return Err(DriverError::new(format!(
                "options `pf_err` ({pf_err}) must be positive and `pf_z` ({pf_z}) a number"
            )));
        }
        let mut odom_drift = d.odom_drift;
        for row in 0..3 {
            let key = format!("odom_drift[{row}]");
            for col in 0..3 {
                if let Some(v) = options::tuple_float(block, &key, col)? {
                    odom_drift[(row, col)] = v;
                }
            }
        }
        let sonar_poses = match options::int(block, "scount")? {
            None => None,
            Some(n) if n < 1 => {
                return Err(DriverError::new(format!(
                    "option `scount` must be at least 1, not {n}"
                )));
            }
            Some(n) if n > 4096 => {
                return Err(DriverError::new(format!(
                    "option `scount` ({n}) is more transducers than any sonar has"
                )));
            }
            Some(n) => Some(
                (0..n)
                    .map(|i| pose(block, &format!("spose[{i}]"), Pose::zeros()))
                    .collect::<Result<Vec<_>, _>>()?,
            ),
        };
        let seed = match block.option("seed") {
            None => d.seed,
            Some(text) => text.parse().map_err(|_| {
                DriverError::new(format!(
                    "option `seed` must be a non-negative integer, not \"{text}\""
                ))
            })?,
        };
        // The beam models divide by these: zero or negative spreads make every weight NaN.
        let spread = |key: &str, default: f64| -> Result<f64, DriverError> {
            let v = options::length(block, key)?.unwrap_or(default);
            if v > 0.0 && v.is_finite() {
                Ok(v)
            } else {
                Err(DriverError::new(format!(
                    "option `{key}` must be a positive length, not {v}"
                )))
            }
        };
        Ok(Settings {
            pf_min_samples,
            pf_max_samples,
            pf_err,
            pf_z,
            init_pose: pose(block, "init_pose", d.init_pose)?,
            init_pose_var: pose(block, "init_pose_var", d.init_pose_var)?,
            update_dist: options::tuple_length(block, "update_thresh", 0)?.unwrap_or(d.update_dist),
            update_angle: options::tuple_angle(block, "update_thresh", 1)?
                .unwrap_or(d.update_angle),
            odom_drift,
            laser_max_beams: count(block, "laser_max_beams", d.laser_max_beams)?,
            laser_range_var: spread("laser_range_var", d.laser_range_var)?,
            laser_range_bad: options::float(block, "laser_range_bad")?.unwrap_or(d.laser_range_bad),
            sonar_poses,
            sonar_range_max: options::length(block, "sonar_range_max")?
                .unwrap_or(d.sonar_range_max),
            sonar_range_var: spread("sonar_range_var", d.sonar_range_var)?,
            sonar_range_bad: options::float(block, "sonar_range_bad")?.unwrap_or(d.sonar_range_bad),
            seed,
        })
    }

    /// The initial covariance: the squares of `init_pose_var`.
    pub fn init_cov(&self) -> Matrix3<f64> {
        Matrix3::from_diagonal(&self.init_pose_var.component_mul(&self.init_pose_var))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn block(options: &[(&str, &[&str])]) -> DriverBlock {
        let mut b = DriverBlock::default();
        for (k, v) in options {
            b.options
                .insert(k.to_string(), v.iter().map(|s| s.to_string()).collect());
        }
        b
    }

    #[test]
    fn defaults_are_player_3_0_2s() {
        let s = Settings::from_block(&DriverBlock::default()).unwrap();
        assert_eq!(s, Settings::default());
        assert_eq!(s.init_cov()[(2, 2)], (2.0 * std::f64::consts::PI).powi(2));
    }

    #[test]
    fn tuples_read_lengths_and_degrees_and_keep_defaults_for_missing_elements() {
        let s = Settings::from_block(&block(&[
            ("init_pose", &["1", "-2", "90"]),
            ("init_pose_var", &["0.5"]),
            ("update_thresh", &["0.1", "5"]),
            ("odom_drift[2]", &["0.1", "0.05", "0.3"]),
            ("pf_max_samples", &["5000"]),
            ("pf_min_samples", &["500"]),
            ("laser_max_beams", &["20"]),
            ("seed", &["17"]),
        ]))
        .unwrap();
        assert_eq!(s.init_pose.x, 1.0);
        assert_eq!(s.init_pose.y, -2.0);
        assert!((s.init_pose.z - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert_eq!(s.init_pose_var.x, 0.5);
        assert_eq!(s.init_pose_var.y, 1.0);
        assert_eq!(s.update_dist, 0.1);
        assert!((s.update_angle - 5f64.to_radians()).abs() < 1e-12);
        assert_eq!(s.odom_drift.row(2).transpose(), Pose::new(0.1, 0.05, 0.3));
        assert_eq!(s.odom_drift[(0, 0)], 0.2, "other rows keep their defaults");
        assert_eq!((s.pf_min_samples, s.pf_max_samples), (500, 5000));
        assert_eq!(s.laser_max_beams, 20);
        assert_eq!(s.seed, 17);
    }

    #[test]
    fn sonar_poses_come_from_scount_and_spose() {
        let s = Settings::from_block(&block(&[
            ("scount", &["2"]),
            ("spose[0]", &["0.075", "0.130", "90"]),
            ("spose[1]", &["-0.25", "0.025", "170"]),
        ]))
        .unwrap();
        let p = s.sonar_poses.unwrap();
        assert_eq!(p.len(), 2);
        assert!((p[0].z - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert_eq!(p[1].x, -0.25);
    }

    #[test]
    fn bad_values_are_errors_naming_the_option() {
        for (opts, needle) in [
            (block(&[("pf_max_samples", &["0"])]), "pf_max_samples"),
            (
                block(&[("pf_max_samples", &["99999999"])]),
                "pf_max_samples",
            ),
            (
                block(&[("pf_min_samples", &["200"]), ("pf_max_samples", &["100"])]),
                "exceeds",
            ),
            (block(&[("pf_err", &["0"])]), "pf_err"),
            (block(&[("init_pose", &["1", "x"])]), "init_pose"),
            (block(&[("odom_drift[1]", &["a"])]), "odom_drift[1]"),
            (block(&[("scount", &["0"])]), "scount"),
            (block(&[("laser_max_beams", &["-1"])]), "laser_max_beams"),
            (block(&[("seed", &["-3"])]), "seed"),
            (block(&[("laser_range_var", &["0"])]), "laser_range_var"),
            (block(&[("sonar_range_var", &["-1"])]), "sonar_range_var"),
        ] {
            let e = Settings::from_block(&opts).unwrap_err().to_string();
            assert!(e.contains(needle), "{e}");
        }
    }
}
