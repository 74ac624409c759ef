//! `position` (spec §7): control modes, per-update velocity computation, odometry / GPS
//! localization, and the per-step motion delta.

use super::ModelKind;
use crate::digest::Digest;
use crate::node::{ModelId, Node};
use crate::pose::{Pose, normalize};
use crate::rng::SimRng;
use crate::view::View;
use std::f64::consts::PI;
use worldfile::models as wm;
use worldfile::models::{Drive, Localization};

/// Position-model properties (spec §7.1); angles in radians.
#[derive(Clone, Debug, PartialEq)]
pub struct PositionDesc {
    /// Drive model.
    pub drive: Drive,
    /// Localization mode.
    pub localization: Localization,
    /// Origin of the reported pose frame; `None`: the model's global pose at load.
    pub localization_origin: Option<Pose>,
    /// Odometry error factors `(x, y, z, a)`; `None`: drawn at random per model (spec §7.7).
    pub odom_error: Option<[f64; 4]>,
    /// Wheelbase for `car` drive (m).
    pub wheelbase: f64,
    /// `[xmin xmax ymin ymax zmin zmax amin amax]` (m/s, rad/s).
    pub velocity_bounds: [f64; 8],
    /// Same layout as `velocity_bounds`, for acceleration mode (m/s², rad/s²).
    pub acceleration_bounds: [f64; 8],
    /// Initial velocity (overwritten by the first control update, as in Stage).
    pub velocity: Pose,
}

impl Default for PositionDesc {
    /// Stage's defaults, from the worldfile crate's property table (one source of truth).
    fn default() -> Self {
        let mut d = desc_from_spec(&wm::PositionSpec::default(), &mut SimRng::new(0, 0));
        // "the model's global pose at load", which the resolver fills in for real models
        d.localization_origin = None;
        d
    }
}

/// How the goal of a position model is interpreted (spec §7.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ControlMode {
    /// Goal = body-frame velocity (`car`: speed and steering angle).
    Velocity,
    /// Goal = target pose in the odometry frame.
    Position,
    /// Goal = accelerations (API only).
    Acceleration,
}

/// What a server publishes for a position model (Player `position2d` DATA_STATE).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PositionData {
    /// Sim time of the update that produced this (µs).
    pub time_us: u64,
    /// Reported pose: the localization estimate (odometry or GPS frame).
    pub pose: Pose,
    /// Body-frame velocity `(vx, vy, 0, va)` as last computed.
    pub velocity: Pose,
    /// The last move was blocked (sticky while stopped).
    pub stall: bool,
}

/// The state of one position model.
#[derive(Clone, Debug)]
pub struct PositionModel {
    /// Configuration from the worldfile.
    pub cfg: PositionDesc,
    /// Control mode.
    pub mode: ControlMode,
    /// Current goal.
    pub goal: Pose,
    /// Body-frame velocity applied at each move.
    pub velocity: Pose,
    /// Localization estimate.
    pub est: Pose,
    /// Origin of the estimate frame.
    pub est_origin: Pose,
    /// Odometry error factors `(x, y, z, a)`.
    pub odom_error: [f64; 4],
    /// Stall flag.
    pub stall: bool,
    /// Power draw (W) from the last update.
    pub watts: f64,
    /// Published data.
    pub data: PositionData,
}

fn clamp(v: f64, lo: f64, hi: f64) -> f64 {
    if v < lo {
        lo
    } else if v > hi {
        hi
    } else {
        v
    }
}

/// `global` expressed in the localization frame whose origin is `origin` (Stage's GPS
/// estimate, and every model's estimate at load). The estimate has no height.
pub fn estimate_in_frame(origin: &Pose, global: &Pose) -> Pose {
    Pose {
        z: 0.0,
        ..origin.relative(global)
    }
}

pub(crate) fn desc_from_spec(p: &wm::PositionSpec, _: &mut SimRng) -> PositionDesc {
    PositionDesc {
        drive: p.drive,
        localization: p.localization,
        localization_origin: Some(Pose::from_array(p.localization_origin)),
        odom_error: p.odom_error,
        wheelbase: p.wheelbase,
        velocity_bounds: p.velocity_bounds,
        acceleration_bounds: p.acceleration_bounds,
        velocity: Pose::from_array(p.velocity),
    }
}

/// A model as described, at `global` on load: the estimate's frame is
/// `localization_origin` (the load pose when unset) and a missing `odom_error` is drawn
/// once from `rng`, uniformly over Stage's spans (spec §7.7). As Stage's load does, the
/// estimate starts at the global pose expressed in the origin's frame whatever the
/// localization mode: zero when the origin defaults to the start pose, the world pose
/// under `localization_origin [0 0 0 0]`.
pub(crate) fn start(p: &PositionDesc, global: &Pose, rng: &mut SimRng) -> PositionModel {
    let origin = p.localization_origin.unwrap_or(*global);
    let err = match p.odom_error {
        Some(e) => e,
        None => wm::PositionSpec::ODOM_ERROR_SPAN.map(|span| rng.uniform(-span / 2.0, span / 2.0)),
    };
    PositionModel::new(p.clone(), global, origin, err)
}

impl ModelKind for PositionModel {
    #[inline]
    fn update(&mut self, v: &View, m: ModelId, _: &Pose, node: &Node, _: &mut SimRng) {
        PositionModel::update(self, &v.globals[m.index()], v.dt, node.mass, v.sim_time)
    }

    fn shutdown(&mut self) {
        PositionModel::shutdown(self)
    }

    /// Feeds the state to the determinism digest: control mode and goal, velocity, estimate,
    /// odometry error, stall and the published data.
    fn digest(&self, d: &mut Digest) {
        d.u64(self.mode as u64);
        d.pose(&self.goal);
        d.pose(&self.velocity);
        d.pose(&self.est);
        d.pose(&self.est_origin);
        self.odom_error.iter().for_each(|&v| d.f64(v));
        d.u64(self.stall as u64);
        d.f64(self.watts);
        d.u64(self.data.time_us);
        d.pose(&self.data.pose);
        d.pose(&self.data.velocity);
        d.u64(self.data.stall as u64);
    }
}

impl PositionModel {
    /// A model with its estimate frame and odometry error given.
    pub fn new(
        cfg: PositionDesc,
        global: &Pose,
        est_origin: Pose,
        odom_error: [f64; 4],
    ) -> PositionModel {
        let velocity = cfg.velocity;
        let est = estimate_in_frame(&est_origin, global);
        PositionModel {
            cfg,
            mode: ControlMode::Velocity,
            goal: Pose::ZERO,
            velocity,
            est,
            est_origin,
            odom_error,
            stall: false,
            watts: 0.0,
            data: PositionData {
                pose: est,
                ..PositionData::default()
            },
        }
    }

    /// Sets a velocity goal (Player CMD_VEL / CMD_CAR).
    pub fn command_velocity(&mut self, x: f64, y: f64, a: f64) {
        self.mode = ControlMode::Velocity;
        self.goal = Pose { x, y, z: 0.0, a };
    }

    /// Sets a position goal in the odometry frame (Player CMD_POS).
    pub fn command_position(&mut self, x: f64, y: f64, a: f64) {
        self.mode = ControlMode::Position;
        self.goal = Pose { x, y, z: 0.0, a };
    }

    /// Sets an acceleration goal (API only, as in Stage).
    pub fn command_acceleration(&mut self, x: f64, y: f64, a: f64) {
        self.mode = ControlMode::Acceleration;
        self.goal = Pose { x, y, z: 0.0, a };
    }

    /// Zeroes goal and velocity (the last subscriber left, spec §5.4).
    pub fn shutdown(&mut self) {
        self.mode = ControlMode::Velocity;
        self.goal = Pose::ZERO;
        self.velocity = Pose::ZERO;
    }

    /// One control update (spec §7.3): velocity from the goal, bounds, localization.
    /// `global` is the model's current global pose, `dt` the world step (s), `mass` in kg.
    pub fn update(&mut self, global: &Pose, dt: f64, mass: f64, time_us: u64) {
        let g = self.goal;
        let mut v = Pose::ZERO;
        match self.mode {
            ControlMode::Velocity => match self.cfg.drive {
                Drive::Diff => {
                    v.x = g.x;
                    v.a = g.a;
                }
                Drive::Omni => {
                    v.x = g.x;
                    v.y = g.y;
                    v.a = g.a;
                }
                Drive::Car => {
                    v.x = g.x * g.a.cos();
                    v.a = g.x * g.a.sin() / self.cfg.wheelbase;
                }
            },
            ControlMode::Position => {
                let ex = g.x - self.est.x;
                let ey = g.y - self.est.y;
                let ea = normalize(g.a - self.est.a);
                match self.cfg.drive {
                    Drive::Omni => {
                        v.x = ex.min(0.4);
                        v.y = ey.min(0.4);
                        v.a = ea.min(1.0);
                    }
                    Drive::Diff => {
                        if ex.abs() < 0.02 && ey.abs() < 0.02 {
                            v.a = ea.max(-1.0);
                        } else {
                            let e = normalize(ey.atan2(ex) - self.est.a);
                            v.a = e.max(-1.0);
                            if e.abs() < PI / 16.0 {
                                v.x = ex.hypot(ey).min(0.4);
                            }
                        }
                    }
                    Drive::Car => {
                        tracing::warn!(
                            "position mode is not supported for car drive (as in Stage)"
                        );
                    }
                }
            }
            ControlMode::Acceleration => {
                let b = &self.cfg.acceleration_bounds;
                let ax = clamp(g.x, b[0], b[1]);
                let ay = clamp(g.y, b[2], b[3]);
                let aa = clamp(g.a, b[6], b[7]);
                v = self.velocity;
                match self.cfg.drive {
                    Drive::Diff => {
                        v.x += ax * dt;
                        v.y = 0.0;
                        v.a += aa * dt;
                    }
                    Drive::Omni => {
                        v.x += ax * dt;
                        v.y += ay * dt;
                        v.a += aa * dt;
                    }
                    Drive::Car => {
                        tracing::warn!("acceleration mode is not supported for car drive");
                    }
                }
            }
        }
        self.watts = 1.0 + (v.x.abs() + v.y.abs() + v.a.abs()) * 10.0 * mass;
        let b = &self.cfg.velocity_bounds;
        v.x = clamp(v.x, b[0], b[1]);
        v.y = clamp(v.y, b[2], b[3]);
        v.z = clamp(v.z, b[4], b[5]);
        v.a = clamp(v.a, b[6], b[7]);
        self.velocity = v;

        match self.cfg.localization {
            Localization::Gps => self.est = estimate_in_frame(&self.est_origin, global),
            Localization::Odom => {
                let e = &self.odom_error;
                self.est.a = normalize(self.est.a + v.a * dt * (1.0 + e[3]));
                let dx = v.x * dt * (1.0 + e[0]);
                let dy = v.y * dt * (1.0 + e[1]);
                let (s, c) = self.est.a.sin_cos();
                // Stage's sign quirk on the lateral terms (spec §7.7) is client-visible: kept.
                self.est.x += dx * c + dy * s;
                self.est.y += dx * s - dy * c;
            }
        }
        self.data = PositionData {
            time_us,
            pose: self.est,
            velocity: self.velocity,
            stall: self.stall,
        };
    }

    /// The pose change for one step of `dt` seconds, or `None` when the velocity is zero.
    pub fn step_delta(&self, dt: f64) -> Option<Pose> {
        let v = &self.velocity;
        if v.x == 0.0 && v.y == 0.0 && v.z == 0.0 && v.a == 0.0 {
            return None;
        }
        Some(Pose {
            x: v.x * dt,
            y: v.y * dt,
            z: v.z * dt,
            a: normalize(v.a * dt),
        })
    }

    /// Records the outcome of a move attempt.
    pub fn set_stall(&mut self, stall: bool) {
        self.stall = stall;
        self.data.stall = stall;
    }

    /// Player SET_ODOM / RESET_ODOM: sets the estimate only, as Stage's plugin does (not the
    /// origin, so the next GPS update overwrites it; in odom mode it lasts, spec §7.8).
    pub fn set_odom(&mut self, p: Pose) {
        self.est = p;
        self.data.pose = p;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4};

    fn model(drive: Drive) -> PositionModel {
        PositionModel::new(
            PositionDesc {
                drive,
                ..PositionDesc::default()
            },
            &Pose::ZERO,
            Pose::ZERO,
            [0.0; 4],
        )
    }

    #[test]
    fn velocity_bounds_clamp_commands() {
        let mut p = model(Drive::Diff);
        p.command_velocity(5.0, 3.0, 10.0);
        p.update(&Pose::ZERO, 0.1, 0.0, 0);
        assert_eq!(p.velocity.x, 1.0);
        assert_eq!(p.velocity.y, 0.0, "diff drive ignores y");
        assert!((p.velocity.a - 90f64.to_radians()).abs() < 1e-12);
    }

    #[test]
    fn car_drive_uses_steering_angle_and_wheelbase() {
        let mut p = model(Drive::Car);
        p.cfg.wheelbase = 0.5;
        p.command_velocity(0.5, 0.0, 0.3);
        p.update(&Pose::ZERO, 0.1, 0.0, 0);
        assert!((p.velocity.x - 0.5 * 0.3f64.cos()).abs() < 1e-12);
        assert!((p.velocity.a - 0.5 * 0.3f64.sin() / 0.5).abs() < 1e-12);
    }

    #[test]
    fn odometry_integrates_commanded_velocity_with_lateral_sign_quirk() {
        let mut p = model(Drive::Omni);
        p.cfg.localization = Localization::Odom;
        p.command_velocity(0.0, 0.5, 0.0);
        for _ in 0..10 {
            p.update(&Pose::ZERO, 0.1, 0.0, 0);
        }
        assert!(
            (p.est.y + 0.5).abs() < 1e-9,
            "lateral motion is integrated negated: {:?}",
            p.est
        );
    }

    #[test]
    fn the_estimate_starts_at_the_global_pose_in_the_origin_frame() {
        let global = Pose::new(-6.946, -6.947, 0.3, FRAC_PI_4);
        let at = |origin: Pose| {
            PositionModel::new(PositionDesc::default(), &global, origin, [0.0; 4]).est
        };
        // localization_origin [0 0 0 0]: the world pose (no height)
        assert_eq!(at(Pose::ZERO), Pose { z: 0.0, ..global });
        // no localization_origin: the origin is the start pose, so the estimate is zero
        let own = at(global);
        assert!(own.x.abs() < 1e-12 && own.y.abs() < 1e-12 && own.a.abs() < 1e-12);
        // a rotated, shifted origin: the start pose seen from it
        let o = at(Pose::new(1.0, 2.0, 0.0, FRAC_PI_2));
        let (dx, dy) = (-6.946 - 1.0, -6.947 - 2.0);
        assert!(
            (o.x - dy).abs() < 1e-12 && (o.y + dx).abs() < 1e-12,
            "{o:?}"
        );
        assert!((o.a - (FRAC_PI_4 - FRAC_PI_2)).abs() < 1e-12);
    }

    #[test]
    fn odometry_integrates_from_the_start_estimate_and_keeps_set_odom() {
        let global = Pose::new(3.0, -2.0, 0.0, FRAC_PI_2);
        let cfg = PositionDesc {
            localization: Localization::Odom,
            ..PositionDesc::default()
        };
        let mut p = PositionModel::new(cfg, &global, Pose::ZERO, [0.0; 4]);
        assert_eq!(p.data.pose, p.est, "published before the first update too");
        p.command_velocity(1.0, 0.0, 0.0);
        p.update(&global, 0.5, 0.0, 0);
        // half a metre along the heading (+y), from (3, -2)
        assert!((p.est.x - 3.0).abs() < 1e-12 && (p.est.y + 1.5).abs() < 1e-12);
        p.set_odom(Pose::new(1.0, 1.0, 0.0, 0.0));
        p.update(&global, 0.5, 0.0, 0);
        assert!((p.est.x - 1.5).abs() < 1e-12 && (p.est.y - 1.0).abs() < 1e-12);
        // GPS mode recomputes from the origin: SET_ODOM does not last
        p.cfg.localization = Localization::Gps;
        p.set_odom(Pose::ZERO);
        p.update(&global, 0.5, 0.0, 0);
        assert_eq!(p.est, Pose { z: 0.0, ..global });
    }

    #[test]
    fn position_mode_diff_turns_then_drives() {
        let mut p = model(Drive::Diff);
        p.command_position(1.0, 1.0, 0.0);
        p.update(&Pose::ZERO, 0.1, 0.0, 0);
        assert_eq!(p.velocity.x, 0.0, "not facing the goal yet");
        assert!(p.velocity.a > 0.0);
        p.est.a = std::f64::consts::FRAC_PI_4;
        p.cfg.localization = Localization::Odom;
        p.update(&Pose::ZERO, 0.1, 0.0, 0);
        assert!((p.velocity.x - 0.4).abs() < 1e-12);
    }
}
