//! `mbicp`: odometry corrected by scan matching, as Player 3.0.2's driver.
//!
//! Requires a `position2d` (the odometry: an initial guess of each motion) and a `laser`
//! publishing SCANPOSE data (each scan with the odometric pose it was taken from, e.g. from
//! `laserposeinterpolator`); provides a `position2d` whose pose is the odometry corrected by
//! matching consecutive scans with metric-based ICP ([`alg`]).
//!
//! As upstream: the first scan starts the corrected pose at its odometric pose. Each later
//! scan taken from a different odometric pose is matched against the previous one, from
//! the odometric motion of the laser as the guess; a converged match replaces that motion,
//! any other outcome (no convergence within `MaxIter`, too few pairs, a singular system)
//! keeps the odometric one, with a warning. Each odometry STATE is republished with the
//! pose moved to the corrected pose of the last matched scan plus the odometric motion
//! since; velocity and stall pass through. Geometry DATA, commands and requests pass to and
//! from the odometry device; when the last client leaves the base is told to stop.
//!
//! Options (Player 3.0.2's, with the defaults its code uses — its documentation lists
//! `filter 0.95`, the code reads 0.85): `max_laser_range` (7.9 m), `laserPose_x` (0.16 m),
//! `laserPose_y` (0), `laserPose_th` (0 rad; read as written, not degrees), `radial_window`
//! (0.3 m), `angular_window` (1.57/3 rad), `L` (3.0 m), `laserStep` (1), `MaxDistInter`
//! (0.5), `filter` (0.85), `ProjectionFilter` (1), `AsocError` (0.1), `MaxIter` (50),
//! `errorRatio` (0.0001), `errx_out`, `erry_out`, `errt_out` (0.0001) and `IterSmoothConv`
//! (2). See [`alg::Params`] for what each does.

pub mod alg;

use player_proto::{
    Body, DeviceAddr, InterfaceCode, LaserData, LaserDataScanpose, LaserMsg, Message, Pose2d,
    Position2dCmd, Position2dCmdVel, Position2dData, Position2dMsg,
};
use player_server::{Context, Driver, DriverBlock, DriverError, PendingReply};

use crate::forward::{Waiting, refuse_own_device};
use crate::options;
use alg::{Frame, Outcome, Params, Reading};

/// The Player name of this driver.
pub const NAME: &str = "mbicp";

/// The driver's settings, from its cfg block.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// The matcher's tuning.
    pub params: Params,
    /// Where the laser sits on the robot (`laserPose_x/y/th`): scans are matched in the
    /// laser's frame and the motion is carried back to the robot's.
    pub laser_pose: Frame,
}

impl Default for Settings {
    fn default() -> Settings {
        Settings {
            params: Params::default(),
            laser_pose: Frame::new(0.16, 0.0, 0.0),
        }
    }
}

impl Settings {
    /// Reads the options of a cfg block (absent ones keep Player's defaults).
    pub fn from_block(block: &DriverBlock) -> Result<Settings, DriverError> {
        let d = Settings::default();
        let p = &d.params;
        let float = |key: &str, default: f64| -> Result<f64, DriverError> {
            Ok(options::float(block, key)?.unwrap_or(default))
        };
        let count = |key: &str, default: usize, least: i64| -> Result<usize, DriverError> {
            match options::int(block, key)? {
                None => Ok(default),
                Some(v) if v >= least => Ok(v as usize),
                Some(v) => Err(DriverError::new(format!(
                    "option `{key}` must be at least {least}, not {v}"
                ))),
            }
        };
        let params = Params {
            max_laser_range: float("max_laser_range", p.max_laser_range)?,
            angular_window: float("angular_window", p.angular_window)?,
            radial_window: float("radial_window", p.radial_window)?,
            l: float("L", p.l)?,
            laser_step: count("laserStep", p.laser_step, 1)?,
            max_dist_inter: float("MaxDistInter", p.max_dist_inter)?,
            filter: float("filter", p.filter)?,
            projection_filter: options::int(block, "ProjectionFilter")?
                .map_or(p.projection_filter, |v| v == 1),
            asoc_error: float("AsocError", p.asoc_error)?,
            max_iter: count("MaxIter", p.max_iter, 0)?,
            error_ratio: float("errorRatio", p.error_ratio)?,
            err_out: Frame::new(
                float("errx_out", p.err_out.x)?,
                float("erry_out", p.err_out.y)?,
                float("errt_out", p.err_out.th)?,
            ),
            iter_smooth_conv: count("IterSmoothConv", p.iter_smooth_conv, 0)?,
        };
        Ok(Settings {
            params,
            laser_pose: Frame::new(
                float("laserPose_x", d.laser_pose.x)?,
                float("laserPose_y", d.laser_pose.y)?,
                float("laserPose_th", d.laser_pose.th)?,
            ),
        })
    }
}

/// The readings of a scan, each with its bearing.
pub fn readings(scan: &player_proto::LaserDataScan) -> Vec<Reading> {
    scan.ranges
        .iter()
        .enumerate()
        .map(|(i, &r)| Reading {
            r: r as f64,
            t: scan.min_angle as f64 + i as f64 * scan.resolution as f64,
        })
        .collect()
}

fn frame(p: &Pose2d) -> Frame {
    Frame::new(p.px, p.py, p.pa)
}

fn pose(f: &Frame) -> Pose2d {
    Pose2d {
        px: f.x,
        py: f.y,
        pa: f.th,
    }
}

/// The pose tracker: odometric poses and scans in, corrected poses out (no I/O).
#[derive(Clone, Debug)]
pub struct Tracker {
    settings: Settings,
    last: Option<Matched>,
}

/// The last scan matched (or the first one) and what is known of where it was taken.
#[derive(Clone, Debug)]
struct Matched {
    scan: Vec<Reading>,
    odometry: Frame,
    corrected: Frame,
}

impl Tracker {
    /// A tracker that has seen no scan yet.
    pub fn new(settings: Settings) -> Tracker {
        Tracker {
            settings,
            last: None,
        }
    }

    /// Forgets every scan.
    pub fn reset(&mut self) {
        self.last = None;
    }

    /// A scan taken from odometric pose `odometry`; returns the match's outcome when it
    /// was matched (not for the first scan, nor one taken from the same pose as the last).
    pub fn scan(&mut self, scan: Vec<Reading>, odometry: Frame) -> Option<Outcome> {
        let Some(last) = &mut self.last else {
            self.last = Some(Matched {
                scan,
                odometry,
                corrected: odometry,
            });
            return None;
        };
        if last.odometry == odometry {
            return None;
        }
        let lp = self.settings.laser_pose;
        let guess = last
            .odometry
            .compose(&lp)
            .inverse()
            .compose(&odometry.compose(&lp));
        let outcome = alg::match_scans(&last.scan, &scan, guess, &self.settings.params);
        let laser_motion = match outcome {
            Outcome::Converged(f) => f,
            _ => guess,
        };
        let motion = lp.compose(&laser_motion).compose(&lp.inverse());
        last.corrected = last.corrected.compose(&motion);
        last.odometry = odometry;
        last.scan = scan;
        Some(outcome)
    }

    /// The corrected pose for odometric pose `odometry` (itself before the first scan).
    pub fn correct(&self, odometry: Frame) -> Frame {
        match &self.last {
            None => odometry,
            Some(m) => m
                .corrected
                .compose(&m.odometry.inverse().compose(&odometry)),
        }
    }
}

/// The `mbicp` driver.
pub struct Mbicp {
    addr: DeviceAddr,
    odom: DeviceAddr,
    laser: DeviceAddr,
    tracker: Tracker,
    waiting: Waiting<PendingReply>,
}

impl Mbicp {
    /// Builds the driver from its cfg block.
    pub fn from_block(block: &DriverBlock) -> Result<Mbicp, DriverError> {
        let addr = block.provided(InterfaceCode::POSITION2D)?;
        let odom = block.required(InterfaceCode::POSITION2D, None)?.addr;
        refuse_own_device(addr, &[odom])?;
        let laser = block.required(InterfaceCode::LASER, None)?.addr;
        Ok(Mbicp {
            addr,
            odom,
            laser,
            tracker: Tracker::new(Settings::from_block(block)?),
            waiting: Waiting::default(),
        })
    }

    fn take_scan(&mut self, sp: &LaserDataScanpose) {
        match self.tracker.scan(readings(&sp.scan), frame(&sp.pose)) {
            Some(Outcome::MaxIterations(_)) => {
                tracing::warn!("mbicp: reached the maximum number of iterations; using odometry")
            }
            Some(Outcome::AssociationFailure) => {
                tracing::warn!("mbicp: failure in the association step; using odometry")
            }
            Some(Outcome::MinimizationFailure) => {
                tracing::warn!("mbicp: failure in the minimization step; using odometry")
            }
            _ => {}
        }
    }
}

impl Driver for Mbicp {
    fn setup(&mut self, ctx: &mut Context<'_>) -> Result<(), DriverError> {
        self.tracker.reset();
        ctx.subscribe(self.odom);
        ctx.subscribe(self.laser);
        Ok(())
    }

    fn teardown(&mut self, ctx: &mut Context<'_>) {
        // As upstream: stop the base before letting go of it.
        ctx.command(
            self.odom,
            Position2dCmd::Vel(Position2dCmdVel {
                vel: Pose2d::default(),
                state: 0,
            }),
        );
    }

    fn handle_data(&mut self, ctx: &mut Context<'_>, data: &Message) {
        let from = data.header.addr;
        let time = data.header.timestamp;
        match &data.body {
            Body::Laser(LaserMsg::Data(LaserData::ScanPose(sp)))
                if from.same_device(&self.laser) =>
            {
                self.take_scan(sp)
            }
            Body::Position2d(Position2dMsg::Data(Position2dData::State(state)))
                if from.same_device(&self.odom) =>
            {
                let mut state = state.clone();
                state.pos = pose(&self.tracker.correct(frame(&state.pos)));
                ctx.publish_at(self.addr, Position2dData::State(state), time);
            }
            Body::Position2d(Position2dMsg::Data(Position2dData::Geom(geom)))
                if from.same_device(&self.odom) =>
            {
                ctx.publish_at(self.addr, Position2dData::Geom(geom.clone()), time);
            }
            _ => {}
        }
    }

    fn handle_command(&mut self, ctx: &mut Context<'_>, command: &Message) {
        ctx.command(self.odom, command.body.clone());
    }

    crate::forward::pass_requests_to!(odom);
}

#[cfg(test)]
mod tests {
    use super::*;
    use alg::tests::scan;

    fn close(a: Frame, b: Frame, tol_xy: f64, tol_th: f64) -> bool {
        (a.x - b.x).abs() < tol_xy && (a.y - b.y).abs() < tol_xy && (a.th - b.th).abs() < tol_th
    }

    #[test]
    fn odometry_passes_until_the_first_scan_then_is_corrected_by_matches() {
        let lp = Settings::default().laser_pose;
        let mut t = Tracker::new(Settings::default());
        let odo0 = Frame::new(-1.0, 0.2, 0.1);
        assert_eq!(t.correct(odo0), odo0);
        // The true robot starts where odometry says.
        let truth0 = odo0;
        assert_eq!(t.scan(scan(truth0.compose(&lp)), odo0), None);
        assert_eq!(t.correct(odo0), odo0);
        // The robot turns 0.1 rad and creeps 5 cm; odometry claims 0.07 rad and 8 cm.
        let truth1 = truth0.compose(&Frame::new(0.05, 0.0, 0.1));
        let odo1 = odo0.compose(&Frame::new(0.08, 0.0, 0.07));
        let out = t.scan(scan(truth1.compose(&lp)), odo1);
        assert!(matches!(out, Some(Outcome::Converged(_))), "{out:?}");
        let c = t.correct(odo1);
        assert!(close(c, truth1, 0.005, 0.003), "{c:?} vs {truth1:?}");
        // Odometry between scans is added to the corrected pose.
        let step = Frame::new(0.01, 0.0, 0.0);
        let c2 = t.correct(odo1.compose(&step));
        assert!(close(c2, c.compose(&step), 1e-9, 1e-9), "{c2:?}");
        // A scan from the same odometric pose is not matched.
        assert_eq!(t.scan(scan(truth1.compose(&lp)), odo1), None);
        t.reset();
        assert_eq!(t.correct(odo1), odo1);
    }

    #[test]
    fn a_failed_match_keeps_the_odometric_motion() {
        let mut t = Tracker::new(Settings::default());
        let far: Vec<Reading> = (0..181)
            .map(|i| Reading {
                r: 9.0,
                t: -1.5 + i as f64 * 0.01,
            })
            .collect();
        let odo0 = Frame::new(1.0, 1.0, 0.5);
        t.scan(far.clone(), odo0);
        let odo1 = odo0.compose(&Frame::new(0.3, 0.0, 0.2));
        assert_eq!(t.scan(far, odo1), Some(Outcome::AssociationFailure));
        let c = t.correct(odo1);
        assert!(close(c, odo1, 1e-9, 1e-9), "{c:?}");
    }

    #[test]
    fn options_with_their_defaults_and_errors() {
        let mut block = DriverBlock::default();
        let s = Settings::from_block(&block).unwrap();
        assert_eq!(s, Settings::default());
        assert_eq!(s.params.filter, 0.85);
        assert_eq!(s.params.max_iter, 50);
        assert_eq!(s.params.radial_window, 0.3);
        for (k, v) in [
            ("max_laser_range", "7.5"),
            ("laserPose_x", "0.2"),
            ("laserPose_th", "0.5"),
            ("radial_window", "0.09"),
            ("angular_window", "0.4"),
            ("L", "2"),
            ("laserStep", "2"),
            ("MaxDistInter", "0.3"),
            ("filter", "0.95"),
            ("ProjectionFilter", "0"),
            ("AsocError", "0.2"),
            ("MaxIter", "500"),
            ("errorRatio", "0.001"),
            ("errt_out", "0.01"),
            ("IterSmoothConv", "3"),
        ] {
            block.options.insert(k.into(), vec![v.into()]);
        }
        let s = Settings::from_block(&block).unwrap();
        assert_eq!(s.laser_pose, Frame::new(0.2, 0.0, 0.5));
        let p = &s.params;
        assert_eq!(
            (p.max_laser_range, p.radial_window, p.angular_window, p.l),
            (7.5, 0.09, 0.4, 2.0)
        );
        assert_eq!((p.laser_step, p.max_iter, p.iter_smooth_conv), (2, 500, 3));
        assert_eq!((p.max_dist_inter, p.filter, p.asoc_error), (0.3, 0.95, 0.2));
        assert!(!p.projection_filter);
        assert_eq!(
            (p.error_ratio, p.err_out.th, p.err_out.x),
            (0.001, 0.01, 0.0001)
        );
        block.options.insert("laserStep".into(), vec!["0".into()]);
        let e = Settings::from_block(&block).unwrap_err().to_string();
        assert!(e.contains("laserStep"), "{e}");
        block.options.insert("laserStep".into(), vec!["1".into()]);
        block.options.insert("L".into(), vec!["long".into()]);
        let e = Settings::from_block(&block).unwrap_err().to_string();
        assert!(e.contains('L'), "{e}");
    }

    fn laser_scan(readings: &[Reading]) -> player_proto::LaserDataScan {
        player_proto::LaserDataScan {
            min_angle: readings[0].t as f32,
            max_angle: readings[readings.len() - 1].t as f32,
            resolution: (readings[1].t - readings[0].t) as f32,
            max_range: 8.0,
            ranges: readings.iter().map(|r| r.r as f32).collect(),
            intensity: vec![0; readings.len()],
            id: 0,
        }
    }

    #[test]
    fn the_driver_corrects_odometry_data_and_passes_the_rest_to_the_base() {
        use crate::testing::{Harness, addr, block};
        use player_proto::{Position2dDataState, Position2dGeom};
        let (me, odom, laser) = (
            addr(InterfaceCode::POSITION2D, 1),
            addr(InterfaceCode::POSITION2D, 0),
            addr(InterfaceCode::LASER, 1),
        );
        let b = block(NAME, &[me], &[odom, laser], &[("laserPose_x", "0")]);
        let mut h = Harness::new(Mbicp::from_block(&b).unwrap());
        assert_eq!(h.setup().subscriptions(), vec![odom, laser]);
        let state = |f: Frame| Position2dDataState {
            pos: pose(&f),
            vel: Pose2d {
                px: 0.2,
                py: 0.0,
                pa: 0.1,
            },
            stall: 0,
        };
        let published_pose = |out: crate::testing::Outcome| match &out.published[..] {
            [p] if p.addr == me => match &p.body {
                Body::Position2d(Position2dMsg::Data(Position2dData::State(s))) => {
                    assert_eq!(s.vel.px, 0.2);
                    frame(&s.pos)
                }
                other => panic!("{other:?}"),
            },
            other => panic!("{other:?}"),
        };
        // Before any scan, odometry passes unchanged.
        let odo0 = Frame::new(-1.0, 0.2, 0.1);
        assert_eq!(
            published_pose(h.data(odom, Position2dData::State(state(odo0)), 1.0)),
            odo0
        );
        // Two scans: the robot moved 10 cm, odometry says 15 cm.
        let truth1 = odo0.compose(&Frame::new(0.1, 0.0, 0.0));
        let odo1 = odo0.compose(&Frame::new(0.15, 0.0, 0.0));
        for (at, odo) in [(odo0, odo0), (truth1, odo1)] {
            let sp = LaserDataScanpose {
                scan: laser_scan(&alg::tests::scan(at)),
                pose: pose(&odo),
            };
            assert!(
                h.data(laser, LaserData::ScanPose(sp), 1.1)
                    .published
                    .is_empty()
            );
        }
        let c = published_pose(h.data(odom, Position2dData::State(state(odo1)), 1.2));
        assert!(close(c, truth1, 0.01, 0.01), "{c:?} vs {truth1:?}");
        // Geometry passes through; commands go to the base.
        let geom = Position2dGeom::default();
        let out = h.data(odom, Position2dData::Geom(geom.clone()), 1.3);
        assert_eq!(out.published.len(), 1);
        assert_eq!(out.published[0].addr, me);
        let cmd = Position2dCmd::Vel(Position2dCmdVel {
            vel: Pose2d {
                px: 0.3,
                py: 0.0,
                pa: 0.0,
            },
            state: 1,
        });
        let out = h.command(me, cmd.clone());
        assert!(matches!(
            &out.actions[..],
            [player_server::Action::Command(to, body)] if *to == odom && *body == Body::from(cmd)
        ));
    }

    #[test]
    fn bearings_come_from_the_scan_geometry() {
        let scan = player_proto::LaserDataScan {
            min_angle: -1.0,
            max_angle: 1.0,
            resolution: 0.5,
            max_range: 8.0,
            ranges: vec![1.0, 2.0, 3.0, 4.0, 5.0],
            intensity: vec![],
            id: 0,
        };
        let r = readings(&scan);
        assert_eq!(r.len(), 5);
        assert_eq!((r[4].r, r[4].t), (5.0, 1.0));
        assert_eq!(r[1].t, -0.5);
    }
}
