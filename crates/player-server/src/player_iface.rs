//! The `player` interface (code 1): the server's own requests, answered without any driver
//! except for (un)subscription (player-protocol.md §4.2–§4.3, upstream
//! `PlayerTCP::HandlePlayerMessage`).
//!
//! Every request gets exactly one reply. Its header is the request's, rewritten: host and port
//! of the server, interface 1, the request's index, subtype and `seq`, type ACK or NACK, the
//! server time, and the size of the body actually encoded.

use player_proto::constants::{
    PLAYER_CLOSE_MODE, PLAYER_DATAMODE_PULL, PLAYER_DATAMODE_PUSH, PLAYER_ERROR_MODE,
    PLAYER_MAX_DEVICES, PLAYER_MAX_DRIVER_STRING_LEN, PLAYER_OPEN_MODE,
};
use player_proto::{
    Body, DeviceAddr, DeviceDevlist, DeviceDriverinfo, DeviceReq, Frame, Message, MsgHeader,
    MsgType, PlayerMsg, PlayerReq, Text,
};

use crate::device::{DeviceIndex, DeviceTable, local_addr};
use crate::driver::DriverError;
use crate::queue::{OutQueue, PushOutcome, ReplaceRule};

/// A message for interface 1: typed, or only a header when its (type, subtype) is not in the
/// function table (sent without a body).
#[derive(Clone, Copy, Debug)]
pub(crate) enum PlayerInput<'m> {
    /// Decoded.
    Typed(&'m Message),
    /// No table row; no body.
    Untyped(&'m MsgHeader),
}

impl PlayerInput<'_> {
    fn header(&self) -> &MsgHeader {
        match self {
            PlayerInput::Typed(m) => &m.header,
            PlayerInput::Untyped(h) => h,
        }
    }
}

/// Why an unsubscription was refused.
#[derive(Debug, thiserror::Error)]
pub(crate) enum UnsubscribeError {
    /// The connection holds no subscription to the device.
    #[error("not subscribed")]
    NotSubscribed,
    /// The driver refused.
    #[error("{0}")]
    Driver(DriverError),
}

/// Subscription bookkeeping the core provides for one connection.
pub(crate) trait Subscriptions {
    /// Subscribes the connection to the device (calling its driver); recorded on success.
    fn subscribe(&mut self, device: DeviceIndex) -> Result<(), DriverError>;
    /// Removes one subscription of the connection to the device (calling its driver).
    fn unsubscribe(&mut self, device: DeviceIndex) -> Result<(), UnsubscribeError>;
}

/// Removes the latest of a connection's `held` subscriptions to `device` (a connection may
/// hold several), or says it holds none: the record every [`Subscriptions`] keeps of what it
/// must release when the connection goes.
pub(crate) fn release_held(
    held: &mut Vec<DeviceIndex>,
    device: DeviceIndex,
) -> Result<(), UnsubscribeError> {
    let pos = held
        .iter()
        .rposition(|&d| d == device)
        .ok_or(UnsubscribeError::NotSubscribed)?;
    held.remove(pos);
    Ok(())
}

/// What the player interface needs of the connection it answers.
pub(crate) struct Session<'a> {
    /// The device table.
    pub table: &'a DeviceTable,
    /// The port the connection was accepted on.
    pub port: u32,
    /// Server time for the reply header.
    pub now: f64,
    /// The connection's outgoing queue.
    pub queue: &'a mut OutQueue,
    /// Peer, for log lines.
    pub peer: &'a str,
}

/// The reply header of §4.2.
fn reply_header(req: &MsgHeader, kind: MsgType, now: f64) -> MsgHeader {
    MsgHeader {
        msg_type: kind.code(),
        timestamp: now,
        size: 0,
        ..*req
    }
}

/// Encodes a reply: header per §4.2 and the body of `body` (a player-interface REQ kind).
fn reply(req: &MsgHeader, kind: MsgType, now: f64, body: Option<PlayerReq>) -> Frame {
    let header = reply_header(req, kind, now);
    let bytes = match body {
        // These bodies are built from the device table within their C capacities.
        Some(b) => Body::Player(PlayerMsg::Req(b)).encode().unwrap_or_default(),
        None => Vec::new(),
    };
    Frame::new(header, bytes).unwrap_or(Frame {
        header,
        body: Vec::new(),
    })
}

/// The driver name as DEV and DRIVERINFO carry it: NUL terminated, at most 64 bytes in all.
fn driver_name_text(name: &str) -> Text {
    let mut bytes: Vec<u8> = name
        .bytes()
        .take(PLAYER_MAX_DRIVER_STRING_LEN - 1)
        .collect();
    if let Some(nul) = bytes.iter().position(|&b| b == 0) {
        bytes.truncate(nul);
    }
    bytes.push(0);
    Text::from_bytes(bytes)
}

/// Handles one message to interface 1 and queues its reply. Returns how the reply was queued
/// (`None` when nothing is sent).
pub(crate) fn handle(
    input: PlayerInput<'_>,
    s: &mut Session<'_>,
    subs: &mut dyn Subscriptions,
) -> Option<PushOutcome> {
    let req = input.header();
    let nack = |s: &mut Session<'_>| reply(req, MsgType::RespNack, s.now, None);
    let frame = match input {
        PlayerInput::Untyped(h) => {
            tracing::warn!(
                "{}: player interface NACKs message of unsupported type {} subtype {}",
                s.peer,
                h.msg_type,
                h.subtype
            );
            nack(s)
        }
        PlayerInput::Typed(msg) => match &msg.body {
            Body::Player(PlayerMsg::Req(r)) => match request(r, req, s, subs) {
                Handled::Reply(frame) => frame,
                Handled::DataRound(frame) => {
                    let outcome = s
                        .queue
                        .push_front(crate::queue::Outgoing::from_frame(&frame));
                    s.queue.request_data();
                    return Some(outcome);
                }
            },
            other => {
                tracing::warn!(
                    "{}: player interface discarding message of unsupported type {}",
                    s.peer,
                    other.msg_type()
                );
                nack(s)
            }
        },
    };
    Some(s.queue.push(crate::queue::Outgoing::from_frame(&frame)))
}

enum Handled {
    Reply(Frame),
    /// The REQ_DATA ACK: to the front of the queue, opening a round.
    DataRound(Frame),
}

fn request(
    r: &PlayerReq,
    req: &MsgHeader,
    s: &mut Session<'_>,
    subs: &mut dyn Subscriptions,
) -> Handled {
    let now = s.now;
    let ack = |body| Handled::Reply(reply(req, MsgType::RespAck, now, body));
    let nack = || Handled::Reply(reply(req, MsgType::RespNack, now, None));
    // A request the clients always send with a body, sent without: upstream would read a
    // null pointer. Refuse it instead.
    let bodyless = |what: &str| {
        tracing::warn!("{}: {what} request without a body; NACK", s.peer);
        Handled::Reply(reply(req, MsgType::RespNack, now, None))
    };
    match r {
        PlayerReq::DevList(_) => {
            let devices: Vec<DeviceAddr> = s
                .table
                .on_port(s.port)
                .map(|d| d.addr)
                .take(PLAYER_MAX_DEVICES)
                .collect();
            ack(Some(PlayerReq::DevList(Some(DeviceDevlist { devices }))))
        }
        PlayerReq::DriverInfo(None) => bodyless("DRIVERINFO"),
        PlayerReq::DriverInfo(Some(info)) => {
            let addr = local_addr(s.port, info.addr.interf, info.addr.index);
            match s.table.find(&addr) {
                None => {
                    tracing::warn!(
                        "{}: skipping info request for unknown device {}:{}",
                        s.peer,
                        addr.interf,
                        addr.index
                    );
                    nack()
                }
                Some(i) => ack(Some(PlayerReq::DriverInfo(Some(DeviceDriverinfo {
                    addr,
                    driver_name: driver_name_text(&s.table.get(i).driver_name),
                })))),
            }
        }
        PlayerReq::Dev(None) => bodyless("DEV"),
        PlayerReq::Dev(Some(dev)) => dev_request(dev, req, s, subs),
        PlayerReq::Data => Handled::DataRound(reply(req, MsgType::RespAck, now, None)),
        PlayerReq::DataMode(None) => bodyless("DATAMODE"),
        PlayerReq::DataMode(Some(m)) => {
            match m.mode {
                PLAYER_DATAMODE_PUSH => s.queue.set_pull(false),
                PLAYER_DATAMODE_PULL => s.queue.set_pull(true),
                other => tracing::warn!("{}: unknown data mode requested: {other}", s.peer),
            }
            ack(None)
        }
        PlayerReq::AddReplaceRule(None) => bodyless("ADD_REPLACE_RULE"),
        PlayerReq::AddReplaceRule(Some(rule)) => {
            match s.queue.add_replace_rule(ReplaceRule::from_request(rule)) {
                Ok(()) => ack(None),
                Err(e) => {
                    tracing::warn!("{}: refusing replace rule: {e}", s.peer);
                    nack()
                }
            }
        }
        PlayerReq::Auth(_) | PlayerReq::NameService(_) => {
            tracing::warn!(
                "{}: player interface discarding message of unsupported subtype {}",
                s.peer,
                req.subtype
            );
            nack()
        }
    }
}

/// §4.3.3: the reply always carries a `player_device_req_t`; NACK only for unknown devices.
fn dev_request(
    dev: &DeviceReq,
    req: &MsgHeader,
    s: &mut Session<'_>,
    subs: &mut dyn Subscriptions,
) -> Handled {
    let addr = local_addr(s.port, dev.addr.interf, dev.addr.index);
    let Some(index) = s.table.find(&addr) else {
        tracing::warn!(
            "{}: skipping subscription to unknown device {}:{}",
            s.peer,
            addr.interf,
            addr.index
        );
        let body = DeviceReq {
            addr,
            access: PLAYER_ERROR_MODE,
            driver_name: Text::empty(),
        };
        return Handled::Reply(reply(
            req,
            MsgType::RespNack,
            s.now,
            Some(PlayerReq::Dev(Some(body))),
        ));
    };
    let access = match dev.access {
        PLAYER_OPEN_MODE => match subs.subscribe(index) {
            Ok(()) => PLAYER_OPEN_MODE,
            Err(e) => {
                tracing::warn!(
                    "{}: subscription failed for device {}:{}: {e}",
                    s.peer,
                    addr.interf,
                    addr.index
                );
                PLAYER_ERROR_MODE
            }
        },
        PLAYER_CLOSE_MODE => match subs.unsubscribe(index) {
            Ok(()) => PLAYER_CLOSE_MODE,
            Err(e) => {
                tracing::warn!(
                    "{}: unsubscription failed for device {}:{}: {e}",
                    s.peer,
                    addr.interf,
                    addr.index
                );
                PLAYER_ERROR_MODE
            }
        },
        other => {
            tracing::warn!(
                "{}: unknown access mode {other} requested for device {}:{}",
                s.peer,
                addr.interf,
                addr.index
            );
            PLAYER_ERROR_MODE
        }
    };
    let body = DeviceReq {
        addr,
        access,
        driver_name: driver_name_text(&s.table.get(index).driver_name),
    };
    Handled::Reply(reply(
        req,
        MsgType::RespAck,
        s.now,
        Some(PlayerReq::Dev(Some(body))),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::{Device, DriverId};
    use crate::queue::Outgoing;
    use player_proto::constants::LOCALHOST_ADDR;
    use player_proto::{
        AddReplaceRuleReq, DecodeLimits, DeviceDatamodeReq, HEADER_SIZE, InterfaceCode, PlayerSynch,
    };

    #[derive(Default)]
    struct Subs {
        held: Vec<DeviceIndex>,
        refuse: bool,
    }

    impl Subscriptions for Subs {
        fn subscribe(&mut self, device: DeviceIndex) -> Result<(), DriverError> {
            if self.refuse {
                return Err(DriverError::new("refused"));
            }
            self.held.push(device);
            Ok(())
        }
        fn unsubscribe(&mut self, device: DeviceIndex) -> Result<(), UnsubscribeError> {
            release_held(&mut self.held, device)
        }
    }

    fn table() -> DeviceTable {
        let mut t = DeviceTable::new();
        for (port, interf, index) in [
            (6665, InterfaceCode::SIMULATION, 0),
            (6665, InterfaceCode::POSITION2D, 0),
            (6666, InterfaceCode::GRIPPER, 0),
        ] {
            t.add(Device {
                addr: local_addr(port, interf, index),
                key: None,
                driver: DriverId(0),
                driver_name: "stage".into(),
                origin: "t.cfg:1".into(),
            })
            .unwrap();
        }
        t
    }

    /// One connection talking to the player interface: the device table it sees, its queue
    /// and its subscriptions.
    struct Conn {
        table: DeviceTable,
        queue: OutQueue,
        subs: Subs,
    }

    impl Conn {
        fn new() -> Conn {
            Conn {
                table: table(),
                queue: OutQueue::default(),
                subs: Subs::default(),
            }
        }

        /// Sends `body` as libplayerc does (host 0, robot 0; the server rewrites host and port
        /// before the player interface sees the header) and returns the replies queued.
        fn send(&mut self, body: Body) -> Vec<Message> {
            let msg = Message::new(local_addr(6665, InterfaceCode::PLAYER, 0), 1.0, body);
            self.handle(PlayerInput::Typed(&msg))
                .iter()
                .map(decode)
                .collect()
        }

        /// Sends a header of `msg_type` and `subtype` without a body the codec knows.
        fn send_untyped(&mut self, msg_type: MsgType, subtype: u8) -> Vec<Outgoing> {
            let addr = local_addr(6665, InterfaceCode::PLAYER, 0);
            let header = MsgHeader::new(addr, msg_type, subtype, 1.0);
            self.handle(PlayerInput::Untyped(&header))
        }

        /// A DEV request opening (`access`) the device `interf`:0 of this port.
        fn dev(&mut self, interf: InterfaceCode, access: u8) -> Vec<Message> {
            self.send(dev(interf, 0, access))
        }

        fn handle(&mut self, input: PlayerInput<'_>) -> Vec<Outgoing> {
            let mut s = Session {
                table: &self.table,
                port: 6665,
                now: 7.5,
                queue: &mut self.queue,
                peer: "test",
            };
            handle(input, &mut s, &mut self.subs);
            std::iter::from_fn(|| self.queue.pop(0.0)).collect()
        }
    }

    fn decode(m: &Outgoing) -> Message {
        let h = MsgHeader::from_bytes(m.bytes[..HEADER_SIZE].try_into().unwrap()).unwrap();
        Message::decode(h, &m.bytes[HEADER_SIZE..], &DecodeLimits::default()).unwrap()
    }

    fn req(r: PlayerReq) -> Body {
        Body::Player(PlayerMsg::Req(r))
    }

    fn dev(interf: InterfaceCode, index: u16, access: u8) -> Body {
        req(PlayerReq::Dev(Some(DeviceReq {
            addr: DeviceAddr::new(0, 0, interf, index),
            access,
            driver_name: Text::empty(),
        })))
    }

    #[test]
    fn devlist_lists_this_port_in_table_order() {
        let mut c = Conn::new();
        let out = c.send(req(PlayerReq::DevList(None)));
        assert_eq!(out.len(), 1);
        assert_eq!(out[0].header.kind().unwrap(), MsgType::RespAck);
        assert_eq!(out[0].header.size, 8 + 2 * 16);
        assert_eq!(
            out[0].header.addr,
            local_addr(6665, InterfaceCode::PLAYER, 0)
        );
        assert_eq!(out[0].header.timestamp, 7.5);
        let Body::Player(PlayerMsg::Ack(PlayerReq::DevList(Some(list)))) = &out[0].body else {
            panic!("{:?}", out[0].body)
        };
        assert_eq!(
            list.devices,
            [
                local_addr(6665, InterfaceCode::SIMULATION, 0),
                local_addr(6665, InterfaceCode::POSITION2D, 0)
            ]
        );
    }

    #[test]
    fn driverinfo_known_and_unknown() {
        let mut c = Conn::new();
        let ask = |interf| {
            req(PlayerReq::DriverInfo(Some(DeviceDriverinfo {
                addr: DeviceAddr::new(0, 0, interf, 0),
                driver_name: Text::empty(),
            })))
        };
        let out = c.send(ask(InterfaceCode::POSITION2D));
        assert_eq!(out[0].header.size, 32);
        let Body::Player(PlayerMsg::Ack(PlayerReq::DriverInfo(Some(info)))) = &out[0].body else {
            panic!()
        };
        assert_eq!(info.driver_name.as_bytes(), b"stage\0");
        assert_eq!(info.addr, local_addr(6665, InterfaceCode::POSITION2D, 0));
        // The gripper lives on 6666 only.
        let out = c.send(ask(InterfaceCode::GRIPPER));
        assert_eq!(out[0].header.kind().unwrap(), MsgType::RespNack);
        assert_eq!(out[0].header.size, 0);
    }

    #[test]
    fn dev_subscribe_unsubscribe_and_failures() {
        let mut c = Conn::new();
        let access_of = |m: &Message| match &m.body {
            Body::Player(PlayerMsg::Ack(PlayerReq::Dev(Some(d))))
            | Body::Player(PlayerMsg::Nack(PlayerReq::Dev(Some(d)))) => d.clone(),
            other => panic!("{other:?}"),
        };
        let out = c.dev(InterfaceCode::POSITION2D, 1);
        assert_eq!(out[0].header.kind().unwrap(), MsgType::RespAck);
        assert_eq!(out[0].header.size, 36);
        let d = access_of(&out[0]);
        assert_eq!((d.access, d.driver_name.as_bytes()), (1, &b"stage\0"[..]));
        assert_eq!(d.addr.host, LOCALHOST_ADDR);
        assert_eq!(d.addr.robot, 6665);
        assert_eq!(c.subs.held, [DeviceIndex(1)]);
        // Close: access 2; closing again: not subscribed → access 3, still an ACK.
        let out = c.dev(InterfaceCode::POSITION2D, 2);
        assert_eq!(access_of(&out[0]).access, 2);
        let out = c.dev(InterfaceCode::POSITION2D, 2);
        assert_eq!(out[0].header.kind().unwrap(), MsgType::RespAck);
        assert_eq!(access_of(&out[0]).access, 3);
        // Unknown access mode → ACK with access 3.
        let out = c.dev(InterfaceCode::POSITION2D, 9);
        assert_eq!(access_of(&out[0]).access, 3);
        // A refusing driver → ACK with access 3.
        c.subs.refuse = true;
        let out = c.dev(InterfaceCode::POSITION2D, 1);
        assert_eq!(out[0].header.kind().unwrap(), MsgType::RespAck);
        assert_eq!(access_of(&out[0]).access, 3);
        // Unknown device (exists on another port only) → NACK with a 28-byte body.
        let out = c.dev(InterfaceCode::GRIPPER, 1);
        assert_eq!(out[0].header.kind().unwrap(), MsgType::RespNack);
        assert_eq!(out[0].header.size, 28);
        let d = access_of(&out[0]);
        assert_eq!(d.access, 3);
        assert!(d.driver_name.is_empty());
        assert_eq!(d.addr, local_addr(6665, InterfaceCode::GRIPPER, 0));
        // The reply is addressed to player:0 with the request's subtype.
        assert_eq!(out[0].header.addr.interf, InterfaceCode::PLAYER);
        assert_eq!(out[0].header.subtype, PlayerReq::DEV);
    }

    #[test]
    fn datamode_data_and_replace_rule() {
        let mut c = Conn::new();
        let mode = |m| req(PlayerReq::DataMode(Some(DeviceDatamodeReq { mode: m })));
        let out = c.send(mode(2));
        assert!(c.queue.is_pull());
        assert_eq!(out[0].header.size, 0);
        assert_eq!(out[0].header.subtype, PlayerReq::DATAMODE);
        // Unknown mode: ACK, mode unchanged.
        let out = c.send(mode(7));
        assert_eq!(out[0].header.kind().unwrap(), MsgType::RespAck);
        assert!(c.queue.is_pull());
        // REQ_DATA: ACK first, round open.
        let out = c.send(req(PlayerReq::Data));
        assert_eq!(out.len(), 1);
        assert_eq!(out[0].header.subtype, PlayerReq::DATA);
        assert!(c.queue.data_requested());
        let rule = AddReplaceRuleReq {
            interf: -1,
            index: -1,
            msg_type: 1,
            subtype: -1,
            replace: 1,
        };
        let out = c.send(req(PlayerReq::AddReplaceRule(Some(rule))));
        assert_eq!(out[0].header.kind().unwrap(), MsgType::RespAck);
        assert_eq!(out[0].header.size, 0);
    }

    #[test]
    fn everything_else_is_nacked_without_body() {
        let mut c = Conn::new();
        let out = c.send(req(PlayerReq::Auth(None)));
        assert_eq!(out[0].header.kind().unwrap(), MsgType::RespNack);
        assert_eq!((out[0].header.subtype, out[0].header.size), (7, 0));
        // A subtype the table lacks (no body), and a CMD: NACK with the same subtype.
        let header = |m: &Outgoing| {
            MsgHeader::from_bytes(m.bytes[..HEADER_SIZE].try_into().unwrap()).unwrap()
        };
        let out = c.send_untyped(MsgType::Req, 42);
        let h = header(&out[0]);
        assert_eq!((h.subtype, h.size, h.msg_type), (42, 0, 6));
        assert_eq!(h.addr, local_addr(6665, InterfaceCode::PLAYER, 0));
        let out = c.send_untyped(MsgType::Cmd, 3);
        let h = header(&out[0]);
        assert_eq!((h.subtype, h.size, h.msg_type), (3, 0, 6));
        // A (typed) SYNCH sent by a client.
        let out = c.send(Body::Player(PlayerMsg::Synch(PlayerSynch::Ok)));
        assert_eq!(out[0].header.kind().unwrap(), MsgType::RespNack);
        // Requests that need a body but came without one.
        let out = c.send(req(PlayerReq::Dev(None)));
        assert_eq!(
            (out[0].header.kind().unwrap(), out[0].header.size),
            (MsgType::RespNack, 0)
        );
    }

    #[test]
    fn long_driver_names_are_cut_to_64_with_nul() {
        let name = "x".repeat(100);
        let text = driver_name_text(&name);
        assert_eq!(text.len(), 64);
        assert_eq!(text.as_bytes()[63], 0);
        assert_eq!(driver_name_text("stage").as_bytes(), b"stage\0");
    }
}
