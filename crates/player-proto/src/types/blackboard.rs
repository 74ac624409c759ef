//! The `blackboard` interface (64): entries shared between clients through a server-side store
//! (Player's `blackboard.def`, served by the `localbb` driver).

use crate::xdr::Text;

xdr_struct! {
    /// One blackboard entry, and every request and update of the interface: a request fills
    /// in the key and group it names (a set request the whole entry); replies and updates carry
    /// the stored entry.
    pub struct BlackboardEntry = "player_blackboard_entry_t" {
        /// The entry's name, NUL counted.
        key: Text,
        /// The group it belongs to (a second name; `""` counted as one NUL by upstream), NUL
        /// counted.
        group: Text,
        /// The Player message type of the data, as the setter chose (upstream stores it
        /// untouched).
        kind ("type"): u16,
        /// The Player message subtype of the data, likewise.
        subtype: u16,
        /// The entry's bytes.
        data: Vec<u8>,
        /// When the setter made the entry: seconds since the epoch.
        timestamp_sec: u32,
        /// Microseconds part of the time.
        timestamp_usec: u32,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::DecodeLimits;
    use crate::header::{DeviceAddr, HEADER_SIZE, MsgHeader, MsgType};
    use crate::interface::InterfaceCode;
    use crate::message::{BlackboardData, BlackboardMsg, BlackboardReq, Body, Message};

    fn entry() -> BlackboardEntry {
        BlackboardEntry {
            key: Text::new("ab"),
            group: Text::new(""),
            kind: 2,
            subtype: 7,
            data: vec![1, 2, 3, 4, 5],
            timestamp_sec: 10,
            timestamp_usec: 20,
        }
    }

    #[test]
    fn an_entry_has_upstreams_layout() {
        // Each counted member: its count word, xdr_bytes' own length word, bytes, zero pad.
        let mut bytes = Vec::new();
        crate::xdr::Xdr::encode(&entry(), &mut bytes).unwrap();
        #[rustfmt::skip]
        let expected = [
            0, 0, 0, 3, 0, 0, 0, 3, b'a', b'b', 0, 0, // key "ab\0"
            0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 0,       // group "\0"
            0, 0, 0, 2,                               // type, as xdr_u_short
            0, 0, 0, 7,                               // subtype
            0, 0, 0, 5, 0, 0, 0, 5, 1, 2, 3, 4, 5, 0, 0, 0, // data
            0, 0, 0, 10, 0, 0, 0, 20,                 // timestamp
        ];
        assert_eq!(bytes, expected);
    }

    #[test]
    fn every_blackboard_message_round_trips_through_xdr() {
        let addr = DeviceAddr::new(16777343, 6665, InterfaceCode::BLACKBOARD, 0);
        let e = entry();
        let bodies: Vec<(MsgType, u8, Body)> = vec![
            (
                MsgType::Req,
                1,
                BlackboardReq::SubscribeToKey(Some(e.clone())).into(),
            ),
            (
                MsgType::Req,
                2,
                BlackboardReq::UnsubscribeFromKey(Some(e.clone())).into(),
            ),
            (
                MsgType::Req,
                3,
                BlackboardReq::SetEntry(Some(e.clone())).into(),
            ),
            (
                MsgType::Req,
                4,
                BlackboardReq::SubscribeToGroup(Some(e.clone())).into(),
            ),
            (
                MsgType::Req,
                5,
                BlackboardReq::UnsubscribeFromGroup(Some(e.clone())).into(),
            ),
            (
                MsgType::Req,
                6,
                BlackboardReq::GetEntry(Some(e.clone())).into(),
            ),
            (MsgType::Data, 1, BlackboardData::Update(e.clone()).into()),
        ];
        for (msg_type, subtype, body) in bodies {
            let msg = Message::new(addr, 1.5, body);
            let wire = msg.encode().unwrap();
            let header = MsgHeader::from_bytes(wire[..HEADER_SIZE].try_into().unwrap()).unwrap();
            assert_eq!(
                (header.kind().unwrap(), header.subtype),
                (msg_type, subtype)
            );
            assert_eq!(header.size as usize, wire.len() - HEADER_SIZE);
            let back =
                Message::decode(header, &wire[HEADER_SIZE..], &DecodeLimits::default()).unwrap();
            assert_eq!(back.body, msg.body, "subtype {subtype}");
        }
        // The ACKs that carry nothing (unsubscribe, group subscribe, set).
        let ack = Body::Blackboard(BlackboardMsg::Ack(BlackboardReq::SetEntry(None)));
        let wire = Message::new(addr, 0.0, ack.clone()).encode().unwrap();
        assert_eq!(wire.len(), HEADER_SIZE);
    }
}
