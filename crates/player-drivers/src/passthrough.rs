//! `passthrough`: serves a device of this or another Player server under a local address.
//!
//! As in Player 3.0.2, the block's `provides` and `requires` are paired in order (the i-th
//! provided device relays the i-th required one, so their counts must match): a client's
//! subscription to a provided device subscribes the driver to the required ones, their DATA is
//! republished under the local address with its original timestamp, commands go down
//! unchanged, and requests are forwarded with their answers (ACK with body, or NACK) passed back.
//! A required address on another host or on a port this server does not serve is reached over
//! TCP by the server's remote devices, so the classic use, `requires [":host:6665:laser:0"]`,
//! aggregates devices of several servers behind one port.
//!
//! Upstream's runtime properties for re-pointing the link (`remote_host`, `remote_port`,
//! `connect`) are not supported: such requests are forwarded like any other.

use player_proto::{DeviceAddr, Message};
use player_server::{
    Context, Driver, DriverBlock, DriverError, DriverRegistry, Reply, RequestError, RequestTicket,
};

use crate::forward::Forwarder;

/// The Player name of this driver.
pub const NAME: &str = "passthrough";

/// The driver: pairs of (local device, the device it relays).
#[derive(Debug)]
pub struct Passthrough {
    pairs: Vec<(DeviceAddr, DeviceAddr)>,
    forwarder: Forwarder,
}

impl Passthrough {
    /// Builds the driver from its cfg block.
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
                    "{}: provides a {} device but relays {} ({}), a {} device",
                    p.origin, p.addr.interf, r.addr, r.origin, r.addr.interf
                )));
            }
            if p.addr.same_device(&r.addr) {
                return Err(DriverError::new(format!(
                    "{}: passthrough connected to itself ({})",
                    r.origin, r.addr
                )));
            }
            pairs.push((p.addr, r.addr));
        }
        Ok(Passthrough {
            pairs,
            forwarder: Forwarder::new(),
        })
    }

    fn remote_of(&self, local: &DeviceAddr) -> Option<DeviceAddr> {
        self.pairs
            .iter()
            .find(|(l, _)| l.same_device(local))
            .map(|&(_, r)| r)
    }
}

impl Driver for Passthrough {
    fn setup(&mut self, ctx: &mut Context<'_>) -> Result<(), DriverError> {
        for &(_, remote) in &self.pairs {
            ctx.subscribe(remote);
        }
        Ok(())
    }

    fn teardown(&mut self, _ctx: &mut Context<'_>) {
        self.forwarder.clear();
    }

    fn handle_data(&mut self, ctx: &mut Context<'_>, data: &Message) {
        for &(local, remote) in &self.pairs {
            if remote.same_device(&data.header.addr) {
                ctx.publish_at(local, data.body.clone(), data.header.timestamp);
            }
        }
    }

    fn handle_command(&mut self, ctx: &mut Context<'_>, command: &Message) {
        if let Some(remote) = self.remote_of(&command.header.addr) {
            ctx.command(remote, command.body.clone());
        }
    }

    fn handle_request(&mut self, ctx: &mut Context<'_>, request: &Message) -> Reply {
        match self.remote_of(&request.header.addr) {
            Some(remote) => self.forwarder.forward(ctx, request, remote),
            None => Reply::NotHandled,
        }
    }

    fn handle_reply(
        &mut self,
        ctx: &mut Context<'_>,
        ticket: RequestTicket,
        reply: Result<Message, RequestError>,
    ) {
        self.forwarder.answer(ctx, ticket, &reply);
    }
}

/// Registers the driver under its Player name.
pub fn register(registry: &mut DriverRegistry) {
    registry.register(NAME, |block: &DriverBlock| {
        Ok(Box::new(Passthrough::from_block(block)?) as Box<dyn Driver>)
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use player_proto::InterfaceCode;
    use player_proto::constants::LOCALHOST_ADDR;
    use player_server::{ProvidedDevice, RequiredDevice};

    fn addr(port: u32, interf: InterfaceCode, index: u16) -> DeviceAddr {
        DeviceAddr::new(LOCALHOST_ADDR, port, interf, index)
    }

    fn block(provides: &[DeviceAddr], requires: &[DeviceAddr]) -> DriverBlock {
        DriverBlock {
            name: NAME.into(),
            provides: provides
                .iter()
                .map(|&addr| ProvidedDevice {
                    addr,
                    key: None,
                    origin: "p.cfg:2".into(),
                })
                .collect(),
            requires: requires
                .iter()
                .map(|&addr| RequiredDevice {
                    addr,
                    key: None,
                    origin: "p.cfg:3".into(),
                })
                .collect(),
            ..DriverBlock::default()
        }
    }

    #[test]
    fn provides_and_requires_pair_up_in_order() {
        let l0 = addr(6665, InterfaceCode::LASER, 0);
        let l1 = addr(6665, InterfaceCode::POSITION2D, 3);
        let r0 = addr(7000, InterfaceCode::LASER, 0);
        let r1 = addr(7000, InterfaceCode::POSITION2D, 0);
        let p = Passthrough::from_block(&block(&[l0, l1], &[r0, r1])).unwrap();
        assert_eq!(p.remote_of(&l1), Some(r1));
        assert_eq!(p.remote_of(&r1), None);

        let e = Passthrough::from_block(&block(&[l0, l1], &[r0])).unwrap_err();
        assert!(e.to_string().contains("mismatched"), "{e}");
        let e = Passthrough::from_block(&block(&[l0], &[r1])).unwrap_err();
        assert!(e.to_string().contains("p.cfg:2"), "{e}");
        let e = Passthrough::from_block(&block(&[l0], &[l0])).unwrap_err();
        assert!(e.to_string().contains("itself"), "{e}");
    }
}
