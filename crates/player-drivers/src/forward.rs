//! Requests a driver passes on to a device it uses, and the bookkeeping that brings each
//! answer back to whoever asked.
//!
//! Upstream's converters keep one `ret_queue` — the queue of the *last* requester — and send
//! every answer from their input device there, so two clients asking at once can get each
//! other's replies. Here every forwarded request has its own [`RequestTicket`], and the ticket
//! remembers what the driver owes (usually a client's [`PendingReply`]), so answers can never
//! cross.

use std::collections::HashMap;

use player_proto::{Body, Message, UniversalMsg, UniversalReq};
use player_server::{Context, DriverError, PendingReply, Reply, RequestError, RequestTicket};

/// Upstream's "attempt to subscribe to self": a driver whose `provided` device is also one of
/// the `inputs` it subscribes to would forward requests to itself and wait forever.
pub(crate) fn refuse_own_device(
    provided: player_proto::DeviceAddr,
    inputs: &[player_proto::DeviceAddr],
) -> Result<(), DriverError> {
    if inputs.iter().any(|i| i.same_device(&provided)) {
        return Err(DriverError::new("attempt to subscribe to self"));
    }
    Ok(())
}

/// What a driver is waiting for, by the ticket of the request it sent.
#[derive(Debug)]
pub(crate) struct Waiting<K> {
    by_ticket: HashMap<RequestTicket, K>,
}

impl<K> Default for Waiting<K> {
    fn default() -> Self {
        Waiting {
            by_ticket: HashMap::new(),
        }
    }
}

impl<K> Waiting<K> {
    /// Remembers what the answer to `ticket` is for.
    pub(crate) fn insert(&mut self, ticket: RequestTicket, what: K) {
        self.by_ticket.insert(ticket, what);
    }

    /// Sends `body` to `device` on behalf of the request being handled, which waits (the
    /// returned [`Reply::Deferred`]) until `device` answers; its answer to the ticket then
    /// finds `what(pending)` here. A NACK when there is no request to take (called outside
    /// `handle_request`), in which case nothing is sent.
    pub(crate) fn forward(
        &mut self,
        ctx: &mut Context<'_>,
        device: player_proto::DeviceAddr,
        body: impl Into<Body>,
        what: impl FnOnce(PendingReply) -> K,
    ) -> Reply {
        let Some(pending) = ctx.defer() else {
            return Reply::Nack;
        };
        let ticket = ctx.request(device, body);
        self.insert(ticket, what(pending));
        Reply::Deferred
    }

    /// What the answer to `ticket` is for (once: a second answer finds nothing).
    pub(crate) fn take(&mut self, ticket: RequestTicket) -> Option<K> {
        self.by_ticket.remove(&ticket)
    }
}

impl Waiting<PendingReply> {
    /// The reply to `ticket`, when it answers a request [`Waiting::forward`] passed on: sent back
    /// unchanged to whoever asked ([`passed_on`]). Any other reply is handed back to the caller
    /// (`Some`), for the driver's own requests.
    pub(crate) fn pass_back(
        &mut self,
        ctx: &mut Context<'_>,
        ticket: RequestTicket,
        reply: Result<Message, RequestError>,
    ) -> Option<Result<Message, RequestError>> {
        match self.take(ticket) {
            Some(pending) => {
                ctx.answer(pending, passed_on(reply));
                None
            }
            None => Some(reply),
        }
    }
}

/// Who asked a converter for what its input device says of itself (a configuration, a
/// geometry), which the converter keeps: the driver itself at setup, or a client whose
/// request it forwarded.
#[derive(Debug)]
pub(crate) enum Asker {
    /// The driver, at setup: the answer is kept and goes to nobody.
    Setup,
    /// A client, owed an answer.
    Client(PendingReply),
}

impl Asker {
    /// Hands over `answer`, made from the input's reply once the converter has kept what it
    /// says: a client gets it ACKed, or a NACK when the input gave nothing usable; at setup
    /// nobody is answered, and `missing` tells the log what the driver goes on without.
    pub(crate) fn answer(
        self,
        ctx: &mut Context<'_>,
        answer: Option<impl Into<Body>>,
        missing: impl FnOnce(),
    ) {
        match self {
            Asker::Client(pending) => ctx.answer(pending, ack_or_nack(answer)),
            Asker::Setup if answer.is_none() => missing(),
            Asker::Setup => {}
        }
    }
}

/// A client's request a converter passed on to its input device with nothing to keep from
/// the answer: the client's reply follows from how the device answered.
#[derive(Debug)]
pub(crate) enum Relayed {
    /// An empty ACK when the device acknowledged, else a NACK ([`acked`]): POWER.
    Acked(PendingReply),
    /// The device's answer unchanged ([`passed_on`]): property requests.
    PassedOn(PendingReply),
}

impl Relayed {
    /// Answers the client with what the device's `reply` makes of it.
    pub(crate) fn answer(self, ctx: &mut Context<'_>, reply: Result<Message, RequestError>) {
        match self {
            Relayed::Acked(pending) => ctx.answer(pending, acked(&reply)),
            Relayed::PassedOn(pending) => ctx.answer(pending, passed_on(reply)),
        }
    }
}

/// The `handle_request` and `handle_reply` of a driver that passes every request to one of
/// its input devices, `self.$device`, and sends the answer back unchanged (tracked in
/// `self.waiting`, a `Waiting<PendingReply>`): upstream's filters that sit in front of a
/// device (`laserposeinterpolator`, `mbicp`, `snd`) answer their clients so. Used inside the
/// driver's `impl Driver`.
macro_rules! pass_requests_to {
    ($device:ident) => {
        fn handle_request(
            &mut self,
            ctx: &mut player_server::Context<'_>,
            request: &player_proto::Message,
        ) -> player_server::Reply {
            self.waiting
                .forward(ctx, self.$device, request.body.clone(), |p| p)
        }

        fn handle_reply(
            &mut self,
            ctx: &mut player_server::Context<'_>,
            ticket: player_server::RequestTicket,
            reply: Result<player_proto::Message, player_server::RequestError>,
        ) {
            self.waiting.pass_back(ctx, ticket, reply);
        }
    };
}
pub(crate) use pass_requests_to;

/// The answer of a device, passed on unchanged: its ACK body (or an empty ACK), else a NACK.
/// Whatever kept the device from answering (gone, failed) is a NACK to the requester, as a
/// client of upstream would see (or time out waiting for).
pub(crate) fn passed_on(reply: Result<Message, RequestError>) -> Reply {
    match reply {
        Ok(msg) if msg.body.has_body() => Reply::Ack(Some(msg.body)),
        Ok(_) => Reply::Ack(None),
        Err(e) => {
            tracing::debug!("forwarded request not acknowledged: {e}");
            Reply::Nack
        }
    }
}

/// The body of a device's answer (`None` when it refused or could not answer).
pub(crate) fn answer_body(reply: &Result<Message, RequestError>) -> Option<&Body> {
    reply.as_ref().ok().map(|m| &m.body)
}

/// An empty ACK when the device acknowledged, else a NACK: for requests whose answer carries
/// nothing the requester needs (POWER).
pub(crate) fn acked(reply: &Result<Message, RequestError>) -> Reply {
    match reply {
        Ok(_) => Reply::empty_ack(),
        Err(_) => Reply::Nack,
    }
}

/// An ACK with `body` when the driver could make one from the device's answer, else a NACK.
pub(crate) fn ack_or_nack(body: Option<impl Into<Body>>) -> Reply {
    body.map_or(Reply::Nack, Reply::ack)
}

/// What every converter does first with a request (upstream's `ToRanger` / `FromRanger`
/// `ProcessMessage`): a property request goes to the `input` device as it is, its answer
/// later found in `waiting` as `relayed` of a [`Relayed::PassedOn`]; a CAPABILITIES request is
/// answered for the `handled` subtypes. `None` for any other request: the converter's own to
/// handle.
pub(crate) fn converter_request<K>(
    ctx: &mut Context<'_>,
    waiting: &mut Waiting<K>,
    input: player_proto::DeviceAddr,
    body: &Body,
    handled: &[u8],
    relayed: fn(Relayed) -> K,
) -> Option<Reply> {
    if is_forwarded_property(body) {
        let what = |pending| relayed(Relayed::PassedOn(pending));
        return Some(waiting.forward(ctx, input, body.clone(), what));
    }
    capability_reply(body, handled)
}

/// Whether `body` is one of the property requests upstream's `ToRanger` / `FromRanger` base
/// classes pass to their input device (integer, double and string properties; booleans
/// are not among them in 3.0.2).
pub(crate) fn is_forwarded_property(body: &Body) -> bool {
    matches!(
        body,
        Body::Universal(UniversalMsg::Req(
            UniversalReq::GetIntProp(_)
                | UniversalReq::SetIntProp(_)
                | UniversalReq::GetDblProp(_)
                | UniversalReq::SetDblProp(_)
                | UniversalReq::GetStrProp(_)
                | UniversalReq::SetStrProp(_)
        ))
    )
}

/// Upstream's `HANDLE_CAPABILITY_REQUEST` lines for a driver answering requests of the
/// subtypes in `requests`: a CAPABILITIES request asking about (REQ, one of them) or about
/// CAPABILITIES itself gets an empty ACK, any other one a NACK. `None` when `body` is not a
/// CAPABILITIES request.
pub(crate) fn capability_reply(body: &Body, requests: &[u8]) -> Option<Reply> {
    let Body::Universal(UniversalMsg::Req(UniversalReq::Capabilities(asked))) = body else {
        return None;
    };
    let req = u32::from(player_proto::MsgType::Req.code());
    let capabilities = u32::from(UniversalReq::PLAYER_CAPABILTIES_REQ);
    let known = asked.as_ref().is_some_and(|c| {
        c.msg_type == req
            && (c.subtype == capabilities || requests.iter().any(|&s| u32::from(s) == c.subtype))
    });
    Some(if known {
        Reply::empty_ack()
    } else {
        Reply::Nack
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use player_proto::{
        CapabilitiesReq, DeviceAddr, IntPropReq, InterfaceCode, MsgType, RangerReq, Text,
    };

    fn caps(msg_type: MsgType, subtype: u8) -> Body {
        Body::Universal(UniversalMsg::Req(UniversalReq::Capabilities(Some(
            CapabilitiesReq {
                msg_type: u32::from(msg_type.code()),
                subtype: u32::from(subtype),
            },
        ))))
    }

    #[test]
    fn capabilities_are_the_listed_requests_and_capabilities_itself() {
        let own = [RangerReq::GET_GEOM, RangerReq::POWER];
        assert_eq!(
            capability_reply(&caps(MsgType::Req, RangerReq::GET_GEOM), &own),
            Some(Reply::empty_ack())
        );
        assert_eq!(
            capability_reply(
                &caps(MsgType::Req, UniversalReq::PLAYER_CAPABILTIES_REQ),
                &own
            ),
            Some(Reply::empty_ack())
        );
        assert_eq!(
            capability_reply(&caps(MsgType::Req, RangerReq::SET_CONFIG), &own),
            Some(Reply::Nack)
        );
        assert_eq!(
            capability_reply(&caps(MsgType::Cmd, RangerReq::GET_GEOM), &own),
            Some(Reply::Nack)
        );
        assert_eq!(
            capability_reply(&RangerReq::GetGeom(None).into(), &own),
            None
        );
    }

    #[test]
    fn property_requests_forwarded_are_int_double_and_string() {
        let int = Body::Universal(UniversalMsg::Req(UniversalReq::GetIntProp(Some(
            IntPropReq {
                key: Text::from("x"),
                value: 0,
            },
        ))));
        assert!(is_forwarded_property(&int));
        let boolean = Body::Universal(UniversalMsg::Req(UniversalReq::GetBoolProp(None)));
        assert!(!is_forwarded_property(&boolean));
        assert!(!is_forwarded_property(&RangerReq::GetGeom(None).into()));
    }

    #[test]
    fn answers_pass_on_ack_bodies_empty_acks_and_nacks() {
        let addr = DeviceAddr::new(0, 6665, InterfaceCode::RANGER, 0);
        let full = Message::new(addr, 1.0, RangerReq::GetConfig(Some(Default::default())));
        assert!(matches!(passed_on(Ok(full)), Reply::Ack(Some(_))));
        let empty = Message::new(addr, 1.0, RangerReq::GetConfig(None));
        assert_eq!(passed_on(Ok(empty)), Reply::Ack(None));
        assert_eq!(passed_on(Err(RequestError::Nack)), Reply::Nack);
        let mut w = Waiting::default();
        w.insert(RequestTicket(3), "geom");
        assert_eq!(w.take(RequestTicket(3)), Some("geom"));
        assert_eq!(w.take(RequestTicket(3)), None);
    }
}
