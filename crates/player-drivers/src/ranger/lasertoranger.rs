//! `lasertoranger` (Player 3.0.2 `server/drivers/ranger/lasertoranger.cc`): a `laser` device
//! read as a `ranger`, for programs written against Player 3's `RangerProxy`.
//!
//! cfg: `requires ["laser:N"]` (the first laser entry), `provides ["ranger:M"]`; options
//! `buggy_geom` (default 0: when 1, the z, roll and pitch of the laser's geometry are zeroed,
//! for laser drivers that leave them uninitialised) and `force_config [min_angle max_angle
//! angular_res max_range range_res]` (degrees and metres; overrides the configuration the laser
//! reports, for laser drivers that report a wrong one; exactly five values or none).
//!
//! At setup it subscribes to the laser and asks for its configuration (kept, so that ranger
//! INTNS and SET_CONFIG requests can send the laser a whole configuration). Each laser SCAN
//! becomes a ranger RANGE, then an INTNS when the scan has intensities; a SCANPOSE becomes
//! RANGESTAMPED/INTNSSTAMPED carrying the device geometry with the scan's pose; SCANANGLE is
//! not converted (as upstream).
//!
//! Ranger requests become laser requests: GET_GEOM (the laser's pose and size, as the device
//! and its one element), GET_CONFIG and SET_CONFIG (through the laser configuration, or the
//! forced one), INTNS (a laser SET_CONFIG with the intensity flag changed) and POWER; integer,
//! double and string property requests go to the laser unchanged.
//!
//! Differences from upstream, all where upstream is plainly broken: the stamped messages say
//! `have_geom` 1 (upstream fills the geometry but leaves the flag 0, and fills it into the
//! range message only, leaving INTNSSTAMPED's zero); configurations answered carry
//! `min_range` 0 (upstream leaves it uninitialised); each request gets its own answer
//! (upstream answers the last requester, and takes the first GET_CONFIG answer after setup
//! as its own even when a client asked).

use player_proto::{
    Body, DeviceAddr, InterfaceCode, LaserConfig, LaserData, LaserDataScan, LaserGeom, LaserMsg,
    LaserPowerConfig, LaserReq, Message, Pose3d, RangerConfig, RangerData, RangerDataIntns,
    RangerDataIntnsstamped, RangerDataRange, RangerDataRangestamped, RangerGeom, RangerReq,
};
use player_server::{
    Context, Driver, DriverBlock, DriverError, PendingReply, Reply, RequestError, RequestTicket,
};

use crate::forward::{Asker, Relayed, Waiting, ack_or_nack, acked, answer_body, converter_request};
use crate::options;

/// The name cfg files use.
pub const NAME: &str = "lasertoranger";

/// The ranger requests this driver answers (its CAPABILITIES).
const HANDLED: [u8; 5] = [
    RangerReq::POWER,
    RangerReq::INTNS,
    RangerReq::GET_GEOM,
    RangerReq::SET_CONFIG,
    RangerReq::GET_CONFIG,
];

/// The `force_config` option: the configuration reported whatever the laser says. Kept as
/// floats, as upstream stores it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ForcedConfig {
    /// Start angle (rad; written in degrees).
    pub min_angle: f32,
    /// End angle (rad; written in degrees).
    pub max_angle: f32,
    /// Angular resolution (rad; written in degrees).
    pub angular_res: f32,
    /// Maximum range (m).
    pub max_range: f32,
    /// Range resolution (m).
    pub range_res: f32,
}

impl ForcedConfig {
    /// Reads `force_config` from a block: `None` when absent, an error unless it has exactly
    /// five numbers (upstream's "Invalid number of forced settings").
    pub fn from_block(block: &DriverBlock) -> Result<Option<ForcedConfig>, DriverError> {
        let Some(values) = block.options.get("force_config") else {
            return Ok(None);
        };
        if values.is_empty() {
            return Ok(None);
        }
        if values.len() != 5 {
            return Err(DriverError::new(format!(
                "option `force_config` needs 5 values [min_angle max_angle angular_res max_range range_res], not {}",
                values.len()
            )));
        }
        // Angles in the cfg's angle unit (Player's ReadTupleAngle); the ranges are plain
        // numbers (ReadTupleFloat), not scaled by `unit_length`. All five are there.
        let angle =
            |i| options::tuple_angle(block, "force_config", i).map(|v| v.unwrap_or(0.0) as f32);
        let float =
            |i| options::tuple_float(block, "force_config", i).map(|v| v.unwrap_or(0.0) as f32);
        Ok(Some(ForcedConfig {
            min_angle: angle(0)?,
            max_angle: angle(1)?,
            angular_res: angle(2)?,
            max_range: float(3)?,
            range_res: float(4)?,
        }))
    }
}

/// The ranger configuration a laser configuration is reported as (upstream's
/// `HandleConfigResp`): angles, resolution and ranges from `force` when given, else from the
/// laser; the frequency always from the laser.
pub fn ranger_config(laser: &LaserConfig, force: Option<&ForcedConfig>) -> RangerConfig {
    let (min_angle, max_angle, angular_res, max_range, range_res) = match force {
        Some(f) => (
            f.min_angle,
            f.max_angle,
            f.angular_res,
            f.max_range,
            f.range_res,
        ),
        None => (
            laser.min_angle,
            laser.max_angle,
            laser.resolution,
            laser.max_range,
            laser.range_res,
        ),
    };
    RangerConfig {
        min_angle: f64::from(min_angle),
        max_angle: f64::from(max_angle),
        angular_res: f64::from(angular_res),
        min_range: 0.0,
        max_range: f64::from(max_range),
        range_res: f64::from(range_res),
        frequency: f64::from(laser.scanning_frequency),
    }
}

/// The ranger geometry of a laser (upstream's `HandleGeomRequest`): the laser's pose and size
/// as the device's and as its one element's; `buggy_geom` zeroes z, roll and pitch.
pub fn ranger_geom(laser: &LaserGeom, buggy_geom: bool) -> RangerGeom {
    let mut pose = laser.pose;
    if buggy_geom {
        pose.pz = 0.0;
        pose.proll = 0.0;
        pose.ppitch = 0.0;
    }
    RangerGeom {
        pose,
        size: laser.size,
        element_poses: vec![pose],
        element_sizes: vec![laser.size],
    }
}

/// The geometry before the laser answered: zeros, with one element (upstream's `Setup`).
fn empty_geom() -> RangerGeom {
    RangerGeom {
        element_poses: vec![Pose3d::default()],
        element_sizes: vec![Default::default()],
        ..RangerGeom::default()
    }
}

/// The ranger data of one laser scan: RANGE (when it has ranges) and INTNS (when it has
/// intensities), widened to doubles.
pub fn ranger_data(scan: &LaserDataScan) -> (Option<RangerDataRange>, Option<RangerDataIntns>) {
    let ranges = (!scan.ranges.is_empty()).then(|| RangerDataRange {
        ranges: scan.ranges.iter().map(|&r| f64::from(r)).collect(),
    });
    let intensities = (!scan.intensity.is_empty()).then(|| RangerDataIntns {
        intensities: scan.intensity.iter().map(|&v| f64::from(v)).collect(),
    });
    (ranges, intensities)
}

/// What an answer from the laser is for.
#[derive(Debug)]
enum Asked {
    Config(Asker),
    SetConfig(PendingReply),
    Intensity(PendingReply),
    Geom(PendingReply),
    Relayed(Relayed),
}

/// The driver. See the module docs.
#[derive(Debug)]
pub struct LaserToRanger {
    ranger: DeviceAddr,
    laser: DeviceAddr,
    buggy_geom: bool,
    force: Option<ForcedConfig>,
    /// The laser's configuration as last known (upstream's `laserConfig`).
    laser_config: LaserConfig,
    /// The device geometry (upstream's `deviceGeom`).
    geom: RangerGeom,
    waiting: Waiting<Asked>,
}

impl LaserToRanger {
    /// Builds the driver from its cfg block: one ranger provided, one laser required.
    pub fn from_block(block: &DriverBlock) -> Result<LaserToRanger, DriverError> {
        Ok(LaserToRanger {
            ranger: super::provided(block, InterfaceCode::RANGER)?,
            laser: block.required(InterfaceCode::LASER, None)?.addr,
            buggy_geom: super::buggy_geom(block)?,
            force: ForcedConfig::from_block(block)?,
            laser_config: LaserConfig::default(),
            geom: empty_geom(),
            waiting: Waiting::default(),
        })
    }

    fn answer_config(&mut self, reply: &Result<Message, RequestError>) -> Option<RangerConfig> {
        match LaserReq::in_reply(answer_body(reply)?)? {
            LaserReq::GetConfig(Some(c)) | LaserReq::SetConfig(Some(c)) => {
                self.laser_config = c.clone();
                Some(ranger_config(c, self.force.as_ref()))
            }
            _ => None,
        }
    }

    fn publish_scan(
        &mut self,
        ctx: &mut Context<'_>,
        scan: &LaserDataScan,
        at: f64,
        stamped: bool,
    ) {
        // Upstream keeps the laser configuration in step with the scans it sees.
        match self.force {
            Some(f) => {
                self.laser_config.min_angle = f.min_angle;
                self.laser_config.max_angle = f.max_angle;
                self.laser_config.resolution = f.angular_res;
                self.laser_config.max_range = f.max_range;
            }
            None => {
                self.laser_config.min_angle = scan.min_angle;
                self.laser_config.max_angle = scan.max_angle;
                self.laser_config.resolution = scan.resolution;
                self.laser_config.max_range = scan.max_range;
            }
        }
        let (ranges, intensities) = ranger_data(scan);
        if let Some(data) = ranges {
            let body = if stamped {
                RangerData::RangeStamped(RangerDataRangestamped {
                    data,
                    have_geom: 1,
                    geom: self.geom.clone(),
                    ..Default::default()
                })
            } else {
                RangerData::Range(data)
            };
            ctx.publish_at(self.ranger, body, at);
        }
        if let Some(data) = intensities {
            let body = if stamped {
                RangerData::IntnsStamped(RangerDataIntnsstamped {
                    data,
                    have_geom: 1,
                    geom: self.geom.clone(),
                    ..Default::default()
                })
            } else {
                RangerData::Intns(data)
            };
            ctx.publish_at(self.ranger, body, at);
        }
    }
}

impl Driver for LaserToRanger {
    fn setup(&mut self, ctx: &mut Context<'_>) -> Result<(), DriverError> {
        self.geom = empty_geom();
        ctx.subscribe(self.laser);
        let ticket = ctx.request(self.laser, LaserReq::GetConfig(None));
        self.waiting.insert(ticket, Asked::Config(Asker::Setup));
        Ok(())
    }

    fn handle_request(&mut self, ctx: &mut Context<'_>, request: &Message) -> Reply {
        let body = &request.body;
        let (laser, waiting) = (self.laser, &mut self.waiting);
        if let Some(reply) = converter_request(ctx, waiting, laser, body, &HANDLED, Asked::Relayed)
        {
            return reply;
        }
        let Body::Ranger(player_proto::RangerMsg::Req(req)) = body else {
            return Reply::NotHandled;
        };
        let (asked, to_laser): (fn(PendingReply) -> Asked, Body) = match req {
            RangerReq::Power(Some(p)) => (
                |p| Asked::Relayed(Relayed::Acked(p)),
                LaserReq::Power(Some(LaserPowerConfig { state: p.state })).into(),
            ),
            RangerReq::Intns(Some(i)) => {
                self.laser_config.intensity = i.state;
                (
                    Asked::Intensity,
                    LaserReq::SetConfig(Some(self.laser_config.clone())).into(),
                )
            }
            RangerReq::GetGeom(_) => (Asked::Geom, LaserReq::GetGeom(None).into()),
            RangerReq::SetConfig(Some(c)) => {
                let lc = &mut self.laser_config;
                lc.min_angle = c.min_angle as f32;
                lc.max_angle = c.max_angle as f32;
                lc.resolution = c.angular_res as f32;
                lc.max_range = c.max_range as f32;
                lc.range_res = c.range_res as f32;
                lc.scanning_frequency = c.frequency as f32;
                (
                    Asked::SetConfig,
                    LaserReq::SetConfig(Some(self.laser_config.clone())).into(),
                )
            }
            RangerReq::GetConfig(_) => (
                |p| Asked::Config(Asker::Client(p)),
                LaserReq::GetConfig(None).into(),
            ),
            _ => return Reply::NotHandled,
        };
        self.waiting.forward(ctx, self.laser, to_laser, asked)
    }

    fn handle_reply(
        &mut self,
        ctx: &mut Context<'_>,
        ticket: RequestTicket,
        reply: Result<Message, RequestError>,
    ) {
        let Some(asked) = self.waiting.take(ticket) else {
            return;
        };
        match asked {
            Asked::Config(asker) => {
                let config = self.answer_config(&reply);
                asker.answer(ctx, config.map(|c| RangerReq::GetConfig(Some(c))), || {
                    tracing::info!(
                        "{NAME} {}: the laser {} gave no configuration at startup",
                        self.ranger,
                        self.laser
                    )
                });
            }
            Asked::SetConfig(pending) => {
                let answer = match (&reply, self.answer_config(&reply)) {
                    (_, Some(c)) => Reply::ack(RangerReq::SetConfig(Some(c))),
                    // An ACK without the applied configuration: report the one sent.
                    (Ok(_), None) => Reply::ack(RangerReq::SetConfig(Some(ranger_config(
                        &self.laser_config,
                        self.force.as_ref(),
                    )))),
                    (Err(_), None) => Reply::Nack,
                };
                ctx.answer(pending, answer);
            }
            Asked::Intensity(pending) => {
                if reply.is_ok() {
                    self.answer_config(&reply);
                }
                ctx.answer(pending, acked(&reply));
            }
            Asked::Geom(pending) => {
                let geom = match answer_body(&reply).and_then(LaserReq::in_reply) {
                    Some(LaserReq::GetGeom(Some(g))) => {
                        self.geom = ranger_geom(g, self.buggy_geom);
                        Some(RangerReq::GetGeom(Some(self.geom.clone())))
                    }
                    _ => None,
                };
                ctx.answer(pending, ack_or_nack(geom));
            }
            Asked::Relayed(relayed) => relayed.answer(ctx, reply),
        }
    }

    fn handle_data(&mut self, ctx: &mut Context<'_>, data: &Message) {
        let at = data.header.timestamp;
        match &data.body {
            Body::Laser(LaserMsg::Data(LaserData::Scan(scan))) => {
                self.publish_scan(ctx, scan, at, false)
            }
            Body::Laser(LaserMsg::Data(LaserData::ScanPose(sp))) => {
                self.geom.pose = Pose3d {
                    px: sp.pose.px,
                    py: sp.pose.py,
                    pyaw: sp.pose.pa,
                    ..Pose3d::default()
                };
                self.geom.element_poses = vec![self.geom.pose];
                self.publish_scan(ctx, &sp.scan, at, true)
            }
            other => tracing::debug!("{NAME}: not converting {}", other.constant()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{Harness, addr, block};
    use player_proto::{Bbox3d, LaserDataScanpose, Pose2d, RangerIntnsConfig, RangerMsg};

    fn ranger() -> DeviceAddr {
        addr(InterfaceCode::RANGER, 2)
    }

    fn laser() -> DeviceAddr {
        addr(InterfaceCode::LASER, 0)
    }

    fn sick() -> LaserConfig {
        LaserConfig {
            min_angle: -1.25,
            max_angle: 1.25,
            resolution: 0.0174533,
            max_range: 8.0,
            range_res: 0.01,
            intensity: 0,
            scanning_frequency: 10.0,
        }
    }

    fn ready(options: &[(&str, &str)]) -> Harness<LaserToRanger> {
        let b = block(NAME, &[ranger()], &[laser()], options);
        let mut h = Harness::new(LaserToRanger::from_block(&b).unwrap());
        let out = h.setup();
        assert_eq!(out.subscriptions(), vec![laser()]);
        let req = &out.requests()[0];
        assert_eq!(req.2, LaserReq::GetConfig(None).into());
        assert!(
            h.ack(req.0, laser(), LaserReq::GetConfig(Some(sick())))
                .answers()
                .is_empty()
        );
        h
    }

    fn scan(ranges: &[f32], intensity: &[u8]) -> LaserDataScan {
        LaserDataScan {
            min_angle: -1.25,
            max_angle: 1.25,
            resolution: 0.0174533,
            max_range: 8.0,
            ranges: ranges.to_vec(),
            intensity: intensity.to_vec(),
            id: 3,
        }
    }

    #[test]
    fn forced_configurations_are_five_values_in_degrees_and_metres() {
        let none = block(NAME, &[ranger()], &[laser()], &[]);
        assert_eq!(ForcedConfig::from_block(&none).unwrap(), None);
        let five = block(
            NAME,
            &[ranger()],
            &[laser()],
            &[("force_config", "-90 90 1 5.5 0.01")],
        );
        let f = ForcedConfig::from_block(&five).unwrap().unwrap();
        assert_eq!(f.min_angle, (-90f64).to_radians() as f32);
        assert_eq!(f.angular_res, 1f64.to_radians() as f32);
        assert_eq!((f.max_range, f.range_res), (5.5, 0.01));
        let three = block(NAME, &[ranger()], &[laser()], &[("force_config", "1 2 3")]);
        let e = LaserToRanger::from_block(&three).unwrap_err().to_string();
        assert!(e.contains("needs 5 values"), "{e}");
        let bad = block(
            NAME,
            &[ranger()],
            &[laser()],
            &[("force_config", "1 2 x 4 5")],
        );
        assert!(ForcedConfig::from_block(&bad).is_err());
    }

    #[test]
    fn configurations_geometry_and_data_convert_as_upstream() {
        let c = ranger_config(&sick(), None);
        assert_eq!(c.min_angle, f64::from(-1.25f32));
        assert_eq!(c.angular_res, f64::from(0.0174533f32));
        assert_eq!((c.min_range, c.max_range, c.frequency), (0.0, 8.0, 10.0));
        let forced = ForcedConfig {
            min_angle: -1.0,
            max_angle: 1.0,
            angular_res: 0.5,
            max_range: 3.0,
            range_res: 0.1,
        };
        let c = ranger_config(&sick(), Some(&forced));
        assert_eq!((c.min_angle, c.max_range, c.frequency), (-1.0, 3.0, 10.0));
        let lg = LaserGeom {
            pose: Pose3d {
                px: 0.2,
                pz: 7.0,
                proll: 1.0,
                ppitch: 2.0,
                pyaw: 0.1,
                ..Default::default()
            },
            size: Bbox3d {
                sw: 0.1,
                sl: 0.2,
                sh: 0.3,
            },
        };
        let g = ranger_geom(&lg, false);
        assert_eq!(g.pose, lg.pose);
        assert_eq!(
            (g.element_poses.clone(), g.element_sizes.clone()),
            (vec![lg.pose], vec![lg.size])
        );
        let g = ranger_geom(&lg, true);
        assert_eq!(
            (g.pose.pz, g.pose.proll, g.pose.ppitch, g.pose.px),
            (0.0, 0.0, 0.0, 0.2)
        );
        assert_eq!(g.element_poses, vec![g.pose]);
        let (r, i) = ranger_data(&scan(&[1.5, 2.0], &[]));
        assert_eq!(r.unwrap().ranges, vec![1.5, 2.0]);
        assert!(i.is_none());
    }

    #[test]
    fn scans_become_ranges_then_intensities() {
        let mut h = ready(&[]);
        let out = h.data(laser(), LaserData::Scan(scan(&[1.0, 2.5], &[0, 1])), 6.0);
        assert_eq!(
            out.bodies(),
            vec![
                Body::from(RangerData::Range(RangerDataRange {
                    ranges: vec![1.0, 2.5]
                })),
                Body::from(RangerData::Intns(RangerDataIntns {
                    intensities: vec![0.0, 1.0]
                })),
            ]
        );
        assert!(
            out.published
                .iter()
                .all(|p| p.addr == ranger() && p.timestamp == Some(6.0))
        );
        assert!(
            h.data(laser(), LaserData::Scan(scan(&[], &[])), 7.0)
                .published
                .is_empty()
        );
    }

    #[test]
    fn scans_with_a_pose_become_stamped_readings_with_the_geometry() {
        let mut h = ready(&[]);
        let out = h.data(
            laser(),
            LaserData::ScanPose(LaserDataScanpose {
                scan: scan(&[3.0], &[2]),
                pose: Pose2d {
                    px: 1.0,
                    py: 2.0,
                    pa: 0.5,
                },
            }),
            1.0,
        );
        let bodies = out.bodies();
        let Body::Ranger(RangerMsg::Data(RangerData::RangeStamped(r))) = &bodies[0] else {
            panic!("{bodies:?}");
        };
        assert_eq!(r.data.ranges, vec![3.0]);
        assert_eq!(r.have_geom, 1);
        assert_eq!(
            (r.geom.pose.px, r.geom.pose.py, r.geom.pose.pyaw),
            (1.0, 2.0, 0.5)
        );
        assert_eq!(r.geom.element_poses, vec![r.geom.pose]);
        let Body::Ranger(RangerMsg::Data(RangerData::IntnsStamped(i))) = &bodies[1] else {
            panic!("{bodies:?}");
        };
        assert_eq!(
            (i.data.intensities.clone(), i.geom.clone()),
            (vec![2.0], r.geom.clone())
        );
    }

    #[test]
    fn ranger_requests_become_laser_requests() {
        let mut h = ready(&[("buggy_geom", "1")]);
        // GET_GEOM
        let (reply, token, out) = h.request(ranger(), RangerReq::GetGeom(None));
        assert_eq!(reply, Reply::Deferred);
        let req = &out.requests()[0];
        assert_eq!((req.1, &req.2), (laser(), &LaserReq::GetGeom(None).into()));
        let lg = LaserGeom {
            pose: Pose3d {
                px: 0.1,
                pz: 0.5,
                ..Default::default()
            },
            size: Bbox3d {
                sw: 0.1,
                sl: 0.1,
                sh: 0.1,
            },
        };
        let out = h.ack(req.0, laser(), LaserReq::GetGeom(Some(lg.clone())));
        assert_eq!(
            out.answers(),
            vec![(
                token,
                Reply::ack(RangerReq::GetGeom(Some(ranger_geom(&lg, true))))
            )]
        );
        // GET_CONFIG
        let (_, token, out) = h.request(ranger(), RangerReq::GetConfig(None));
        let req = &out.requests()[0];
        let out = h.ack(req.0, laser(), LaserReq::GetConfig(Some(sick())));
        assert_eq!(
            out.answers(),
            vec![(
                token,
                Reply::ack(RangerReq::GetConfig(Some(ranger_config(&sick(), None))))
            )]
        );
        // INTNS: the stored laser configuration with the flag changed
        let (_, token, out) = h.request(
            ranger(),
            RangerReq::Intns(Some(RangerIntnsConfig { state: 1 })),
        );
        let req = &out.requests()[0];
        let expected = LaserConfig {
            intensity: 1,
            ..sick()
        };
        assert_eq!(req.2, LaserReq::SetConfig(Some(expected.clone())).into());
        let out = h.ack(req.0, laser(), LaserReq::SetConfig(Some(expected)));
        assert_eq!(out.answers(), vec![(token, Reply::empty_ack())]);
        // SET_CONFIG refused by the laser
        let wanted = RangerConfig {
            min_angle: -0.5,
            max_angle: 0.5,
            angular_res: 0.01,
            max_range: 4.0,
            frequency: 5.0,
            ..Default::default()
        };
        let (_, token, out) = h.request(ranger(), RangerReq::SetConfig(Some(wanted)));
        let req = &out.requests()[0];
        let Body::Laser(LaserMsg::Req(LaserReq::SetConfig(Some(sent)))) = &req.2 else {
            panic!("{:?}", req.2);
        };
        assert_eq!(
            (sent.min_angle, sent.max_range, sent.intensity),
            (-0.5, 4.0, 1)
        );
        assert_eq!(h.nack(req.0).answers(), vec![(token, Reply::Nack)]);
    }
}
