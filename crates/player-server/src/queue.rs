//! The per-connection outgoing queue, with exactly upstream's semantics (player-protocol.md
//! §7.1–§7.2, `MessageQueue` in message.cc).
//!
//! Everything the server sends on a connection after the banner goes through one of these:
//! DATA published by subscribed devices, replies, and the SYNCH that closes a PULL round (made up
//! on the fly when draining). It is a plain data structure: the core pushes, the connection's
//! writer pops, and neither needs to know the other's timing for the rules to hold.
//!
//! Upstream's length limit only drops DATA and CMD; replies and messages under an unusual
//! replace action are never dropped. A client that never reads could therefore grow a queue
//! without bound, so this queue adds a hard cap on entries and bytes beyond which a push reports
//! [`PushOutcome::Overloaded`] and the connection is closed. Normal clients never get near it.

use std::collections::VecDeque;

use bytes::Bytes;
use player_proto::constants::{
    PLAYER_MSGQUEUE_DEFAULT_MAXLEN, PLAYER_PLAYER_MSG_REPLACE_RULE_ACCEPT,
    PLAYER_PLAYER_MSG_REPLACE_RULE_IGNORE, PLAYER_PLAYER_MSG_REPLACE_RULE_REPLACE,
};
use player_proto::{
    AddReplaceRuleReq, Body, DeviceAddr, Frame, InterfaceCode, Message, MsgHeader, MsgType,
    PlayerMsg, PlayerSynch, Uint32,
};

use crate::map;

/// One encoded message waiting to be written, with the header fields the queue rules look at.
///
/// The bytes are shared ([`Bytes`]), so a DATA message fanned out to many subscribers is encoded
/// once and stored once.
#[derive(Clone, Debug, PartialEq)]
pub struct Outgoing {
    /// The header's device address.
    pub addr: DeviceAddr,
    /// The header's raw message type byte.
    pub msg_type: u8,
    /// The header's subtype.
    pub subtype: u8,
    /// Header and body, exactly as they go on the wire.
    pub bytes: Bytes,
}

impl Outgoing {
    /// Encodes a typed message.
    pub fn from_message(msg: &Message) -> Result<Outgoing, player_proto::Error> {
        if map::is_tile_reply(&msg.header) {
            return Ok(Outgoing::from_frame(&Frame::try_from(msg)?));
        }
        Ok(Outgoing {
            addr: msg.header.addr,
            msg_type: msg.header.msg_type,
            subtype: msg.header.subtype,
            bytes: Bytes::from(msg.encode()?),
        })
    }

    /// Encodes a raw frame (for messages the typed bodies cannot express, e.g. a bodyless NACK
    /// to a subtype that is not in the function table).
    ///
    /// The cells of a map GET_DATA ACK are zlib-compressed here, on their way to a TCP client,
    /// as upstream's TCP layer does (see [`crate::map`]).
    pub fn from_frame(frame: &Frame) -> Outgoing {
        if map::is_tile_reply(&frame.header) {
            if let Some(body) = map::tcp_body(&frame.body) {
                if let Ok(zipped) = Frame::new(frame.header, body) {
                    return Outgoing::from_frame_as_is(&zipped);
                }
            }
            tracing::warn!("map tile reply of unexpected form: sent uncompressed");
        }
        Outgoing::from_frame_as_is(frame)
    }

    fn from_frame_as_is(frame: &Frame) -> Outgoing {
        let mut bytes = Vec::with_capacity(player_proto::HEADER_SIZE + frame.body.len());
        frame.encode_into(&mut bytes);
        Outgoing {
            addr: frame.header.addr,
            msg_type: frame.header.msg_type,
            subtype: frame.header.subtype,
            bytes: Bytes::from(bytes),
        }
    }

    /// A header-only message (size 0).
    pub fn header_only(header: MsgHeader) -> Outgoing {
        let header = MsgHeader { size: 0, ..header };
        Outgoing {
            addr: header.addr,
            msg_type: header.msg_type,
            subtype: header.subtype,
            bytes: Bytes::copy_from_slice(&header.to_bytes()),
        }
    }

    /// The message type, if the byte is one of the six.
    pub fn kind(&self) -> Option<MsgType> {
        MsgType::from_u8(self.msg_type)
    }

    fn is_reply(&self) -> bool {
        matches!(self.kind(), Some(MsgType::RespAck | MsgType::RespNack))
    }

    fn is_data_or_cmd(&self) -> bool {
        matches!(self.kind(), Some(MsgType::Data | MsgType::Cmd))
    }

    /// Upstream's `Message::Compare`: same address, type and subtype.
    fn same_signature(&self, other: &Outgoing) -> bool {
        self.addr == other.addr && self.msg_type == other.msg_type && self.subtype == other.subtype
    }
}

/// A replace rule (`MessageReplaceRule`): fields that are -1 match anything.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ReplaceRule {
    /// Host, or -1 (always -1 for rules added over TCP).
    pub host: i64,
    /// Robot (port), or -1 (always -1 for rules added over TCP).
    pub robot: i64,
    /// Interface code, or -1.
    pub interf: i64,
    /// Index, or -1.
    pub index: i64,
    /// Message type, or -1.
    pub msg_type: i64,
    /// Subtype, or -1.
    pub subtype: i64,
    /// Action: 0 accept, 1 replace, 2 ignore; any other value queues without the length check.
    pub action: i32,
}

impl ReplaceRule {
    /// The rule `PLAYER_PLAYER_REQ_ADD_REPLACE_RULE` adds: host and robot wildcarded.
    pub fn from_request(req: &AddReplaceRuleReq) -> ReplaceRule {
        ReplaceRule {
            host: -1,
            robot: -1,
            interf: req.interf.into(),
            index: req.index.into(),
            msg_type: req.msg_type.into(),
            subtype: req.subtype.into(),
            action: req.replace,
        }
    }

    fn matches(&self, m: &Outgoing) -> bool {
        let field = |rule: i64, value: i64| rule == -1 || rule == value;
        field(self.host, m.addr.host.into())
            && field(self.robot, m.addr.robot.into())
            && field(self.interf, m.addr.interf.0.into())
            && field(self.index, m.addr.index.into())
            && field(self.msg_type, m.msg_type.into())
            && field(self.subtype, m.subtype.into())
    }

    fn same_match_fields(&self, other: &ReplaceRule) -> bool {
        (
            self.host,
            self.robot,
            self.interf,
            self.index,
            self.msg_type,
            self.subtype,
        ) == (
            other.host,
            other.robot,
            other.interf,
            other.index,
            other.msg_type,
            other.subtype,
        )
    }
}

/// Sizes that bound a queue.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct QueueLimits {
    /// Upstream's length limit: DATA/CMD pushed with action ACCEPT onto a queue holding this
    /// many messages are dropped and counted for the next SYNCH (`PLAYER_MSGQUEUE_DEFAULT_MAXLEN`).
    pub maxlen: usize,
    /// The same drop for DATA/CMD once this many bytes are queued (large images), so a slow
    /// reader costs bounded memory even when 1024 messages would be huge.
    pub max_data_bytes: usize,
    /// Hard cap on entries of any kind; beyond it a push reports [`PushOutcome::Overloaded`].
    pub hard_len: usize,
    /// Hard cap on queued bytes of any kind.
    pub hard_bytes: usize,
    /// Most distinct replace rules a connection may add.
    pub max_rules: usize,
}

impl Default for QueueLimits {
    fn default() -> Self {
        QueueLimits {
            maxlen: PLAYER_MSGQUEUE_DEFAULT_MAXLEN,
            max_data_bytes: 64 << 20,
            hard_len: 8 * PLAYER_MSGQUEUE_DEFAULT_MAXLEN,
            hard_bytes: 128 << 20,
            max_rules: 1024,
        }
    }
}

/// What [`OutQueue::push`] did with a message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PushOutcome {
    /// Appended at the tail.
    Queued,
    /// An older message with the same signature was removed, and this one appended.
    Replaced,
    /// Dropped silently by an IGNORE rule.
    Ignored,
    /// DATA/CMD dropped because the queue is full; counted for the next SYNCH OVERFLOW.
    Dropped,
    /// Not queued: the hard cap is reached, the peer is not reading. Close the connection.
    Overloaded,
}

/// Why [`OutQueue::add_replace_rule`] refused a rule.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("too many replace rules (limit {0})")]
pub struct TooManyRules(pub usize);

/// A connection's outgoing queue.
#[derive(Debug)]
pub struct OutQueue {
    items: VecDeque<Outgoing>,
    rules: Vec<ReplaceRule>,
    limits: QueueLimits,
    /// RESP_ACK/RESP_NACK currently queued. With no round open, the head is eligible exactly
    /// when the queue holds a reply (the flush point is the last one), so a count replaces
    /// upstream's scan from the tail.
    replies: usize,
    bytes: usize,
    pull: bool,
    data_requested: bool,
    data_delivered: bool,
    dropped: u32,
}

impl Default for OutQueue {
    fn default() -> Self {
        OutQueue::new(QueueLimits::default())
    }
}

impl OutQueue {
    /// An empty queue in PUSH mode (a new connection's state), with no rules.
    pub fn new(limits: QueueLimits) -> OutQueue {
        OutQueue {
            items: VecDeque::new(),
            rules: Vec::new(),
            limits,
            replies: 0,
            bytes: 0,
            pull: false,
            data_requested: false,
            data_delivered: false,
            dropped: 0,
        }
    }

    /// Messages waiting.
    pub fn len(&self) -> usize {
        self.items.len()
    }

    /// True when nothing waits (a SYNCH may still be due; see [`OutQueue::pop`]).
    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }

    /// Bytes waiting.
    pub fn queued_bytes(&self) -> usize {
        self.bytes
    }

    /// True in PULL mode.
    pub fn is_pull(&self) -> bool {
        self.pull
    }

    /// DATA/CMD dropped since the last SYNCH.
    pub fn dropped(&self) -> u32 {
        self.dropped
    }

    /// True while a PULL round is open (`REQ_DATA` received, SYNCH not yet sent).
    pub fn data_requested(&self) -> bool {
        self.data_requested
    }

    /// Switches PULL (true) / PUSH mode. Neither the queue nor the round state changes.
    pub fn set_pull(&mut self, pull: bool) {
        self.pull = pull;
    }

    /// Opens a data round: "data requested" set, "data delivered" cleared.
    pub fn request_data(&mut self) {
        self.data_requested = true;
        self.data_delivered = false;
    }

    /// Adds a rule at the end of the list, or changes the action of an existing rule with the
    /// same match fields.
    pub fn add_replace_rule(&mut self, rule: ReplaceRule) -> Result<(), TooManyRules> {
        if let Some(existing) = self.rules.iter_mut().find(|r| r.same_match_fields(&rule)) {
            existing.action = rule.action;
            return Ok(());
        }
        if self.rules.len() >= self.limits.max_rules {
            return Err(TooManyRules(self.limits.max_rules));
        }
        self.rules.push(rule);
        Ok(())
    }

    /// The action for a message: the first matching rule, else ACCEPT (replies always; DATA and
    /// CMD because TCP queues are created with upstream's replace flag off).
    fn action(&self, m: &Outgoing) -> i32 {
        self.rules
            .iter()
            .find(|r| r.matches(m))
            .map(|r| r.action)
            .unwrap_or(PLAYER_PLAYER_MSG_REPLACE_RULE_ACCEPT)
    }

    fn over_hard_cap(&self, m: &Outgoing) -> bool {
        self.items.len() >= self.limits.hard_len
            || self.bytes + m.bytes.len() > self.limits.hard_bytes
    }

    /// Upstream's `Push`: apply the rules, drop or replace, append.
    pub fn push(&mut self, m: Outgoing) -> PushOutcome {
        let action = self.action(&m);
        if action == PLAYER_PLAYER_MSG_REPLACE_RULE_IGNORE {
            return PushOutcome::Ignored;
        }
        if action == PLAYER_PLAYER_MSG_REPLACE_RULE_ACCEPT
            && m.is_data_or_cmd()
            && (self.items.len() >= self.limits.maxlen
                || self.bytes + m.bytes.len() > self.limits.max_data_bytes)
        {
            self.dropped = self.dropped.saturating_add(1);
            return PushOutcome::Dropped;
        }
        let mut outcome = PushOutcome::Queued;
        if action == PLAYER_PLAYER_MSG_REPLACE_RULE_REPLACE {
            if let Some(pos) = self.items.iter().rposition(|old| old.same_signature(&m)) {
                self.remove_at(pos);
                outcome = PushOutcome::Replaced;
            }
        }
        if self.over_hard_cap(&m) {
            return PushOutcome::Overloaded;
        }
        self.account_in(&m);
        self.items.push_back(m);
        outcome
    }

    /// Upstream's `PushFront` (only for the ACK to `REQ_DATA`): at the head, no rules, no limit
    /// except the hard cap.
    pub fn push_front(&mut self, m: Outgoing) -> PushOutcome {
        if self.over_hard_cap(&m) {
            return PushOutcome::Overloaded;
        }
        self.account_in(&m);
        self.items.push_front(m);
        PushOutcome::Queued
    }

    fn account_in(&mut self, m: &Outgoing) {
        self.bytes += m.bytes.len();
        if m.is_reply() {
            self.replies += 1;
        }
    }

    fn remove_at(&mut self, pos: usize) -> Option<Outgoing> {
        let m = self.items.remove(pos)?;
        self.bytes -= m.bytes.len();
        if m.is_reply() {
            self.replies -= 1;
        }
        Some(m)
    }

    /// Upstream's `Pop`: the next message the writer may send now, or the SYNCH that closes a
    /// PULL round (stamped `synch_time`), or `None` when nothing is eligible.
    ///
    /// Eligible is the head of the queue when the connection is in PUSH mode, when a round is
    /// open, or (round closed) when a reply is queued: everything up to and including the last
    /// reply is flushed with it. When an open round has sent at least one DATA and the queue is
    /// empty, the SYNCH goes out (OVERFLOW with the drop count if anything was dropped).
    pub fn pop(&mut self, synch_time: f64) -> Option<Outgoing> {
        if !self.items.is_empty() && (!self.pull || self.data_requested || self.replies > 0) {
            let m = self.remove_at(0)?;
            if self.data_requested && m.kind() == Some(MsgType::Data) {
                self.data_delivered = true;
            }
            return Some(m);
        }
        if self.pull && self.data_requested && self.data_delivered {
            let synch = if self.dropped == 0 {
                PlayerSynch::Ok
            } else {
                PlayerSynch::Overflow(Uint32 {
                    value: self.dropped,
                })
            };
            self.dropped = 0;
            self.data_requested = false;
            self.data_delivered = false;
            let msg = Message::new(
                DeviceAddr::new(0, 0, InterfaceCode::PLAYER, 0),
                synch_time,
                Body::Player(PlayerMsg::Synch(synch)),
            );
            // A SYNCH always encodes: fixed header, at most one u32.
            return Outgoing::from_message(&msg).ok();
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use player_proto::constants::LOCALHOST_ADDR;
    use player_proto::{
        DecodeLimits, HEADER_SIZE, PlayerReq, Position2dData, Position2dDataState, RangerData,
        RangerDataIntns, RangerDataRange,
    };

    const PORT: u32 = 6665;

    fn addr(interf: InterfaceCode, index: u16) -> DeviceAddr {
        DeviceAddr::new(LOCALHOST_ADDR, PORT, interf, index)
    }

    /// A DATA message; `tag` goes into the timestamp so tests can tell messages apart.
    fn data(interf: InterfaceCode, index: u16, tag: f64) -> Outgoing {
        let body: Body = match interf {
            InterfaceCode::POSITION2D => {
                Position2dData::State(Position2dDataState::default()).into()
            }
            _ => RangerData::Range(RangerDataRange { ranges: vec![1.0] }).into(),
        };
        Outgoing::from_message(&Message::new(addr(interf, index), tag, body)).unwrap()
    }

    fn intns(tag: f64) -> Outgoing {
        let body = RangerData::Intns(RangerDataIntns {
            intensities: vec![0.5],
        });
        Outgoing::from_message(&Message::new(addr(InterfaceCode::RANGER, 0), tag, body)).unwrap()
    }

    fn reply(kind: MsgType, subtype: u8, tag: f64) -> Outgoing {
        let mut h = MsgHeader::new(addr(InterfaceCode::PLAYER, 0), kind, subtype, tag);
        h.seq = 0;
        Outgoing::header_only(h)
    }

    fn ack(tag: f64) -> Outgoing {
        reply(MsgType::RespAck, PlayerReq::DATAMODE, tag)
    }

    fn data_ack(tag: f64) -> Outgoing {
        reply(MsgType::RespAck, PlayerReq::DATA, tag)
    }

    fn header(m: &Outgoing) -> MsgHeader {
        MsgHeader::from_bytes(m.bytes[..HEADER_SIZE].try_into().unwrap()).unwrap()
    }

    fn tag(m: &Outgoing) -> f64 {
        header(m).timestamp
    }

    fn drain(q: &mut OutQueue) -> Vec<Outgoing> {
        std::iter::from_fn(|| q.pop(99.0)).collect()
    }

    fn kinds(ms: &[Outgoing]) -> Vec<MsgType> {
        ms.iter().map(|m| m.kind().unwrap()).collect()
    }

    /// A queue whose limits are the defaults changed by `set`.
    fn queue_with(set: impl FnOnce(&mut QueueLimits)) -> OutQueue {
        let mut limits = QueueLimits::default();
        set(&mut limits);
        OutQueue::new(limits)
    }

    /// Pushes `n` copies of one ranger DATA.
    fn push_ranger_data(q: &mut OutQueue, n: usize) {
        for _ in 0..n {
            q.push(data(InterfaceCode::RANGER, 0, 0.0));
        }
    }

    /// Pushes each message in turn: what became of each.
    fn push_each(
        q: &mut OutQueue,
        messages: impl IntoIterator<Item = Outgoing>,
    ) -> Vec<PushOutcome> {
        messages.into_iter().map(|m| q.push(m)).collect()
    }

    /// The probe of a rule on ranger DATA: a ranger:0 DATA (tag 1) then a position2d:0 DATA
    /// (tag 2), which the rule does not match.
    fn push_ranger_then_position2d(q: &mut OutQueue) -> Vec<PushOutcome> {
        let probe = [
            data(InterfaceCode::RANGER, 0, 1.0),
            data(InterfaceCode::POSITION2D, 0, 2.0),
        ];
        push_each(q, probe)
    }

    fn pull_queue() -> OutQueue {
        let mut q = OutQueue::default();
        q.set_pull(true);
        q
    }

    fn rule(interf: i64, index: i64, msg_type: i64, subtype: i64, action: i32) -> ReplaceRule {
        ReplaceRule::from_request(&AddReplaceRuleReq {
            interf: interf as i32,
            index: index as i32,
            msg_type: msg_type as i32,
            subtype: subtype as i32,
            replace: action,
        })
    }

    #[test]
    fn push_mode_is_strict_fifo_without_synch() {
        let mut q = OutQueue::default();
        q.push(data(InterfaceCode::POSITION2D, 0, 1.0));
        q.push(ack(2.0));
        q.push(data(InterfaceCode::RANGER, 0, 3.0));
        let out = drain(&mut q);
        assert_eq!(out.iter().map(tag).collect::<Vec<_>>(), [1.0, 2.0, 3.0]);
        // Gotcha 5: a REQ_DATA in PUSH mode still never yields a SYNCH.
        q.push_front(data_ack(4.0));
        q.request_data();
        q.push(data(InterfaceCode::RANGER, 0, 5.0));
        let out = drain(&mut q);
        assert_eq!(kinds(&out), [MsgType::RespAck, MsgType::Data]);
        assert!(q.pop(0.0).is_none());
    }

    #[test]
    fn pull_mode_holds_data_until_a_round_or_reply() {
        let mut q = pull_queue();
        q.push(data(InterfaceCode::POSITION2D, 0, 1.0));
        q.push(data(InterfaceCode::RANGER, 0, 2.0));
        assert!(
            q.pop(0.0).is_none(),
            "no round open, no reply: nothing eligible"
        );
        assert_eq!(q.len(), 2);
    }

    #[test]
    fn reply_flushes_everything_ahead_of_it() {
        // §7.2: with no round open, the last reply is the flush point.
        let mut q = pull_queue();
        q.push(data(InterfaceCode::POSITION2D, 0, 1.0));
        q.push(ack(2.0));
        q.push(data(InterfaceCode::RANGER, 0, 3.0));
        q.push(ack(4.0));
        q.push(data(InterfaceCode::RANGER, 0, 5.0));
        let out = drain(&mut q);
        assert_eq!(
            out.iter().map(tag).collect::<Vec<_>>(),
            [1.0, 2.0, 3.0, 4.0]
        );
        assert_eq!(q.len(), 1, "DATA behind the last reply waits");
    }

    #[test]
    fn data_round_ack_first_then_data_then_synch() {
        // Gotcha 14: the REQ_DATA ACK goes ahead of already queued DATA.
        let mut q = pull_queue();
        q.push(data(InterfaceCode::POSITION2D, 0, 1.0));
        q.push(data(InterfaceCode::RANGER, 0, 2.0));
        q.push_front(data_ack(3.0));
        q.request_data();
        let out = drain(&mut q);
        assert_eq!(
            kinds(&out),
            [
                MsgType::RespAck,
                MsgType::Data,
                MsgType::Data,
                MsgType::Synch
            ]
        );
        assert_eq!(tag(&out[0]), 3.0);
        let synch = header(&out[3]);
        assert_eq!(synch.addr, DeviceAddr::new(0, 0, InterfaceCode::PLAYER, 0));
        assert_eq!(synch.subtype, PlayerSynch::OK);
        assert_eq!(synch.size, 0);
        assert_eq!(synch.timestamp, 99.0);
        assert!(!q.data_requested());
        // Data published after the SYNCH waits for the next round.
        q.push(data(InterfaceCode::RANGER, 0, 4.0));
        assert!(q.pop(0.0).is_none());
    }

    #[test]
    fn round_without_data_sends_no_synch_until_data_arrives() {
        // Gotcha 15: never a SYNCH in a round with no DATA.
        let mut q = pull_queue();
        q.push_front(data_ack(1.0));
        q.request_data();
        assert_eq!(kinds(&drain(&mut q)), [MsgType::RespAck]);
        assert!(q.data_requested(), "the round stays open");
        // The first DATA published later goes at once, then the SYNCH.
        q.push(data(InterfaceCode::RANGER, 0, 2.0));
        assert_eq!(kinds(&drain(&mut q)), [MsgType::Data, MsgType::Synch]);
        // A reply alone in an open round does not close it either.
        q.push_front(data_ack(3.0));
        q.request_data();
        q.push(ack(4.0));
        assert_eq!(kinds(&drain(&mut q)), [MsgType::RespAck, MsgType::RespAck]);
        assert!(q.data_requested());
    }

    #[test]
    fn overflow_drops_data_beyond_1024_and_reports_it() {
        // Gotcha 24: the 1025th DATA is dropped, the next round ends with SYNCH OVERFLOW.
        let mut q = pull_queue();
        let ranger = |i: i32| data(InterfaceCode::RANGER, 0, f64::from(i));
        assert_eq!(
            push_each(&mut q, (0..1024).map(ranger)),
            [PushOutcome::Queued; 1024]
        );
        assert_eq!(
            push_each(&mut q, (2000..2005).map(ranger)),
            [PushOutcome::Dropped; 5]
        );
        assert_eq!(q.dropped(), 5);
        // Replies are never dropped for length.
        assert_eq!(q.push(ack(3000.0)), PushOutcome::Queued);
        assert_eq!(q.len(), 1025);
        q.push_front(data_ack(3001.0));
        q.request_data();
        let out = drain(&mut q);
        assert_eq!(out.len(), 1 + 1024 + 1 + 1);
        let last = out.last().unwrap();
        let h = header(last);
        assert_eq!(h.subtype, PlayerSynch::OVERFLOW);
        assert_eq!(h.size, 4);
        let msg = Message::decode(h, &last.bytes[HEADER_SIZE..], &DecodeLimits::default()).unwrap();
        assert_eq!(
            msg.body,
            Body::Player(PlayerMsg::Synch(PlayerSynch::Overflow(Uint32 { value: 5 })))
        );
        // The counter is reset: the next round ends with OK.
        assert_eq!(q.dropped(), 0);
        q.push(data(InterfaceCode::RANGER, 0, 1.0));
        q.push_front(data_ack(2.0));
        q.request_data();
        assert_eq!(
            header(drain(&mut q).last().unwrap()).subtype,
            PlayerSynch::OK
        );
    }

    #[test]
    fn replace_rule_keeps_the_newest_per_signature_at_the_tail() {
        // §7.1 step 4: the replacing message goes to the end (can reorder devices).
        let mut q = pull_queue();
        q.add_replace_rule(rule(-1, -1, 1, -1, 1)).unwrap();
        let pushed = [
            data(InterfaceCode::POSITION2D, 0, 1.0),
            data(InterfaceCode::RANGER, 0, 2.0),
            intns(3.0),
            data(InterfaceCode::POSITION2D, 0, 4.0),
            data(InterfaceCode::RANGER, 1, 5.0),
        ];
        use PushOutcome::{Queued, Replaced};
        assert_eq!(
            push_each(&mut q, pushed),
            [Queued, Queued, Queued, Replaced, Queued]
        );
        q.push_front(data_ack(6.0));
        q.request_data();
        let out = drain(&mut q);
        assert_eq!(
            out.iter().map(tag).collect::<Vec<_>>(),
            [6.0, 2.0, 3.0, 4.0, 5.0, 99.0]
        );
    }

    #[test]
    fn replace_rule_means_no_overflow_through_data() {
        let mut q = pull_queue();
        q.add_replace_rule(rule(-1, -1, 1, -1, 1)).unwrap();
        for i in 0..5000 {
            q.push(data(InterfaceCode::POSITION2D, 0, f64::from(i)));
            q.push(data(InterfaceCode::RANGER, 0, f64::from(i)));
        }
        assert_eq!(q.len(), 2);
        assert_eq!(q.dropped(), 0);
    }

    #[test]
    fn ignore_rule_drops_silently_even_replies() {
        let mut q = OutQueue::default();
        q.add_replace_rule(rule(62, -1, -1, -1, 2)).unwrap();
        assert_eq!(
            push_ranger_then_position2d(&mut q),
            [PushOutcome::Ignored, PushOutcome::Queued]
        );
        q.add_replace_rule(rule(-1, -1, 4, -1, 2)).unwrap();
        assert_eq!(q.push(ack(3.0)), PushOutcome::Ignored);
        assert_eq!(q.dropped(), 0);
        assert_eq!(q.len(), 1);
    }

    #[test]
    fn first_matching_rule_wins_and_readding_overwrites() {
        let mut q = pull_queue();
        q.add_replace_rule(rule(62, 0, 1, -1, 2)).unwrap(); // ignore ranger:0 DATA
        q.add_replace_rule(rule(-1, -1, 1, -1, 1)).unwrap(); // replace all DATA
        assert_eq!(
            push_ranger_then_position2d(&mut q),
            [PushOutcome::Ignored, PushOutcome::Queued]
        );
        // Same match fields: the action changes, the rule keeps its place (first).
        q.add_replace_rule(rule(62, 0, 1, -1, 0)).unwrap();
        assert_eq!(q.rules.len(), 2);
        let ranger = |tag| data(InterfaceCode::RANGER, 0, tag);
        assert_eq!(
            push_each(&mut q, [ranger(3.0), ranger(4.0)]),
            [PushOutcome::Queued, PushOutcome::Queued]
        );
        assert_eq!(q.len(), 3, "accept rule first: ranger:0 no longer replaced");
    }

    #[test]
    fn rule_with_unusual_action_queues_beyond_the_length_limit() {
        let mut q = OutQueue::default();
        q.add_replace_rule(rule(-1, -1, 1, -1, 7)).unwrap();
        let ranger = |i: i32| data(InterfaceCode::RANGER, 0, f64::from(i));
        assert_eq!(
            push_each(&mut q, (0..1100).map(ranger)),
            [PushOutcome::Queued; 1100]
        );
        assert_eq!(q.dropped(), 0);
    }

    #[test]
    fn hard_cap_reports_overload_instead_of_growing() {
        let mut q = queue_with(|l| l.hard_len = 10);
        for i in 0..10 {
            assert_eq!(q.push(ack(f64::from(i))), PushOutcome::Queued);
        }
        assert_eq!(q.push(ack(10.0)), PushOutcome::Overloaded);
        assert_eq!(q.push_front(data_ack(11.0)), PushOutcome::Overloaded);
        assert_eq!(q.len(), 10);
        // DATA beyond maxlen still just drops (no overload) with the default action.
        let mut q = queue_with(|l| l.maxlen = 2);
        push_ranger_data(&mut q, 5);
        assert_eq!((q.len(), q.dropped()), (2, 3));
    }

    #[test]
    fn byte_cap_drops_large_data() {
        let one = data(InterfaceCode::RANGER, 0, 0.0).bytes.len();
        let mut q = queue_with(|l| l.max_data_bytes = 3 * one);
        push_ranger_data(&mut q, 5);
        assert_eq!((q.len(), q.dropped(), q.queued_bytes()), (3, 2, 3 * one));
        drain(&mut q);
        assert_eq!(q.queued_bytes(), 0);
    }

    #[test]
    fn rule_count_is_bounded() {
        let mut q = queue_with(|l| l.max_rules = 2);
        q.add_replace_rule(rule(1, -1, -1, -1, 1)).unwrap();
        q.add_replace_rule(rule(2, -1, -1, -1, 1)).unwrap();
        assert_eq!(
            q.add_replace_rule(rule(3, -1, -1, -1, 1)),
            Err(TooManyRules(2))
        );
        // Overwriting an existing rule is still allowed.
        q.add_replace_rule(rule(2, -1, -1, -1, 0)).unwrap();
    }

    #[test]
    fn duplicate_pushes_are_kept_without_rules() {
        // Gotcha 22 at queue level: two subscriptions push the same message twice; both stay.
        let mut q = OutQueue::default();
        let m = data(InterfaceCode::RANGER, 0, 1.0);
        q.push(m.clone());
        q.push(m.clone());
        assert_eq!(drain(&mut q), [m.clone(), m]);
    }

    #[test]
    fn replacing_a_reply_keeps_the_flush_point_count_right() {
        // A (foolish) replace rule on ACKs removes a queued reply; with no reply left the
        // DATA ahead of it must not be flushed.
        let mut q = pull_queue();
        q.add_replace_rule(rule(-1, -1, 4, -1, 1)).unwrap();
        q.push(data(InterfaceCode::RANGER, 0, 1.0));
        q.push(ack(2.0));
        q.push(ack(3.0));
        assert_eq!(q.len(), 2);
        let out = drain(&mut q);
        assert_eq!(out.iter().map(tag).collect::<Vec<_>>(), [1.0, 3.0]);
        assert!(q.pop(0.0).is_none());
    }

    #[test]
    fn switching_modes_keeps_queue_and_round() {
        let mut q = pull_queue();
        q.push(data(InterfaceCode::RANGER, 0, 1.0));
        q.push_front(data_ack(2.0));
        q.request_data();
        q.set_pull(false);
        assert!(q.data_requested());
        assert_eq!(q.len(), 2);
        // PUSH: everything flows, and no SYNCH follows.
        assert_eq!(kinds(&drain(&mut q)), [MsgType::RespAck, MsgType::Data]);
        // Back to PULL with the round still open and DATA delivered: the SYNCH is due.
        q.set_pull(true);
        assert_eq!(kinds(&drain(&mut q)), [MsgType::Synch]);
    }
}
