//! The filter's bookkeeping: odometry, sensor readings and requests in, hypotheses and pose
//! estimates out, in arrival order, as Player 3.0.2's `AdaptiveMCL::UpdateFilter` sequences
//! them.
//!
//! The filter is updated only once the odometry has moved more than `update_thresh` since the
//! last update (x or y beyond the distance, or the heading beyond the angle, in the frame of
//! the last update). Such an update applies the odometry step, then waits for the next sensor
//! reading (odometry arriving meanwhile is dropped), weighs the particles with that one
//! reading, resamples and publishes the clusters as hypotheses; readings between updates are
//! dropped. Every odometry reading that does not update the filter publishes the best
//! hypothesis moved on by the odometry since the last update, so the `position2d` estimate
//! keeps pace with the robot.
//!
//! Everything happens in input order and the only randomness is the filter's seeded
//! generator, so the same inputs always give the same outputs, however long each update takes
//! and whichever thread runs it. (Upstream handles requests as they arrive instead, which
//! makes their effect depend on timing; here a SET_POSE or GET_PARTICLES takes effect after
//! the data that arrived before it.)

use std::collections::VecDeque;

use nalgebra::Matrix3;
use player_proto::{
    LocalizeDataHypoths, LocalizeGetParticles, LocalizeHypoth, LocalizeParticle, Pose2d,
};
use player_server::PendingReply;

use super::models::{LaserModel, LaserScan, OdometryModel, SonarModel};
use super::pf::{ParticleFilter, Population};
use super::pose::{Pose, compose, relative};

/// Something for the filter, in arrival order.
#[derive(Clone, Debug)]
pub enum Input {
    /// An odometry pose, and when it was measured.
    Odometry {
        /// The pose in the odometry frame.
        pose: Pose,
        /// Its timestamp.
        time: f64,
    },
    /// A laser scan.
    Laser(LaserScan),
    /// A set of sonar ranges, one per transducer.
    Sonar(Vec<f64>),
    /// SET_POSE: start again from a Gaussian.
    SetPose {
        /// Mean pose.
        mean: Pose,
        /// Covariance.
        cov: Matrix3<f64>,
    },
    /// GET_PARTICLES, answered with the token.
    GetParticles(PendingReply),
}

/// Something the driver should send.
#[derive(Clone, Debug, PartialEq)]
pub enum Output {
    /// New hypotheses (DATA HYPOTHS on `localize`), stamped with the odometry that caused
    /// the update.
    Hypotheses {
        /// The data, hypotheses heaviest first.
        data: LocalizeDataHypoths,
        /// Timestamp.
        time: f64,
    },
    /// The best pose estimate now (DATA STATE on `position2d`).
    Position {
        /// The pose.
        pose: Pose,
        /// The odometry timestamp it corresponds to.
        time: f64,
    },
    /// The answer to a GET_PARTICLES.
    Particles {
        /// Who asked.
        reply: PendingReply,
        /// The particle set.
        data: LocalizeGetParticles,
    },
}

/// How the filter is set up.
#[derive(Clone, Debug)]
pub struct EngineConfig {
    /// Sample counts and KLD parameters.
    pub population: Population,
    /// Seed of the filter's random generator.
    pub seed: u64,
    /// Initial pose estimate.
    pub init_mean: Pose,
    /// Its covariance.
    pub init_cov: Matrix3<f64>,
    /// Odometry distance (m, along x or y) that triggers an update.
    pub update_dist: f64,
    /// Odometry turn (rad) that triggers an update.
    pub update_angle: f64,
    /// The action model.
    pub odometry: OdometryModel,
}

/// The filter and its input queue.
#[derive(Debug)]
pub struct Engine {
    config: EngineConfig,
    pf: ParticleFilter,
    laser: Option<LaserModel>,
    sonar: Option<SonarModel>,
    queue: VecDeque<Input>,
    /// Odometry at the last update; `None` until the first reading after (re)initialisation.
    odom_ref: Option<Pose>,
    /// An update waiting for its sensor reading: the odometry that triggered it.
    awaiting: Option<(Pose, f64)>,
    best: Pose,
}

impl Engine {
    /// A filter initialised from the configured Gaussian, weighing particles with the given
    /// sensor models (with none, every update is odometry alone).
    pub fn new(
        config: EngineConfig,
        laser: Option<LaserModel>,
        sonar: Option<SonarModel>,
    ) -> Engine {
        let mut pf = ParticleFilter::new(config.population, config.seed);
        pf.init_gaussian(config.init_mean, config.init_cov);
        Engine {
            best: config.init_mean,
            config,
            pf,
            laser,
            sonar,
            queue: VecDeque::new(),
            odom_ref: None,
            awaiting: None,
        }
    }

    /// The particle filter.
    pub fn filter(&self) -> &ParticleFilter {
        &self.pf
    }

    /// Queues an input.
    pub fn push(&mut self, input: Input) {
        self.queue.push_back(input);
    }

    /// How many inputs wait.
    pub fn queued(&self) -> usize {
        self.queue.len()
    }

    /// Handles the oldest queued input, appending what it produces to `out`; `false` when
    /// nothing was queued.
    pub fn step(&mut self, out: &mut Vec<Output>) -> bool {
        let Some(input) = self.queue.pop_front() else {
            return false;
        };
        match input {
            Input::SetPose { mean, cov } => {
                self.pf.init_gaussian(mean, cov);
                self.odom_ref = None;
                self.awaiting = None;
            }
            Input::GetParticles(reply) => out.push(Output::Particles {
                reply,
                data: self.particles(),
            }),
            // Odometry while an update waits for its reading is dropped, as upstream does.
            Input::Odometry { .. } if self.awaiting.is_some() => {}
            Input::Odometry { pose, time } => self.odometry(pose, time, out),
            Input::Laser(scan) => {
                if let (Some(trigger), Some(laser)) = (self.awaiting, &self.laser) {
                    laser.update(&mut self.pf, &scan);
                    self.finish_update(trigger, out);
                }
            }
            Input::Sonar(ranges) => {
                if let (Some(trigger), Some(sonar)) = (self.awaiting, &self.sonar) {
                    sonar.update(&mut self.pf, &ranges);
                    self.finish_update(trigger, out);
                }
            }
        }
        true
    }

    /// Handles every queued input.
    pub fn run(&mut self, out: &mut Vec<Output>) {
        while self.step(out) {}
    }

    fn odometry(&mut self, pose: Pose, time: f64, out: &mut Vec<Output>) {
        let Some(reference) = self.odom_ref else {
            // The first reading after (re)initialisation: weigh the initial belief with the
            // next sensor reading, without motion.
            self.odom_ref = Some(pose);
            self.start_update(pose, time, out);
            return;
        };
        let delta = relative(&reference, &pose);
        let c = &self.config;
        if delta.x.abs() > c.update_dist
            || delta.y.abs() > c.update_dist
            || delta.z.abs() > c.update_angle
        {
            self.config.odometry.apply(&mut self.pf, &delta);
            self.start_update(pose, time, out);
        } else {
            out.push(Output::Position {
                pose: compose(&self.best, &delta),
                time,
            });
        }
    }

    fn start_update(&mut self, pose: Pose, time: f64, out: &mut Vec<Output>) {
        self.awaiting = Some((pose, time));
        if self.laser.is_none() && self.sonar.is_none() {
            // Upstream would wait for a reading forever; with no sensor, odometry alone
            // drives the filter.
            self.finish_update((pose, time), out);
        }
    }

    fn finish_update(&mut self, (pose, time): (Pose, f64), out: &mut Vec<Output>) {
        self.awaiting = None;
        self.odom_ref = Some(pose);
        self.pf.resample();
        let mut hypoths: Vec<LocalizeHypoth> = self
            .pf
            .clusters()
            .iter()
            .map(|c| LocalizeHypoth {
                mean: pose2d(&c.mean),
                cov: [c.cov[(0, 0)], c.cov[(1, 1)], c.cov[(2, 2)]],
                alpha: c.weight,
            })
            .collect();
        if let Some(best) = self
            .pf
            .clusters()
            .iter()
            .filter(|c| c.weight > 0.0)
            .reduce(|a, b| if b.weight > a.weight { b } else { a })
        {
            self.best = best.mean;
        }
        hypoths.sort_by(|a, b| b.alpha.total_cmp(&a.alpha));
        out.push(Output::Hypotheses {
            data: LocalizeDataHypoths {
                pending_count: 0,
                pending_time: 0.0,
                hypoths,
            },
            time,
        });
        out.push(Output::Position {
            pose: self.best,
            time,
        });
    }

    /// The GET_PARTICLES answer: the weighted mean and spread of every particle, and the
    /// particles themselves.
    pub fn particles(&self) -> LocalizeGetParticles {
        let (mean, variance) = self.pf.cep_stats();
        LocalizeGetParticles {
            mean: pose2d(&mean),
            variance,
            particles: self
                .pf
                .samples()
                .iter()
                .map(|s| LocalizeParticle {
                    pose: pose2d(&s.pose),
                    alpha: s.weight,
                })
                .collect(),
        }
    }

    /// The best estimate so far (the heaviest cluster's mean at the last update).
    pub fn best(&self) -> Pose {
        self.best
    }
}

fn pose2d(p: &Pose) -> Pose2d {
    Pose2d {
        px: p.x,
        py: p.y,
        pa: p.z,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;

    use super::super::map::tests::room;

    fn config(samples: usize) -> EngineConfig {
        EngineConfig {
            population: Population {
                min_samples: samples / 10,
                max_samples: samples,
                err: 0.01,
                z: 3.0,
            },
            seed: 0,
            init_mean: Pose::new(0.0, 0.0, 0.0),
            init_cov: Matrix3::from_diagonal(&Pose::new(0.01, 0.01, 0.01)),
            update_dist: 0.2,
            update_angle: 0.5,
            odometry: OdometryModel {
                drift: Matrix3::zeros(),
            },
        }
    }

    fn odom(x: f64, time: f64) -> Input {
        Input::Odometry {
            pose: Pose::new(x, 0.0, 0.0),
            time,
        }
    }

    fn positions(out: &[Output]) -> Vec<(f64, f64)> {
        out.iter()
            .filter_map(|o| match o {
                Output::Position { pose, time } => Some((pose.x, *time)),
                _ => None,
            })
            .collect()
    }

    fn hypotheses(out: &[Output]) -> Vec<&LocalizeDataHypoths> {
        out.iter()
            .filter_map(|o| match o {
                Output::Hypotheses { data, .. } => Some(data),
                _ => None,
            })
            .collect()
    }

    #[test]
    fn without_sensors_odometry_alone_updates_past_the_threshold() {
        let mut e = Engine::new(config(500), None, None);
        let mut out = Vec::new();
        for (k, x) in [0.0, 0.1, 0.15, 0.25, 0.3].iter().enumerate() {
            e.push(odom(*x, k as f64));
        }
        e.run(&mut out);
        // Updates at the first reading and past 0.2 m; in between, the estimate follows the
        // odometry from the last update.
        assert_eq!(hypotheses(&out).len(), 2);
        let p = positions(&out);
        assert_eq!(p.len(), 5);
        let x0 = p[0].0;
        assert!(x0.abs() < 0.05);
        // (The estimate's heading is the cluster's, a few hundredths of a radian.)
        assert!((p[1].0 - (x0 + 0.1)).abs() < 1e-3 && p[1].1 == 1.0);
        assert!((p[2].0 - (x0 + 0.15)).abs() < 1e-3);
        // After the update at 0.25 m the estimate is the cluster mean, moved by the step
        // exactly (no drift noise).
        assert!((p[3].0 - (x0 + 0.25)).abs() < 0.01, "{p:?}");
        assert!((p[4].0 - (p[3].0 + 0.05)).abs() < 1e-3);
    }

    #[test]
    fn an_update_waits_for_the_next_reading_and_drops_odometry_meanwhile() {
        let laser = LaserModel {
            map: Arc::new(room(4.0, 0.05)),
            laser_pose: Pose::zeros(),
            max_beams: 5,
            range_sigma: 0.1,
            range_bad: 0.1,
        };
        let scan = |x: f64| LaserScan {
            range_max: 8.0,
            beams: (0..5)
                .map(|k| {
                    let b = -1.0 + 0.5 * k as f64;
                    (laser.map.calc_range(x, 0.0, b, 8.0), b)
                })
                .collect(),
        };
        let mut e = Engine::new(config(500), Some(laser.clone()), None);
        let mut out = Vec::new();
        e.push(odom(0.0, 0.0));
        e.run(&mut out);
        assert!(out.is_empty(), "waiting for a scan");
        e.push(odom(0.5, 1.0)); // dropped: an update is waiting
        e.push(Input::Laser(scan(0.0)));
        e.run(&mut out);
        assert_eq!(hypotheses(&out).len(), 1);
        assert_eq!(positions(&out).len(), 1);
        assert_eq!(
            positions(&out)[0].1,
            0.0,
            "stamped with the triggering odometry"
        );
        out.clear();
        // A scan with no update waiting is dropped; small moves only move the estimate.
        e.push(Input::Laser(scan(0.0)));
        e.push(odom(0.1, 2.0));
        e.run(&mut out);
        assert!(hypotheses(&out).is_empty());
        assert_eq!(positions(&out).len(), 1);
        out.clear();
        // A big move updates once its scan arrives; the estimate follows the robot.
        e.push(odom(0.6, 3.0));
        e.push(Input::Laser(scan(0.6)));
        e.run(&mut out);
        let h = hypotheses(&out);
        assert_eq!(h.len(), 1);
        let best = &h[0].hypoths[0];
        assert!((best.mean.px - 0.6).abs() < 0.1, "{best:?}");
        assert!(h[0].hypoths.windows(2).all(|w| w[0].alpha >= w[1].alpha));
    }

    #[test]
    fn set_pose_restarts_from_the_new_gaussian() {
        let mut e = Engine::new(config(300), None, None);
        let mut out = Vec::new();
        e.push(odom(0.0, 0.0));
        e.push(Input::SetPose {
            mean: Pose::new(3.0, 4.0, 1.0),
            cov: Matrix3::zeros(),
        });
        e.push(odom(0.0, 1.0));
        e.run(&mut out);
        let h = hypotheses(&out);
        assert_eq!(h.len(), 2);
        let m = &h[1].hypoths[0].mean;
        assert!(
            (m.px - 3.0).abs() < 1e-9 && (m.py - 4.0).abs() < 1e-9 && (m.pa - 1.0).abs() < 1e-9
        );
        assert!((h[1].hypoths[0].alpha - 1.0).abs() < 1e-9);
    }
}
