//! `rangertolaser` (Player 3.0.2 `server/drivers/ranger/rangertolaser.cc`): a `ranger` device
//! read as a `laser`, for programs written against Player 2's `LaserProxy`.
//!
//! cfg: `requires ["ranger:N"]` (the first ranger entry), `provides ["laser:M"]`; no options.
//!
//! At setup it subscribes to the ranger and asks for its configuration (ranger GET_CONFIG);
//! every scan then carries that configuration's start and end angles, angular resolution and
//! maximum range, with scan `id` 0, as upstream.
//!
//! Laser requests become ranger requests and the ranger's answers become laser answers:
//! GET_GEOM (the ranger's pose and size), GET_CONFIG, POWER, and SET_CONFIG (sent as a ranger
//! SET_CONFIG plus a ranger INTNS for the intensity flag, ACKed once both are, NACKed at the
//! first refusal). Integer, double and string property requests go to the ranger unchanged.
//!
//! Unlike upstream, a scan's intensities join its ranges. Upstream publishes a separate laser
//! scan for every ranger DATA message, so the INTNS that Stage (and the hokuyo drivers) send
//! right after each RANGE becomes a second scan with no ranges, and a laser client sees every
//! other scan empty. Here a RANGE is held until its INTNS arrives and both go out as one scan;
//! a ranger that sends no intensities has its scan sent when the driver is next woken, in the
//! same pass of the server (no added latency), or at the latest with its next scan.
//! Also unlike upstream (which keeps only the last requester), concurrent requests from
//! several clients are each answered with their own reply.

use std::collections::HashMap;

use player_proto::{
    Body, DeviceAddr, InterfaceCode, LaserConfig, LaserData, LaserDataScan, LaserDataScanpose,
    LaserGeom, LaserMsg, LaserReq, Message, Pose2d, RangerConfig, RangerData, RangerGeom,
    RangerIntnsConfig, RangerMsg, RangerPowerConfig, RangerReq,
};
use player_server::{
    Context, Driver, DriverBlock, DriverError, PendingReply, Reply, RequestError, RequestTicket,
};

use crate::forward::{Asker, Relayed, Waiting, ack_or_nack, answer_body, converter_request};

/// The name cfg files use.
pub const NAME: &str = "rangertolaser";

/// The laser requests this driver answers (its CAPABILITIES).
const HANDLED: [u8; 4] = [
    LaserReq::POWER,
    LaserReq::GET_GEOM,
    LaserReq::SET_CONFIG,
    LaserReq::GET_CONFIG,
];

/// The laser configuration upstream's `CopyConfig` makes of a ranger configuration: angles,
/// resolution and ranges narrowed to floats; `intensity` is the laser's own flag (the ranger
/// configuration has none).
pub fn laser_config(ranger: &RangerConfig, intensity: u8) -> LaserConfig {
    LaserConfig {
        min_angle: ranger.min_angle as f32,
        max_angle: ranger.max_angle as f32,
        resolution: ranger.angular_res as f32,
        max_range: ranger.max_range as f32,
        range_res: ranger.range_res as f32,
        intensity,
        scanning_frequency: ranger.frequency as f32,
    }
}

/// The ranger SET_CONFIG a laser SET_CONFIG becomes. The laser has no minimum range, which
/// upstream leaves uninitialised; here it is 0.
pub fn ranger_config(laser: &LaserConfig) -> RangerConfig {
    RangerConfig {
        min_angle: f64::from(laser.min_angle),
        max_angle: f64::from(laser.max_angle),
        angular_res: f64::from(laser.resolution),
        min_range: 0.0,
        max_range: f64::from(laser.max_range),
        range_res: f64::from(laser.range_res),
        frequency: f64::from(laser.scanning_frequency),
    }
}

/// The laser geometry of a ranger: the device's pose and size (its elements are not
/// reported, as upstream's `HandleGeomRequest`).
pub fn laser_geom(ranger: &RangerGeom) -> LaserGeom {
    LaserGeom {
        pose: ranger.pose,
        size: ranger.size,
    }
}

/// A ranger intensity as a laser intensity byte: upstream's `static_cast<uint8_t>`
/// (truncated toward zero), saturating where C++ leaves the result undefined.
pub fn intensity_byte(v: f64) -> u8 {
    v as u8
}

/// One laser scan: `ranges` (narrowed to floats) and `intensities` (as bytes) with the scan
/// layout of `config`; `id` 0 as upstream.
pub fn laser_scan(config: &LaserConfig, ranges: &[f64], intensities: &[f64]) -> LaserDataScan {
    LaserDataScan {
        min_angle: config.min_angle,
        max_angle: config.max_angle,
        resolution: config.resolution,
        max_range: config.max_range,
        ranges: ranges.iter().map(|&r| r as f32).collect(),
        intensity: intensities.iter().map(|&v| intensity_byte(v)).collect(),
        id: 0,
    }
}

/// The pose a stamped ranger reading gives a laser SCANPOSE (upstream copies only x and y;
/// the heading is taken from the yaw here, which upstream leaves 0).
fn scan_pose(geom: &RangerGeom) -> Pose2d {
    Pose2d {
        px: geom.pose.px,
        py: geom.pose.py,
        pa: geom.pose.pyaw,
    }
}

/// What an answer from the ranger is for.
#[derive(Debug)]
enum Asked {
    Config(Asker),
    Geom(PendingReply),
    Relayed(Relayed),
    /// The ranger SET_CONFIG half of a laser SET_CONFIG.
    SetConfig(PendingReply),
    /// The ranger INTNS half of a laser SET_CONFIG.
    SetIntensity(PendingReply),
}

/// A laser SET_CONFIG waiting for its two ranger answers.
#[derive(Debug)]
struct SetConfigJob {
    requested: RangerConfig,
    intensity: u8,
    config: Option<RangerConfig>,
    intensity_acked: Option<u8>,
}

/// A ranger scan waiting for the intensities that may follow it.
#[derive(Debug)]
struct HeldScan {
    ranges: Vec<f64>,
    pose: Option<Pose2d>,
    timestamp: f64,
}

/// The driver. See the module docs.
#[derive(Debug)]
pub struct RangerToLaser {
    laser: DeviceAddr,
    ranger: DeviceAddr,
    /// The configuration scans are stamped with (upstream's `config`).
    config: LaserConfig,
    waiting: Waiting<Asked>,
    set_config: HashMap<PendingReply, SetConfigJob>,
    held: Option<HeldScan>,
    /// The ranger's intensities were seen to arrive in a later pass than their ranges (a
    /// remote ranger): scans then wait for them instead of going out when the driver wakes.
    intensities_follow: bool,
    /// The timestamp of the last scan sent without intensities.
    last_alone: Option<f64>,
}

impl RangerToLaser {
    /// Builds the driver from its cfg block: one laser provided, one ranger required.
    pub fn from_block(block: &DriverBlock) -> Result<RangerToLaser, DriverError> {
        let laser = super::provided(block, InterfaceCode::LASER)?;
        let ranger = block.required(InterfaceCode::RANGER, None)?.addr;
        Ok(RangerToLaser {
            laser,
            ranger,
            config: LaserConfig::default(),
            waiting: Waiting::default(),
            set_config: HashMap::new(),
            held: None,
            intensities_follow: false,
            last_alone: None,
        })
    }

    /// The configuration scans are currently stamped with.
    pub fn config(&self) -> &LaserConfig {
        &self.config
    }

    fn publish(&mut self, ctx: &mut Context<'_>, scan: HeldScan, intensities: &[f64]) {
        let data = laser_scan(&self.config, &scan.ranges, intensities);
        let body = match scan.pose {
            Some(pose) => LaserData::ScanPose(LaserDataScanpose { scan: data, pose }),
            None => LaserData::Scan(data),
        };
        ctx.publish_at(self.laser, body, scan.timestamp);
    }

    /// Sends the held scan without intensities (none came for it).
    fn flush(&mut self, ctx: &mut Context<'_>) {
        if let Some(scan) = self.held.take() {
            self.last_alone = Some(scan.timestamp);
            self.publish(ctx, scan, &[]);
        }
    }

    fn hold(&mut self, ctx: &mut Context<'_>, ranges: &[f64], pose: Option<Pose2d>, at: f64) {
        self.flush(ctx);
        self.held = Some(HeldScan {
            ranges: ranges.to_vec(),
            pose,
            timestamp: at,
        });
        if !self.intensities_follow {
            // The intensities of the same scan are already queued behind this message; the
            // wake comes after them.
            if let Some(waker) = ctx.waker() {
                waker.wake();
            }
        }
    }

    fn join(&mut self, ctx: &mut Context<'_>, intensities: &[f64], at: f64) {
        match self.held.take() {
            Some(scan) => self.publish(ctx, scan, intensities),
            None if self.last_alone == Some(at) => {
                tracing::debug!(
                    "{NAME} {}: intensities came after their scan was sent; waiting for them from now on",
                    self.laser
                );
                self.intensities_follow = true;
            }
            None => tracing::debug!("{NAME} {}: intensities without a scan", self.laser),
        }
    }

    fn set_config_part(
        &mut self,
        ctx: &mut Context<'_>,
        pending: PendingReply,
        ranges_half: bool,
        reply: Result<Message, RequestError>,
    ) {
        let Some(job) = self.set_config.get_mut(&pending) else {
            return; // already refused
        };
        let msg = match reply {
            Ok(msg) => msg,
            Err(e) => {
                tracing::debug!(
                    "{NAME} {}: SET_CONFIG refused by the ranger: {e}",
                    self.laser
                );
                self.set_config.remove(&pending);
                ctx.answer(pending, Reply::Nack);
                return;
            }
        };
        if ranges_half {
            let config = match RangerReq::in_reply(&msg.body) {
                Some(RangerReq::SetConfig(Some(c))) => c.clone(),
                _ => job.requested.clone(),
            };
            job.config = Some(config);
        } else {
            let state = match RangerReq::in_reply(&msg.body) {
                Some(RangerReq::Intns(Some(i))) => i.state,
                _ => job.intensity,
            };
            job.intensity_acked = Some(state);
        }
        if let (Some(config), Some(intensity)) = (&job.config, job.intensity_acked) {
            self.config = laser_config(config, intensity);
            if intensity == 0 {
                self.intensities_follow = false;
            }
            self.set_config.remove(&pending);
            let answer = Reply::ack(LaserReq::SetConfig(Some(self.config.clone())));
            ctx.answer(pending, answer);
        }
    }
}

impl Driver for RangerToLaser {
    fn setup(&mut self, ctx: &mut Context<'_>) -> Result<(), DriverError> {
        self.config = LaserConfig::default();
        self.held = None;
        self.intensities_follow = false;
        self.last_alone = None;
        ctx.subscribe(self.ranger);
        let ticket = ctx.request(self.ranger, RangerReq::GetConfig(None));
        self.waiting.insert(ticket, Asked::Config(Asker::Setup));
        Ok(())
    }

    fn teardown(&mut self, _ctx: &mut Context<'_>) {
        // Nobody is left to read a scan still waiting for its intensities.
        self.held = None;
    }

    fn handle_request(&mut self, ctx: &mut Context<'_>, request: &Message) -> Reply {
        let body = &request.body;
        let (ranger, waiting) = (self.ranger, &mut self.waiting);
        if let Some(reply) = converter_request(ctx, waiting, ranger, body, &HANDLED, Asked::Relayed)
        {
            return reply;
        }
        let (asked, to_ranger): (fn(PendingReply) -> Asked, Body) = match body {
            Body::Laser(LaserMsg::Req(LaserReq::Power(Some(p)))) => (
                |p| Asked::Relayed(Relayed::Acked(p)),
                RangerReq::Power(Some(RangerPowerConfig { state: p.state })).into(),
            ),
            Body::Laser(LaserMsg::Req(LaserReq::GetGeom(_))) => {
                (Asked::Geom, RangerReq::GetGeom(None).into())
            }
            Body::Laser(LaserMsg::Req(LaserReq::GetConfig(_))) => (
                |p| Asked::Config(Asker::Client(p)),
                RangerReq::GetConfig(None).into(),
            ),
            Body::Laser(LaserMsg::Req(LaserReq::SetConfig(Some(c)))) => {
                let Some(pending) = ctx.defer() else {
                    return Reply::Nack;
                };
                let requested = ranger_config(c);
                let t = ctx.request(self.ranger, RangerReq::SetConfig(Some(requested.clone())));
                self.waiting.insert(t, Asked::SetConfig(pending));
                let intns = RangerIntnsConfig { state: c.intensity };
                let t = ctx.request(self.ranger, RangerReq::Intns(Some(intns)));
                self.waiting.insert(t, Asked::SetIntensity(pending));
                // Upstream takes the flag at once, whatever the ranger answers.
                self.config.intensity = c.intensity;
                self.set_config.insert(
                    pending,
                    SetConfigJob {
                        requested,
                        intensity: c.intensity,
                        config: None,
                        intensity_acked: None,
                    },
                );
                return Reply::Deferred;
            }
            _ => return Reply::NotHandled,
        };
        self.waiting.forward(ctx, self.ranger, to_ranger, asked)
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
        let config_of = |reply: &Result<Message, RequestError>| match RangerReq::in_reply(
            answer_body(reply)?,
        ) {
            Some(RangerReq::GetConfig(Some(c))) => Some(c.clone()),
            _ => None,
        };
        match asked {
            Asked::Config(asker) => {
                let config = config_of(&reply).map(|c| {
                    self.config = laser_config(&c, self.config.intensity);
                    LaserReq::GetConfig(Some(self.config.clone()))
                });
                asker.answer(ctx, config, || {
                    tracing::warn!(
                        "{NAME} {}: the ranger {} gave no configuration; scans carry zero angles",
                        self.laser,
                        self.ranger
                    )
                });
            }
            Asked::Geom(pending) => {
                let geom = match answer_body(&reply).and_then(RangerReq::in_reply) {
                    Some(RangerReq::GetGeom(Some(g))) => {
                        Some(LaserReq::GetGeom(Some(laser_geom(g))))
                    }
                    _ => None,
                };
                ctx.answer(pending, ack_or_nack(geom));
            }
            Asked::Relayed(relayed) => relayed.answer(ctx, reply),
            Asked::SetConfig(pending) => self.set_config_part(ctx, pending, true, reply),
            Asked::SetIntensity(pending) => self.set_config_part(ctx, pending, false, reply),
        }
    }

    fn handle_data(&mut self, ctx: &mut Context<'_>, data: &Message) {
        let Body::Ranger(RangerMsg::Data(d)) = &data.body else {
            return;
        };
        let at = data.header.timestamp;
        match d {
            RangerData::Range(r) => self.hold(ctx, &r.ranges, None, at),
            RangerData::RangeStamped(r) => {
                self.hold(ctx, &r.data.ranges, Some(scan_pose(&r.geom)), at)
            }
            RangerData::Intns(i) => self.join(ctx, &i.intensities, at),
            RangerData::IntnsStamped(i) => self.join(ctx, &i.data.intensities, at),
            RangerData::Geom(_) => {}
        }
    }

    fn wake(&mut self, ctx: &mut Context<'_>) {
        if !self.intensities_follow {
            self.flush(ctx);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{Harness, addr, block};
    use player_proto::{
        Bbox3d, CapabilitiesReq, LaserPowerConfig, MsgType, Pose3d, RangerDataIntns,
        RangerDataIntnsstamped, RangerDataRange, RangerDataRangestamped, UniversalMsg,
        UniversalReq,
    };

    fn laser() -> DeviceAddr {
        addr(InterfaceCode::LASER, 0)
    }

    fn ranger() -> DeviceAddr {
        addr(InterfaceCode::RANGER, 1)
    }

    fn stage_like_config() -> RangerConfig {
        RangerConfig {
            min_angle: -1.5,
            max_angle: 1.5,
            angular_res: 3.0 / 180.0,
            min_range: 0.0,
            max_range: 8.0,
            range_res: 0.02,
            frequency: 10.0,
        }
    }

    /// A driver set up, with the startup configuration answered.
    fn ready() -> Harness<RangerToLaser> {
        let b = block(NAME, &[laser()], &[ranger()], &[]);
        let mut h = Harness::new(RangerToLaser::from_block(&b).unwrap());
        let out = h.setup();
        assert_eq!(out.subscriptions(), vec![ranger()]);
        let reqs = out.requests();
        assert_eq!(reqs.len(), 1);
        assert_eq!(reqs[0].1, ranger());
        assert_eq!(reqs[0].2, RangerReq::GetConfig(None).into());
        let out = h.ack(
            reqs[0].0,
            ranger(),
            RangerReq::GetConfig(Some(stage_like_config())),
        );
        assert!(
            out.answers().is_empty(),
            "the startup config is nobody's answer"
        );
        h
    }

    fn range(ranges: &[f64]) -> RangerData {
        RangerData::Range(RangerDataRange {
            ranges: ranges.to_vec(),
        })
    }

    fn intns(values: &[f64]) -> RangerData {
        RangerData::Intns(RangerDataIntns {
            intensities: values.to_vec(),
        })
    }

    fn scan_of(p: &player_server::Publication) -> LaserDataScan {
        match &p.body {
            Body::Laser(LaserMsg::Data(LaserData::Scan(s))) => s.clone(),
            other => panic!("not a scan: {other:?}"),
        }
    }

    #[test]
    fn configurations_and_geometry_convert_as_upstream() {
        let c = laser_config(&stage_like_config(), 1);
        assert_eq!(c.min_angle, -1.5f32);
        assert_eq!(c.max_angle, 1.5f32);
        assert_eq!(c.resolution, (3.0f64 / 180.0) as f32);
        assert_eq!(c.max_range, 8.0);
        assert_eq!(c.range_res, 0.02f32);
        assert_eq!(c.scanning_frequency, 10.0);
        assert_eq!(c.intensity, 1);
        let back = ranger_config(&c);
        assert_eq!(back.min_range, 0.0);
        assert_eq!(back.max_range, 8.0);
        assert_eq!(back.angular_res, f64::from(c.resolution));
        let g = RangerGeom {
            pose: Pose3d {
                px: 0.1,
                py: -0.2,
                pyaw: 0.5,
                ..Default::default()
            },
            size: Bbox3d {
                sw: 0.15,
                sl: 0.15,
                sh: 0.2,
            },
            element_poses: vec![Pose3d::default(); 3],
            element_sizes: vec![Bbox3d::default(); 3],
        };
        let lg = laser_geom(&g);
        assert_eq!(lg.pose, g.pose);
        assert_eq!(lg.size, g.size);
    }

    #[test]
    fn intensities_become_bytes_truncated_and_saturated() {
        assert_eq!(intensity_byte(0.9), 0);
        assert_eq!(intensity_byte(1.0), 1);
        assert_eq!(intensity_byte(254.99), 254);
        assert_eq!(intensity_byte(300.0), 255);
        assert_eq!(intensity_byte(-2.0), 0);
        assert_eq!(intensity_byte(f64::NAN), 0);
        let s = laser_scan(
            &laser_config(&stage_like_config(), 0),
            &[1.25, 2.5],
            &[1.0, 0.0],
        );
        assert_eq!(s.ranges, vec![1.25f32, 2.5]);
        assert_eq!(s.intensity, vec![1u8, 0]);
        assert_eq!(s.id, 0);
    }

    #[test]
    fn a_scans_intensities_join_its_ranges() {
        let mut h = ready();
        assert!(
            h.data(ranger(), range(&[1.0, 2.0, 3.0]), 4.5)
                .published
                .is_empty()
        );
        let out = h.data(ranger(), intns(&[1.0, 0.0, 1.0]), 4.5);
        assert_eq!(out.published.len(), 1, "one scan, not a second empty one");
        let p = &out.published[0];
        assert_eq!(p.addr, laser());
        assert_eq!(p.timestamp, Some(4.5));
        let s = scan_of(p);
        assert_eq!(s.ranges, vec![1.0, 2.0, 3.0]);
        assert_eq!(s.intensity, vec![1, 0, 1]);
        assert_eq!(s.min_angle, -1.5);
        assert_eq!(s.max_angle, 1.5);
        assert_eq!(s.resolution, (3.0f64 / 180.0) as f32);
        assert_eq!(s.max_range, 8.0);
        // Nothing is left to send when the driver wakes.
        assert!(h.wake().published.is_empty());
    }

    #[test]
    fn a_scan_without_intensities_goes_out_on_wake_or_with_the_next_scan() {
        let mut h = ready();
        h.data(ranger(), range(&[1.0]), 1.0);
        let out = h.wake();
        assert_eq!(out.published.len(), 1);
        assert!(scan_of(&out.published[0]).intensity.is_empty());
        h.data(ranger(), range(&[2.0]), 2.0);
        let out = h.data(ranger(), range(&[3.0]), 3.0);
        assert_eq!(out.published.len(), 1);
        assert_eq!(scan_of(&out.published[0]).ranges, vec![2.0]);
        assert_eq!(out.published[0].timestamp, Some(2.0));
        // Intensities with no scan waiting are not a scan of their own.
        h.wake();
        assert!(h.data(ranger(), intns(&[5.0]), 9.0).published.is_empty());
    }

    #[test]
    fn late_intensities_make_scans_wait_for_them() {
        let mut h = ready();
        h.data(ranger(), range(&[1.0]), 1.0);
        assert_eq!(h.wake().published.len(), 1);
        // Its intensities come after the wake (a remote ranger): from now on scans wait.
        assert!(h.data(ranger(), intns(&[7.0]), 1.0).published.is_empty());
        h.data(ranger(), range(&[2.0]), 2.0);
        assert!(h.wake().published.is_empty());
        let out = h.data(ranger(), intns(&[8.0]), 2.0);
        let s = scan_of(&out.published[0]);
        assert_eq!((s.ranges, s.intensity), (vec![2.0], vec![8]));
    }

    #[test]
    fn stamped_readings_become_scanpose() {
        let mut h = ready();
        let geom = RangerGeom {
            pose: Pose3d {
                px: 1.0,
                py: 2.0,
                pyaw: 0.25,
                ..Default::default()
            },
            ..Default::default()
        };
        h.data(
            ranger(),
            RangerData::RangeStamped(RangerDataRangestamped {
                data: RangerDataRange { ranges: vec![4.0] },
                have_geom: 1,
                geom: geom.clone(),
                ..Default::default()
            }),
            3.0,
        );
        let out = h.data(
            ranger(),
            RangerData::IntnsStamped(RangerDataIntnsstamped {
                data: RangerDataIntns {
                    intensities: vec![2.0],
                },
                have_geom: 1,
                geom,
                ..Default::default()
            }),
            3.0,
        );
        let Body::Laser(LaserMsg::Data(LaserData::ScanPose(sp))) = &out.published[0].body else {
            panic!("{:?}", out.published);
        };
        assert_eq!((sp.pose.px, sp.pose.py, sp.pose.pa), (1.0, 2.0, 0.25));
        assert_eq!(sp.scan.ranges, vec![4.0]);
        assert_eq!(sp.scan.intensity, vec![2]);
    }

    #[test]
    fn geometry_requests_ask_the_ranger_and_answer_the_requester() {
        let mut h = ready();
        let (reply, token, out) = h.request(laser(), LaserReq::GetGeom(None));
        assert_eq!(reply, Reply::Deferred);
        let reqs = out.requests();
        assert_eq!(reqs[0].1, ranger());
        assert_eq!(reqs[0].2, RangerReq::GetGeom(None).into());
        let g = RangerGeom {
            pose: Pose3d {
                px: 0.03,
                ..Default::default()
            },
            size: Bbox3d {
                sw: 0.156,
                sl: 0.155,
                sh: 0.19,
            },
            ..Default::default()
        };
        let out = h.ack(reqs[0].0, ranger(), RangerReq::GetGeom(Some(g.clone())));
        assert_eq!(
            out.answers(),
            vec![(token, Reply::ack(LaserReq::GetGeom(Some(laser_geom(&g)))))]
        );
        let (_, token, out) = h.request(laser(), LaserReq::GetGeom(None));
        let out2 = h.nack(out.requests()[0].0);
        assert_eq!(out2.answers(), vec![(token, Reply::Nack)]);
    }

    #[test]
    fn concurrent_config_requests_get_their_own_answers() {
        let mut h = ready();
        let (_, first, a) = h.request(laser(), LaserReq::GetConfig(None));
        let (_, second, b) = h.request(laser(), LaserReq::GetConfig(None));
        let (ta, tb) = (a.requests()[0].0, b.requests()[0].0);
        assert_ne!(ta, tb);
        let out = h.nack(tb);
        assert_eq!(out.answers(), vec![(second, Reply::Nack)]);
        let out = h.ack(
            ta,
            ranger(),
            RangerReq::GetConfig(Some(stage_like_config())),
        );
        let expected = laser_config(&stage_like_config(), 0);
        assert_eq!(
            out.answers(),
            vec![(first, Reply::ack(LaserReq::GetConfig(Some(expected))))]
        );
    }

    #[test]
    fn set_config_is_a_ranger_config_and_an_intensity_request() {
        let mut h = ready();
        let wanted = LaserConfig {
            min_angle: -1.0,
            max_angle: 1.0,
            resolution: 0.5,
            max_range: 4.0,
            range_res: 0.01,
            intensity: 1,
            scanning_frequency: 5.0,
        };
        let (reply, token, out) = h.request(laser(), LaserReq::SetConfig(Some(wanted.clone())));
        assert_eq!(reply, Reply::Deferred);
        let reqs = out.requests();
        assert_eq!(reqs.len(), 2);
        assert_eq!(
            reqs[0].2,
            RangerReq::SetConfig(Some(ranger_config(&wanted))).into()
        );
        assert_eq!(
            reqs[1].2,
            RangerReq::Intns(Some(RangerIntnsConfig { state: 1 })).into()
        );
        // The INTNS ACK alone answers nothing; the config ACK completes it.
        assert!(
            h.ack(reqs[1].0, ranger(), RangerReq::Intns(None))
                .answers()
                .is_empty()
        );
        let applied = ranger_config(&wanted);
        let out = h.ack(reqs[0].0, ranger(), RangerReq::SetConfig(Some(applied)));
        assert_eq!(
            out.answers(),
            vec![(token, Reply::ack(LaserReq::SetConfig(Some(wanted.clone()))))]
        );
        assert_eq!(h.driver.config(), &wanted);

        // One refusal NACKs once; the other half's answer is then ignored.
        let (_, token, out) = h.request(laser(), LaserReq::SetConfig(Some(wanted)));
        let reqs = out.requests();
        assert_eq!(h.nack(reqs[0].0).answers(), vec![(token, Reply::Nack)]);
        assert!(h.nack(reqs[1].0).answers().is_empty());
    }

    #[test]
    fn power_capabilities_and_properties() {
        let mut h = ready();
        let (_, token, out) = h.request(
            laser(),
            LaserReq::Power(Some(LaserPowerConfig { state: 0 })),
        );
        let req = &out.requests()[0];
        assert_eq!(
            req.2,
            RangerReq::Power(Some(RangerPowerConfig { state: 0 })).into()
        );
        assert_eq!(
            h.ack(req.0, ranger(), RangerReq::Power(None)).answers(),
            vec![(token, Reply::empty_ack())]
        );
        let caps = |subtype: u8| {
            Body::Universal(UniversalMsg::Req(UniversalReq::Capabilities(Some(
                CapabilitiesReq {
                    msg_type: u32::from(MsgType::Req.code()),
                    subtype: u32::from(subtype),
                },
            ))))
        };
        assert_eq!(
            h.request(laser(), caps(LaserReq::GET_CONFIG)).0,
            Reply::empty_ack()
        );
        assert_eq!(h.request(laser(), caps(LaserReq::GET_ID)).0, Reply::Nack);
        assert_eq!(
            h.request(laser(), LaserReq::GetId(None)).0,
            Reply::NotHandled
        );
        let prop = Body::Universal(UniversalMsg::Req(UniversalReq::GetDblProp(Some(
            player_proto::DblPropReq {
                key: "range".into(),
                value: 0.0,
            },
        ))));
        let (reply, token, out) = h.request(laser(), prop.clone());
        assert_eq!(reply, Reply::Deferred);
        let req = &out.requests()[0];
        assert_eq!((req.1, &req.2), (ranger(), &prop));
        assert_eq!(h.nack(req.0).answers(), vec![(token, Reply::Nack)]);
    }

    #[test]
    fn blocks_need_one_laser_and_a_ranger() {
        let two = block(
            NAME,
            &[laser(), addr(InterfaceCode::SONAR, 0)],
            &[ranger()],
            &[],
        );
        let e = RangerToLaser::from_block(&two).unwrap_err().to_string();
        assert!(e.contains("provides one laser device only"), "{e}");
        let none = block(NAME, &[laser()], &[addr(InterfaceCode::SONAR, 0)], &[]);
        let e = RangerToLaser::from_block(&none).unwrap_err().to_string();
        assert!(e.contains("requires a ranger device"), "{e}");
    }
}
