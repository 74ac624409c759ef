//! Passing a client's request on to a required device and its answer back: what Player's
//! relaying drivers (laserposeinterpolator, passthrough) do with a queue filter, done here with
//! a deferred reply per forwarded request.

use std::collections::HashMap;

use player_proto::{DeviceAddr, Message};
use player_server::{Context, PendingReply, Reply, RequestError, RequestTicket};

/// Requests forwarded and not yet answered.
#[derive(Debug, Default)]
pub struct Forwarder {
    waiting: HashMap<RequestTicket, PendingReply>,
}

impl Forwarder {
    /// An empty forwarder.
    pub fn new() -> Forwarder {
        Forwarder::default()
    }

    /// Sends `request` (addressed to one of the driver's own devices) on to `to`, and returns
    /// the reply to give the requester now: deferred until `to` answers.
    pub fn forward(&mut self, ctx: &mut Context<'_>, request: &Message, to: DeviceAddr) -> Reply {
        let Some(pending) = ctx.defer() else {
            return Reply::NotHandled;
        };
        let ticket = ctx.request(to, request.body.clone());
        self.waiting.insert(ticket, pending);
        Reply::Deferred
    }

    /// Passes the answer to a forwarded request back to its requester; `false` when `ticket`
    /// is not one of this forwarder's (the driver's own requests).
    pub fn answer(
        &mut self,
        ctx: &mut Context<'_>,
        ticket: RequestTicket,
        reply: &Result<Message, RequestError>,
    ) -> bool {
        let Some(pending) = self.waiting.remove(&ticket) else {
            return false;
        };
        let answer = match reply {
            Ok(ack) => Reply::Ack(ack.body.has_body().then(|| ack.body.clone())),
            Err(e) => {
                tracing::debug!("forwarded request {} failed: {e}", ticket.0);
                Reply::Nack
            }
        };
        ctx.answer(pending, answer);
        true
    }

    /// Forgets every request in flight (the driver stopped; their requesters were told or left).
    pub fn clear(&mut self) {
        self.waiting.clear();
    }
}
