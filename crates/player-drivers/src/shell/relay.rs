//! `relay` (Player 3.0.2 `server/drivers/shell/relay.cc`): a general-purpose communications
//! relay on the `opaque` interface. Every message a client sends to the device (a command or a
//! request) is published back to every subscriber as `opaque` DATA of the same subtype, so
//! clients sharing the device can talk to each other through the server.
//!
//! Nothing is required. Upstream never answers a request (its sender times out after 5 s);
//! here it gets an empty ACK once its bytes are relayed.

use player_proto::{
    Body, DeviceAddr, InterfaceCode, Message, OpaqueCmd, OpaqueDataMsg, OpaqueMsg, OpaqueReq,
};
use player_server::{Context, Driver, DriverBlock, DriverError, Reply};

/// The name cfg files use.
pub const NAME: &str = "relay";

/// The driver: one `opaque` device.
#[derive(Debug)]
pub struct Relay {
    addr: DeviceAddr,
}

impl Relay {
    /// Builds the driver from its cfg block: it provides one `opaque` device.
    pub fn from_block(block: &DriverBlock) -> Result<Relay, DriverError> {
        let addr = block.provided(InterfaceCode::OPAQUE)?;
        Ok(Relay { addr })
    }

    /// What a client's message becomes: the same bytes as DATA (upstream republishes the body
    /// under the message's own subtype, which for the opaque interface is always 1, STATE).
    fn echo(&self, ctx: &mut Context<'_>, body: &Body) {
        let data = match body {
            Body::Opaque(OpaqueMsg::Cmd(OpaqueCmd::Data(d)))
            | Body::Opaque(OpaqueMsg::Req(OpaqueReq::Data(Some(d)))) => d.clone(),
            other => {
                tracing::warn!("{NAME}: ignoring {} (not opaque data)", other.constant());
                return;
            }
        };
        ctx.publish(self.addr, OpaqueDataMsg::State(data));
    }
}

impl Driver for Relay {
    fn handle_command(&mut self, ctx: &mut Context<'_>, command: &Message) {
        self.echo(ctx, &command.body);
    }

    fn handle_request(&mut self, ctx: &mut Context<'_>, request: &Message) -> Reply {
        self.echo(ctx, &request.body);
        Reply::empty_ack()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{Harness, addr, block};
    use player_proto::OpaqueData;

    #[test]
    fn commands_and_requests_come_back_as_data() {
        let b = block(NAME, &[addr(InterfaceCode::OPAQUE, 0)], &[], &[]);
        let mut h = Harness::new(Relay::from_block(&b).unwrap());
        let bytes = OpaqueData {
            data: vec![1, 2, 3],
        };
        let dev = addr(InterfaceCode::OPAQUE, 0);
        let out = h.command(dev, OpaqueCmd::Data(bytes.clone()));
        let echoed = Body::from(OpaqueDataMsg::State(bytes.clone()));
        assert_eq!(out.bodies(), std::slice::from_ref(&echoed));
        let (reply, _, out) = h.request(dev, OpaqueReq::Data(Some(bytes.clone())));
        assert_eq!(reply, Reply::empty_ack());
        assert_eq!(out.bodies(), [echoed]);
        let b = block(NAME, &[addr(InterfaceCode::LASER, 0)], &[], &[]);
        assert!(Relay::from_block(&b).is_err());
    }
}
