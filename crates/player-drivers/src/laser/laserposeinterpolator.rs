//! `laserposeinterpolator`: laser scans stamped with the pose they were taken from.
//!
//! Requires a `laser` (SCAN data) and a `position2d` (STATE data); provides a `laser` that
//! publishes SCANPOSE. Scans are buffered until the pose after them arrives, and each one's
//! pose is interpolated linearly in time between the poses around it (the heading along the
//! shorter way round); with `interpolate 0` a scan takes the latest pose at once. Requests
//! to the provided laser are forwarded to the required one, as upstream does.
//!
//! Options (Player 3.0.2's, with its defaults): `interpolate` (1), `max_scans` (100: scans
//! buffered while waiting for the next pose; more are dropped with a warning),
//! `update_thresh [length angle]` (`[-1 -1]`: publish a scan only after the robot moved that
//! far or turned that much; -1 disables a dimension; the angle is in degrees, as Player reads
//! cfg angles), `update_interval` (-1: publish at least this often, in seconds) and
//! `send_all_scans` (1: publish every scan, overriding the thresholds).

use player_proto::{
    Body, DeviceAddr, InterfaceCode, LaserData, LaserDataScan, LaserDataScanpose, LaserMsg,
    Message, Pose2d, Position2dData, Position2dMsg,
};
use player_server::{Context, Driver, DriverBlock, DriverError, PendingReply};

use crate::forward::{Waiting, refuse_own_device};
use crate::options;
use pose::angle::{diff as angle_diff, normalize_atan2 as normalize};

/// The Player name of this driver.
pub const NAME: &str = "laserposeinterpolator";

/// The driver's settings, from its cfg block.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// Interpolate between poses (true) or take the latest pose (false).
    pub interpolate: bool,
    /// Scans buffered while waiting for the next pose.
    pub max_scans: usize,
    /// Minimum move (m) before a scan is published; negative = no threshold.
    pub update_dist: f64,
    /// Minimum turn (rad) before a scan is published; negative = no threshold.
    pub update_angle: f64,
    /// Longest time (s) between published scans; negative = no limit.
    pub update_interval: f64,
    /// Publish every scan, whatever the thresholds say.
    pub send_all_scans: bool,
}

impl Default for Settings {
    fn default() -> Settings {
        Settings {
            interpolate: true,
            max_scans: 100,
            update_dist: -1.0,
            update_angle: -1.0,
            update_interval: -1.0,
            send_all_scans: true,
        }
    }
}

impl Settings {
    /// Reads the options of a cfg block (absent ones keep Player's defaults).
    pub fn from_block(block: &DriverBlock) -> Result<Settings, DriverError> {
        let d = Settings::default();
        let max_scans = options::int(block, "max_scans")?.unwrap_or(100);
        if max_scans < 1 {
            return Err(DriverError::new(format!(
                "option `max_scans` must be at least 1, not {max_scans}"
            )));
        }
        Ok(Settings {
            interpolate: options::flag(block, "interpolate")?.unwrap_or(d.interpolate),
            max_scans: max_scans as usize,
            // A length and an angle (Player's ReadTupleLength and ReadTupleAngle, in the cfg's
            // units); a negative value only switches the test off.
            update_dist: options::tuple_length(block, "update_thresh", 0)?.unwrap_or(d.update_dist),
            update_angle: options::tuple_float(block, "update_thresh", 1)?.map_or(
                d.update_angle,
                |a| {
                    if a < 0.0 { a } else { a * block.units.angle }
                },
            ),
            update_interval: options::float(block, "update_interval")?.unwrap_or(d.update_interval),
            send_all_scans: options::flag(block, "send_all_scans")?.unwrap_or(d.send_all_scans),
        })
    }
}

/// The pose at time `t` on the straight line from `p0` (at `t0`) to `p1` (at `t1`).
pub fn interpolate_pose(p0: Pose2d, t0: f64, p1: Pose2d, t1: f64, t: f64) -> Pose2d {
    let span = t1 - t0;
    let f = (t - t0) / span;
    Pose2d {
        px: p0.px + f * (p1.px - p0.px),
        py: p0.py + f * (p1.py - p0.py),
        pa: normalize(p0.pa + f * angle_diff(p1.pa, p0.pa)),
    }
}

/// The pure part of the driver: scans and poses in, stamped scans out.
#[derive(Debug)]
pub struct Interpolator {
    settings: Settings,
    scans: Vec<(LaserDataScan, f64)>,
    last_pose: Option<(Pose2d, f64)>,
    last_published: Option<(Pose2d, f64)>,
}

impl Interpolator {
    /// An interpolator that has seen nothing.
    pub fn new(settings: Settings) -> Interpolator {
        Interpolator {
            settings,
            scans: Vec::new(),
            last_pose: None,
            last_published: None,
        }
    }

    /// Forgets every scan and pose (the driver stopped).
    pub fn reset(&mut self) {
        self.scans.clear();
        self.last_pose = None;
        self.last_published = None;
    }

    /// A scan taken at `time`: stamped at once without interpolation (after a first pose),
    /// else buffered for the next pose.
    pub fn scan(&mut self, scan: LaserDataScan, time: f64) -> Option<(LaserDataScanpose, f64)> {
        if !self.settings.interpolate {
            let (pose, _) = self.last_pose?;
            return Some((LaserDataScanpose { scan, pose }, time));
        }
        if self.scans.len() >= self.settings.max_scans {
            tracing::warn!(
                "exceeded maximum number of scans to buffer ({})",
                self.settings.max_scans
            );
            return None;
        }
        self.scans.push((scan, time));
        None
    }

    /// A pose at `time`: the buffered scans, stamped and filtered by the thresholds.
    pub fn pose(&mut self, pose: Pose2d, time: f64) -> Vec<(LaserDataScanpose, f64)> {
        let mut out = Vec::new();
        if let Some((p0, t0)) = self.last_pose {
            if self.settings.interpolate {
                for (scan, t) in std::mem::take(&mut self.scans) {
                    let stamped = interpolate_pose(p0, t0, pose, time, t);
                    if self.due(stamped, t) {
                        self.last_published = Some((stamped, t));
                        out.push((
                            LaserDataScanpose {
                                scan,
                                pose: stamped,
                            },
                            t,
                        ));
                    }
                }
            }
        }
        self.last_pose = Some((pose, time));
        out
    }

    fn due(&self, pose: Pose2d, t: f64) -> bool {
        let s = &self.settings;
        let Some((last, last_t)) = self.last_published else {
            return true;
        };
        s.send_all_scans
            || (s.update_dist >= 0.0
                && (pose.px - last.px).hypot(pose.py - last.py) >= s.update_dist)
            || (s.update_angle >= 0.0 && angle_diff(pose.pa, last.pa).abs() >= s.update_angle)
            || (s.update_interval >= 0.0 && t - last_t >= s.update_interval)
    }
}

/// The driver.
#[derive(Debug)]
pub struct LaserPoseInterpolator {
    addr: DeviceAddr,
    laser: DeviceAddr,
    position: DeviceAddr,
    interp: Interpolator,
    waiting: Waiting<PendingReply>,
}

impl LaserPoseInterpolator {
    /// Builds the driver from its cfg block.
    pub fn from_block(block: &DriverBlock) -> Result<LaserPoseInterpolator, DriverError> {
        let addr = block.provided(InterfaceCode::LASER)?;
        let laser = block.required(InterfaceCode::LASER, None)?.addr;
        refuse_own_device(addr, &[laser])?;
        let position = block.required(InterfaceCode::POSITION2D, None)?.addr;
        Ok(LaserPoseInterpolator {
            addr,
            laser,
            position,
            interp: Interpolator::new(Settings::from_block(block)?),
            waiting: Waiting::default(),
        })
    }
}

impl Driver for LaserPoseInterpolator {
    fn setup(&mut self, ctx: &mut Context<'_>) -> Result<(), DriverError> {
        self.interp.reset();
        ctx.subscribe(self.laser);
        ctx.subscribe(self.position);
        Ok(())
    }

    fn handle_data(&mut self, ctx: &mut Context<'_>, data: &Message) {
        let time = data.header.timestamp;
        match &data.body {
            Body::Laser(LaserMsg::Data(LaserData::Scan(scan)))
                if data.header.addr.same_device(&self.laser) =>
            {
                if let Some((stamped, t)) = self.interp.scan(scan.clone(), time) {
                    ctx.publish_at(self.addr, LaserData::ScanPose(stamped), t);
                }
            }
            Body::Position2d(Position2dMsg::Data(Position2dData::State(state)))
                if data.header.addr.same_device(&self.position) =>
            {
                for (stamped, t) in self.interp.pose(state.pos, time) {
                    ctx.publish_at(self.addr, LaserData::ScanPose(stamped), t);
                }
            }
            _ => {}
        }
    }

    crate::forward::pass_requests_to!(laser);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::pose;

    fn scan(n: usize) -> LaserDataScan {
        LaserDataScan {
            ranges: vec![n as f32; 3],
            ..LaserDataScan::default()
        }
    }

    #[test]
    fn scans_wait_for_the_next_pose_and_are_interpolated() {
        let mut i = Interpolator::new(Settings::default());
        assert!(i.scan(scan(0), 0.5).is_none(), "no pose yet: buffered");
        assert!(
            i.pose(pose(0.0, 0.0, 0.0), 1.0).is_empty(),
            "first pose only stored"
        );
        assert!(i.scan(scan(1), 1.25).is_none());
        assert!(i.scan(scan(2), 1.5).is_none());
        let out = i.pose(pose(2.0, -4.0, 1.0), 2.0);
        assert_eq!(
            out.len(),
            3,
            "the scan before the first pose is stamped too"
        );
        // The early scan extrapolates backwards along the same line, as upstream's formula does.
        assert_eq!(out[0].1, 0.5);
        assert!((out[0].0.pose.px + 1.0).abs() < 1e-12);
        assert!((out[1].0.pose.px - 0.5).abs() < 1e-12);
        assert!((out[1].0.pose.py + 1.0).abs() < 1e-12);
        assert!((out[1].0.pose.pa - 0.25).abs() < 1e-12);
        assert_eq!(out[2].0.scan.ranges, [2.0; 3]);
        assert!((out[2].0.pose.px - 1.0).abs() < 1e-12);
    }

    #[test]
    fn headings_interpolate_the_short_way_round() {
        let pi = std::f64::consts::PI;
        let p = interpolate_pose(
            pose(0.0, 0.0, pi - 0.1),
            0.0,
            pose(0.0, 0.0, -pi + 0.1),
            1.0,
            0.5,
        );
        assert!((p.pa.abs() - pi).abs() < 1e-9, "{}", p.pa);
        assert!((angle_diff(0.1, -0.1) - 0.2).abs() < 1e-12);
        assert!((angle_diff(-pi + 0.1, pi - 0.1) - 0.2).abs() < 1e-12);
    }

    #[test]
    fn without_interpolation_the_latest_pose_is_attached_at_once() {
        let mut i = Interpolator::new(Settings {
            interpolate: false,
            ..Settings::default()
        });
        assert!(i.scan(scan(0), 0.1).is_none(), "dropped before any pose");
        i.pose(pose(1.0, 2.0, 0.5), 0.2);
        let (s, t) = i.scan(scan(1), 0.3).unwrap();
        assert_eq!((s.pose, t), (pose(1.0, 2.0, 0.5), 0.3));
    }

    #[test]
    fn thresholds_choke_the_rate_unless_every_scan_is_wanted() {
        let mut i = Interpolator::new(Settings {
            send_all_scans: false,
            update_dist: 1.0,
            ..Settings::default()
        });
        i.pose(pose(0.0, 0.0, 0.0), 0.0);
        for k in 1..=10 {
            i.scan(scan(k), k as f64 * 0.1 - 0.05);
        }
        // 10 scans over a 1 m move: the first is published, then one per metre.
        let out = i.pose(pose(1.0, 0.0, 0.0), 1.0);
        assert_eq!(out.len(), 1);
        i.scan(scan(11), 1.5);
        i.scan(scan(12), 1.75);
        i.scan(scan(13), 2.0);
        let out = i.pose(pose(3.0, 0.0, 0.0), 2.0);
        // At 2.0 m (1.95 m on), 2.5 m (0.5 m on: held back) and 3.0 m (1.0 m on).
        let xs: Vec<f64> = out.iter().map(|(s, _)| s.pose.px).collect();
        assert_eq!(xs, [2.0, 3.0]);
    }

    #[test]
    fn the_buffer_is_bounded() {
        let mut i = Interpolator::new(Settings {
            max_scans: 2,
            ..Settings::default()
        });
        i.pose(pose(0.0, 0.0, 0.0), 0.0);
        for k in 0..5 {
            i.scan(scan(k), 0.1 * k as f64);
        }
        assert_eq!(i.pose(pose(1.0, 0.0, 0.0), 1.0).len(), 2);
    }

    #[test]
    fn options_and_their_errors() {
        let mut block = DriverBlock::default();
        assert_eq!(Settings::from_block(&block).unwrap(), Settings::default());
        block
            .options
            .insert("update_thresh".into(), vec!["0.5".into(), "90".into()]);
        block.options.insert("interpolate".into(), vec!["0".into()]);
        let s = Settings::from_block(&block).unwrap();
        assert!(!s.interpolate);
        assert_eq!(s.update_dist, 0.5);
        assert!((s.update_angle - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        block.options.insert("max_scans".into(), vec!["0".into()]);
        assert!(Settings::from_block(&block).is_err());
        block
            .options
            .insert("max_scans".into(), vec!["many".into()]);
        let e = Settings::from_block(&block).unwrap_err().to_string();
        assert!(e.contains("max_scans"), "{e}");
    }
}
