//! `sonartoranger` (Player 3.0.2 `server/drivers/ranger/sonartoranger.cc`): a `sonar` array
//! read as a `ranger`, for programs written against Player 3's `RangerProxy`.
//!
//! cfg: `requires ["sonar:N"]` (the first sonar entry), `provides ["ranger:M"]`; option
//! `buggy_geom` (default 0: when 1, the z, roll and pitch of each transducer pose are zeroed).
//!
//! At setup it subscribes to the sonar and asks for its geometry. Sonar RANGES become ranger
//! RANGE (widened to doubles); sonar DATA GEOM becomes ranger DATA GEOM. Ranger GET_GEOM asks
//! the sonar and converts its answer: one element per transducer with its pose and a zero
//! size, no device pose, and a device size spanning the transducers' positions and the
//! origin. GET_CONFIG is answered with zeros (a sonar has no configuration); POWER becomes a
//! sonar POWER; integer, double and string property requests go to the sonar unchanged.
//!
//! Unlike upstream, a GET_GEOM answer goes to the client that asked (upstream publishes the
//! ACK to every subscriber of the ranger and its NACK to the last requester), and the
//! geometry asked for at setup is never taken for a client's answer.

use player_proto::{
    Bbox3d, Body, DeviceAddr, InterfaceCode, Message, Pose3d, RangerConfig, RangerData,
    RangerDataRange, RangerGeom, RangerMsg, RangerReq, SonarData, SonarDataRanges, SonarGeom,
    SonarMsg, SonarPowerConfig, SonarReq,
};
use player_server::{
    Context, Driver, DriverBlock, DriverError, PendingReply, Reply, RequestError, RequestTicket,
};

use crate::forward::{Asker, Relayed, Waiting, answer_body, converter_request};

/// The name cfg files use.
pub const NAME: &str = "sonartoranger";

/// The ranger requests this driver lists in its CAPABILITIES (upstream answers GET_CONFIG
/// too but does not list it).
const HANDLED: [u8; 2] = [RangerReq::POWER, RangerReq::GET_GEOM];

/// The ranger geometry of a sonar array (upstream's `ConvertGeom`): one element per
/// transducer with its pose (z, roll and pitch zeroed under `buggy_geom`) and a zero size; a
/// zero device pose; a device size spanning the transducer positions and the origin (the
/// extents are measured from 0, before `buggy_geom` applies).
pub fn ranger_geom(sonar: &SonarGeom, buggy_geom: bool) -> RangerGeom {
    let (mut min, mut max) = ([0f64; 3], [0f64; 3]);
    for p in &sonar.poses {
        for (axis, v) in [p.px, p.py, p.pz].into_iter().enumerate() {
            min[axis] = min[axis].min(v);
            max[axis] = max[axis].max(v);
        }
    }
    let element_poses = sonar
        .poses
        .iter()
        .map(|p| {
            if buggy_geom {
                Pose3d {
                    pz: 0.0,
                    proll: 0.0,
                    ppitch: 0.0,
                    ..*p
                }
            } else {
                *p
            }
        })
        .collect();
    RangerGeom {
        pose: Pose3d::default(),
        size: Bbox3d {
            sw: max[0] - min[0],
            sl: max[1] - min[1],
            sh: max[2] - min[2],
        },
        element_poses,
        element_sizes: vec![Bbox3d::default(); sonar.poses.len()],
    }
}

/// Sonar ranges as ranger ranges (widened to doubles).
pub fn ranger_ranges(sonar: &SonarDataRanges) -> RangerDataRange {
    RangerDataRange {
        ranges: sonar.ranges.iter().map(|&r| f64::from(r)).collect(),
    }
}

/// What an answer from the sonar is for.
#[derive(Debug)]
enum Asked {
    Geom(Asker),
    Relayed(Relayed),
}

/// The driver. See the module docs.
#[derive(Debug)]
pub struct SonarToRanger {
    ranger: DeviceAddr,
    sonar: DeviceAddr,
    buggy_geom: bool,
    /// The device geometry (upstream's `deviceGeom`).
    geom: RangerGeom,
    waiting: Waiting<Asked>,
}

impl SonarToRanger {
    /// Builds the driver from its cfg block: one ranger provided, one sonar required.
    pub fn from_block(block: &DriverBlock) -> Result<SonarToRanger, DriverError> {
        Ok(SonarToRanger {
            ranger: super::provided(block, InterfaceCode::RANGER)?,
            sonar: block.required(InterfaceCode::SONAR, None)?.addr,
            buggy_geom: super::buggy_geom(block)?,
            geom: RangerGeom::default(),
            waiting: Waiting::default(),
        })
    }

    /// The geometry as last converted.
    pub fn geom(&self) -> &RangerGeom {
        &self.geom
    }

    fn converted_geom(&mut self, reply: &Result<Message, RequestError>) -> Option<RangerGeom> {
        match SonarReq::in_reply(answer_body(reply)?)? {
            SonarReq::GetGeom(Some(g)) => {
                self.geom = ranger_geom(g, self.buggy_geom);
                Some(self.geom.clone())
            }
            _ => None,
        }
    }
}

impl Driver for SonarToRanger {
    fn setup(&mut self, ctx: &mut Context<'_>) -> Result<(), DriverError> {
        self.geom = RangerGeom::default();
        ctx.subscribe(self.sonar);
        let ticket = ctx.request(self.sonar, SonarReq::GetGeom(None));
        self.waiting.insert(ticket, Asked::Geom(Asker::Setup));
        Ok(())
    }

    fn handle_request(&mut self, ctx: &mut Context<'_>, request: &Message) -> Reply {
        let body = &request.body;
        let (sonar, waiting) = (self.sonar, &mut self.waiting);
        if let Some(reply) = converter_request(ctx, waiting, sonar, body, &HANDLED, Asked::Relayed)
        {
            return reply;
        }
        let (asked, to_sonar): (fn(PendingReply) -> Asked, Body) = match body {
            Body::Ranger(RangerMsg::Req(RangerReq::Power(Some(p)))) => (
                |p| Asked::Relayed(Relayed::Acked(p)),
                SonarReq::Power(Some(SonarPowerConfig { state: p.state })).into(),
            ),
            Body::Ranger(RangerMsg::Req(RangerReq::GetGeom(_))) => (
                |p| Asked::Geom(Asker::Client(p)),
                SonarReq::GetGeom(None).into(),
            ),
            Body::Ranger(RangerMsg::Req(RangerReq::GetConfig(_))) => {
                return Reply::ack(RangerReq::GetConfig(Some(RangerConfig::default())));
            }
            _ => return Reply::NotHandled,
        };
        self.waiting.forward(ctx, self.sonar, to_sonar, asked)
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
            Asked::Geom(asker) => {
                let geom = self.converted_geom(&reply);
                asker.answer(ctx, geom.map(|g| RangerReq::GetGeom(Some(g))), || {
                    tracing::info!(
                        "{NAME} {}: the sonar {} gave no geometry at startup",
                        self.ranger,
                        self.sonar
                    )
                });
            }
            Asked::Relayed(relayed) => relayed.answer(ctx, reply),
        }
    }

    fn handle_data(&mut self, ctx: &mut Context<'_>, data: &Message) {
        let at = data.header.timestamp;
        match &data.body {
            Body::Sonar(SonarMsg::Data(SonarData::Ranges(r))) => {
                ctx.publish_at(self.ranger, RangerData::Range(ranger_ranges(r)), at);
            }
            Body::Sonar(SonarMsg::Data(SonarData::Geom(g))) => {
                self.geom = ranger_geom(g, self.buggy_geom);
                ctx.publish_at(self.ranger, RangerData::Geom(self.geom.clone()), at);
            }
            other => tracing::debug!("{NAME}: not converting {}", other.constant()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{Harness, addr, block};

    fn ranger() -> DeviceAddr {
        addr(InterfaceCode::RANGER, 0)
    }

    fn sonar() -> DeviceAddr {
        addr(InterfaceCode::SONAR, 0)
    }

    fn pioneer_front() -> SonarGeom {
        let pose = |px, py, pz, pyaw: f64| Pose3d {
            px,
            py,
            pz,
            proll: 0.5,
            pyaw: pyaw.to_radians(),
            ..Default::default()
        };
        SonarGeom {
            poses: vec![
                pose(0.075, 0.130, 0.2, 90.0),
                pose(0.115, 0.115, 0.2, 50.0),
                pose(0.150, -0.080, 0.2, -30.0),
            ],
        }
    }

    #[test]
    fn geometry_spans_the_transducers_and_the_origin() {
        let g = ranger_geom(&pioneer_front(), false);
        assert_eq!(g.pose, Pose3d::default());
        assert!((g.size.sw - 0.150).abs() < 1e-12, "{:?}", g.size);
        assert!((g.size.sl - (0.130 + 0.080)).abs() < 1e-12, "{:?}", g.size);
        assert!((g.size.sh - 0.2).abs() < 1e-12, "{:?}", g.size);
        assert_eq!(g.element_poses, pioneer_front().poses);
        assert_eq!(g.element_sizes, vec![Bbox3d::default(); 3]);
        let g = ranger_geom(&pioneer_front(), true);
        assert!(
            g.element_poses
                .iter()
                .all(|p| p.pz == 0.0 && p.proll == 0.0)
        );
        assert!(
            (g.size.sh - 0.2).abs() < 1e-12,
            "extents are taken before zeroing"
        );
    }

    #[test]
    fn ranges_and_geometry_data_convert() {
        let b = block(NAME, &[ranger()], &[sonar()], &[]);
        let mut h = Harness::new(SonarToRanger::from_block(&b).unwrap());
        let out = h.setup();
        assert_eq!(out.subscriptions(), vec![sonar()]);
        let req = out.requests()[0].clone();
        assert_eq!(req.2, SonarReq::GetGeom(None).into());
        let out = h.ack(req.0, sonar(), SonarReq::GetGeom(Some(pioneer_front())));
        assert!(
            out.answers().is_empty(),
            "the setup geometry is nobody's answer"
        );
        assert_eq!(h.driver.geom(), &ranger_geom(&pioneer_front(), false));

        let out = h.data(
            sonar(),
            SonarData::Ranges(SonarDataRanges {
                ranges: vec![0.5, 1.25, 5.0],
            }),
            2.0,
        );
        assert_eq!(
            out.bodies(),
            vec![Body::from(RangerData::Range(RangerDataRange {
                ranges: vec![0.5, 1.25, 5.0]
            }))]
        );
        assert_eq!(out.published[0].timestamp, Some(2.0));
        let out = h.data(sonar(), SonarData::Geom(pioneer_front()), 2.0);
        assert_eq!(
            out.bodies(),
            vec![Body::from(RangerData::Geom(ranger_geom(
                &pioneer_front(),
                false
            )))]
        );
    }

    #[test]
    fn requests() {
        let b = block(NAME, &[ranger()], &[sonar()], &[]);
        let mut h = Harness::new(SonarToRanger::from_block(&b).unwrap());
        h.setup();
        // GET_CONFIG: zeros, at once.
        let (reply, _, out) = h.request(ranger(), RangerReq::GetConfig(None));
        assert_eq!(
            reply,
            Reply::ack(RangerReq::GetConfig(Some(RangerConfig::default())))
        );
        assert!(out.requests().is_empty());
        // GET_GEOM: asked of the sonar, answered to the requester.
        let (reply, token, out) = h.request(ranger(), RangerReq::GetGeom(None));
        assert_eq!(reply, Reply::Deferred);
        let req = out.requests()[0].clone();
        let out = h.ack(req.0, sonar(), SonarReq::GetGeom(Some(pioneer_front())));
        assert_eq!(
            out.answers(),
            vec![(
                token,
                Reply::ack(RangerReq::GetGeom(Some(ranger_geom(
                    &pioneer_front(),
                    false
                ))))
            )]
        );
        // POWER refused by the sonar (as Stage does).
        let (_, token, out) = h.request(
            ranger(),
            RangerReq::Power(Some(player_proto::RangerPowerConfig { state: 1 })),
        );
        let req = out.requests()[0].clone();
        assert_eq!(
            req.2,
            SonarReq::Power(Some(SonarPowerConfig { state: 1 })).into()
        );
        assert_eq!(h.nack(req.0).answers(), vec![(token, Reply::Nack)]);
        // SET_CONFIG is not handled.
        assert_eq!(
            h.request(
                ranger(),
                RangerReq::SetConfig(Some(RangerConfig::default()))
            )
            .0,
            Reply::NotHandled
        );
    }
}
