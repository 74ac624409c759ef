//! `passthrough` (Player 3.0.2 `server/drivers/shell/passthrough.cc`): serves devices that
//! are other devices under another address — a local device under a second index, or a
//! device of another Player server as one of this one.
//!
//! cfg: `provides` and `requires` of equal length, paired in order (upstream: "Mismatched
//! number of entries in provides and requires" otherwise); each provided device is the
//! required device of the same position, of any interface. The required device may be on
//! another server (`":host:port:interface:index"`); the server's remote devices reach it.
//!
//! Everything passes through: DATA of a required device is published by its provided device
//! (timestamps kept), commands to a provided device go to its required device, and requests
//! are forwarded, the client's request waiting until the required device answers and then
//! getting that answer (ACK with its body, or NACK). The required devices are subscribed while
//! any provided device has a subscriber.
//!
//! Differences from upstream: a provided device must have the interface of its required
//! device (upstream accepts any pair, and would then hand, say, ranger data to laser clients);
//! upstream's `remote_host`, `remote_port` and `connect` properties, which re-point or
//! disconnect a remote pair at run time, are not supported (a remote pair is always
//! connected, as upstream's default `connect 1`); the required devices are subscribed once
//! for all clients rather than once per client (each subscriber still receives all data); and
//! a remote server that dies is reported once and reconnected to when it is back, with no
//! need to subscribe again (see [`player_server::remote_device`]): meanwhile requests to the
//! provided device are NACKed at once (upstream's time out).

use player_proto::{Body, DeviceAddr, Message};
use player_server::{
    Context, Driver, DriverBlock, DriverError, PendingReply, Reply, RequestError, RequestTicket,
};

use crate::forward::Waiting;

/// The name cfg files use.
pub const NAME: &str = "passthrough";

/// One provided device and the device it stands for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pair {
    /// The device this driver serves.
    pub provided: DeviceAddr,
    /// The device whose messages it carries.
    pub required: DeviceAddr,
}

/// The driver. See the module docs.
#[derive(Debug)]
pub struct Passthrough {
    pairs: Vec<Pair>,
    waiting: Waiting<PendingReply>,
}

impl Passthrough {
    /// Builds the driver from its cfg block: `provides[i]` stands for `requires[i]`.
    pub fn from_block(block: &DriverBlock) -> Result<Passthrough, DriverError> {
        if block.provides.len() != block.requires.len() {
            return Err(DriverError::new(format!(
                "mismatched number of entries in provides ({}) and requires ({})",
                block.provides.len(),
                block.requires.len()
            )));
        }
        let mut pairs = Vec::new();
        for (p, r) in block.provides.iter().zip(&block.requires) {
            if p.addr.interf != r.addr.interf {
                return Err(DriverError::new(format!(
                    "{}: provided device {}:{} passes through required device {} of another interface ({})",
                    p.origin, p.addr.interf, p.addr.index, r.addr, r.origin
                )));
            }
            pairs.push(Pair {
                provided: p.addr,
                required: r.addr,
            });
        }
        Ok(Passthrough {
            pairs,
            waiting: Waiting::default(),
        })
    }

    /// The pairs, in cfg order.
    pub fn pairs(&self) -> &[Pair] {
        &self.pairs
    }

    fn required_for(&self, provided: &DeviceAddr) -> Option<DeviceAddr> {
        self.pairs
            .iter()
            .find(|p| p.provided.same_device(provided))
            .map(|p| p.required)
    }
}

impl Driver for Passthrough {
    fn setup(&mut self, ctx: &mut Context<'_>) -> Result<(), DriverError> {
        // One subscription per distinct device: two pairs sharing a required device must not
        // receive its data twice.
        let mut done: Vec<DeviceAddr> = Vec::new();
        for pair in &self.pairs {
            if !done.iter().any(|d| d.same_device(&pair.required)) {
                ctx.subscribe(pair.required);
                done.push(pair.required);
            }
        }
        Ok(())
    }

    fn handle_request(&mut self, ctx: &mut Context<'_>, request: &Message) -> Reply {
        let Some(required) = self.required_for(&request.header.addr) else {
            return Reply::NotHandled;
        };
        self.waiting
            .forward(ctx, required, request.body.clone(), |p| p)
    }

    fn handle_reply(
        &mut self,
        ctx: &mut Context<'_>,
        ticket: RequestTicket,
        reply: Result<Message, RequestError>,
    ) {
        self.waiting.pass_back(ctx, ticket, reply);
    }

    fn handle_command(&mut self, ctx: &mut Context<'_>, command: &Message) {
        match self.required_for(&command.header.addr) {
            Some(required) => ctx.command(required, command.body.clone()),
            None => tracing::warn!("{NAME}: command for unknown device {}", command.header.addr),
        }
    }

    fn handle_data(&mut self, ctx: &mut Context<'_>, data: &Message) {
        let from = data.header.addr;
        for pair in &self.pairs {
            if pair.required.same_device(&from) {
                let body: Body = data.body.clone();
                ctx.publish_at(pair.provided, body, data.header.timestamp);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{Harness, addr, block};
    use player_proto::{
        InterfaceCode, Pose2d, Position2dCmd, Position2dCmdVel, Position2dData,
        Position2dDataState, Position2dGeom, Position2dReq,
    };

    fn p(index: u16) -> DeviceAddr {
        addr(InterfaceCode::POSITION2D, index)
    }

    #[test]
    fn provides_and_requires_pair_up_by_position_and_interface() {
        let b = block(NAME, &[p(5)], &[p(0), p(1)], &[]);
        let e = Passthrough::from_block(&b).unwrap_err().to_string();
        assert!(e.contains("mismatched number of entries"), "{e}");
        let b = block(NAME, &[p(5)], &[addr(InterfaceCode::LASER, 0)], &[]);
        let e = Passthrough::from_block(&b).unwrap_err().to_string();
        assert!(
            e.contains("test.cfg:2") && e.contains("another interface"),
            "{e}"
        );
        let b = block(NAME, &[p(5), p(6)], &[p(0), p(1)], &[]);
        let d = Passthrough::from_block(&b).unwrap();
        assert_eq!(
            d.pairs()[1],
            Pair {
                provided: p(6),
                required: p(1)
            }
        );
    }

    #[test]
    fn everything_passes_through() {
        let b = block(NAME, &[p(5), p(6)], &[p(0), p(0)], &[]);
        let mut h = Harness::new(Passthrough::from_block(&b).unwrap());
        assert_eq!(
            h.setup().subscriptions(),
            vec![p(0)],
            "one subscription per device"
        );

        // DATA of the required device comes out of both provided devices, stamps kept.
        let state = Position2dData::State(Position2dDataState {
            pos: Pose2d {
                px: 1.0,
                ..Default::default()
            },
            ..Default::default()
        });
        let out = h.data(p(0), state.clone(), 12.5);
        let from: Vec<_> = out
            .published
            .iter()
            .map(|x| (x.addr, x.timestamp))
            .collect();
        assert_eq!(from, vec![(p(5), Some(12.5)), (p(6), Some(12.5))]);
        assert_eq!(
            out.bodies(),
            vec![Body::from(state.clone()), Body::from(state)]
        );

        // Commands go to the required device.
        let vel = Position2dCmd::Vel(Position2dCmdVel::default());
        let out = h.command(p(6), vel.clone());
        assert_eq!(
            out.actions,
            vec![player_server::Action::Command(p(0), vel.into())]
        );

        // Requests are forwarded unchanged and their answers passed back.
        let (reply, token, out) = h.request(p(5), Position2dReq::GetGeom(None));
        assert_eq!(reply, Reply::Deferred);
        let req = out.requests()[0].clone();
        assert_eq!((req.1, req.2), (p(0), Position2dReq::GetGeom(None).into()));
        let geom = Position2dReq::GetGeom(Some(Position2dGeom::default()));
        let out = h.ack(req.0, p(0), geom.clone());
        assert_eq!(out.answers(), vec![(token, Reply::ack(geom))]);
        let (_, token, out) = h.request(p(6), Position2dReq::ResetOdom);
        let t = out.requests()[0].0;
        assert_eq!(
            h.ack(t, p(0), Position2dReq::ResetOdom).answers(),
            vec![(token, Reply::empty_ack())]
        );
        let (_, token, out) = h.request(p(6), Position2dReq::ResetOdom);
        let t = out.requests()[0].0;
        assert_eq!(h.nack(t).answers(), vec![(token, Reply::Nack)]);
        // A stale or repeated answer is nobody's.
        assert!(h.nack(t).answers().is_empty());
    }
}
