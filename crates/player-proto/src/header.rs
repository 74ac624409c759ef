//! The 40-byte message header, device addresses, message types and the connection banner.

use std::fmt;

use crate::constants::{LOCALHOST_ADDR, PLAYER_IDENT_STRLEN};
use crate::error::{Error, MessageKey};
use crate::interface::InterfaceCode;
use crate::xdr::{Reader, Xdr};

/// Encoded size of [`MsgHeader`] (`PLAYERXDR_MSGHDR_SIZE`): every field widened to 4+ bytes.
pub const HEADER_SIZE: usize = 40;

/// The six message types of `player.h` (`PLAYER_MSGTYPE_*`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[repr(u8)]
pub enum MsgType {
    /// Server → client, published by devices to their subscribers.
    Data = 1,
    /// Client → server, asynchronous and never acknowledged.
    Cmd = 2,
    /// Client → server, answered by exactly one ACK or NACK.
    Req = 3,
    /// Positive reply; carries reply data where the request defines it.
    RespAck = 4,
    /// End of a PULL-mode data round.
    Synch = 5,
    /// Negative reply; normally without a body (DEV is the exception).
    RespNack = 6,
}

impl MsgType {
    /// All six, in code order.
    pub const ALL: [MsgType; 6] = [
        MsgType::Data,
        MsgType::Cmd,
        MsgType::Req,
        MsgType::RespAck,
        MsgType::Synch,
        MsgType::RespNack,
    ];

    /// The type for a header byte, or `None` outside 1..=6.
    pub fn from_u8(code: u8) -> Option<MsgType> {
        MsgType::ALL.get(usize::from(code).wrapping_sub(1)).copied()
    }

    /// The header byte.
    pub fn code(self) -> u8 {
        self as u8
    }

    /// Upstream's diagnostic name (`interface_util.c`): "data", "command", "request",
    /// "resp_ack", "sync", "resp_nack".
    pub fn name(self) -> &'static str {
        match self {
            MsgType::Data => "data",
            MsgType::Cmd => "command",
            MsgType::Req => "request",
            MsgType::RespAck => "resp_ack",
            MsgType::Synch => "sync",
            MsgType::RespNack => "resp_nack",
        }
    }

    /// The C constant, e.g. `PLAYER_MSGTYPE_RESP_ACK`.
    pub fn constant(self) -> &'static str {
        match self {
            MsgType::Data => "PLAYER_MSGTYPE_DATA",
            MsgType::Cmd => "PLAYER_MSGTYPE_CMD",
            MsgType::Req => "PLAYER_MSGTYPE_REQ",
            MsgType::RespAck => "PLAYER_MSGTYPE_RESP_ACK",
            MsgType::Synch => "PLAYER_MSGTYPE_SYNCH",
            MsgType::RespNack => "PLAYER_MSGTYPE_RESP_NACK",
        }
    }

    /// The short name used by the conformance files: DATA, CMD, REQ, RESP_ACK, SYNCH, RESP_NACK.
    pub fn short_name(self) -> &'static str {
        &self.constant()["PLAYER_MSGTYPE_".len()..]
    }
}

impl fmt::Display for MsgType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.short_name())
    }
}

xdr_struct! {
    /// A device address (`host`, `robot` = TCP port, interface code, index).
    ///
    /// It heads every message header and appears inside DEV, DRIVERINFO and DEVLIST bodies.
    #[derive(Copy, Eq, Hash)]
    pub struct DeviceAddr = "player_devaddr_t" {
        /// Host: for local devices 127.0.0.1 packed little-endian ([`LOCALHOST_ADDR`]).
        host: u32,
        /// The TCP port the device is served on.
        robot: u32,
        /// Interface code (widened to 4 bytes).
        interf: InterfaceCode,
        /// Index within (port, interface) (widened to 4 bytes).
        index: u16,
    }

    /// The 40-byte header in front of every message body.
    #[derive(Copy)]
    pub struct MsgHeader = "player_msghdr_t" {
        /// Device the message is from or for.
        addr: DeviceAddr,
        /// Raw message type byte; see [`MsgHeader::kind`]. Kept raw so any header can be read
        /// (and answered or dropped) even when the type is not one of the six.
        msg_type ("type"): u8,
        /// Interface-specific subtype.
        subtype: u8,
        /// Seconds; simulated time under Stage.
        timestamp: f64,
        /// Sequence number (clients send 0; player-interface replies echo it).
        seq: u32,
        /// Encoded body length in bytes that follows the header.
        size: u32,
    }
}

impl DeviceAddr {
    /// An address from its four parts.
    pub fn new(host: u32, robot: u32, interf: InterfaceCode, index: u16) -> DeviceAddr {
        DeviceAddr {
            host,
            robot,
            interf,
            index,
        }
    }

    /// Upstream's `Device::MatchDeviceAddress` (spec §5.1): same robot, interface and index, and
    /// hosts equal or one of them 0 with the other the local host value. Interface code 0 never
    /// matches anything (`DeviceTable::GetDevice`).
    pub fn same_device(&self, other: &DeviceAddr) -> bool {
        let hosts_match = self.host == other.host
            || (self.host == 0 && other.host == LOCALHOST_ADDR)
            || (self.host == LOCALHOST_ADDR && other.host == 0);
        self.interf.0 != 0
            && self.interf == other.interf
            && self.robot == other.robot
            && self.index == other.index
            && hosts_match
    }
}

impl fmt::Display for DeviceAddr {
    /// `host:robot:interface:index`, the full `provides` syntax of `.cfg` files.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}:{}:{}:{}",
            self.host, self.robot, self.interf, self.index
        )
    }
}

impl MsgHeader {
    /// A header with `seq` 0 and `size` 0 (encoding fills `size` in).
    pub fn new(addr: DeviceAddr, msg_type: MsgType, subtype: u8, timestamp: f64) -> MsgHeader {
        MsgHeader {
            addr,
            msg_type: msg_type.code(),
            subtype,
            timestamp,
            seq: 0,
            size: 0,
        }
    }

    /// The message type, or an error for a byte outside 1..=6.
    pub fn kind(&self) -> Result<MsgType, Error> {
        MsgType::from_u8(self.msg_type).ok_or(Error::UnknownMsgType(self.msg_type))
    }

    /// The (interface, type, subtype) key that selects the body struct.
    pub fn key(&self) -> MessageKey {
        MessageKey {
            interf: self.addr.interf,
            msg_type: self.msg_type,
            subtype: self.subtype,
        }
    }

    /// The 40 header bytes.
    pub fn to_bytes(&self) -> [u8; HEADER_SIZE] {
        let mut out = Vec::with_capacity(HEADER_SIZE);
        // Every member is a fixed-size scalar, so encoding cannot fail.
        let _ = self.encode(&mut out);
        let mut bytes = [0u8; HEADER_SIZE];
        bytes.copy_from_slice(&out);
        bytes
    }

    /// Decodes exactly 40 bytes. Fails only for non-canonical widened fields (e.g. an `interf`
    /// word above 0xffff), which no XDR encoder produces.
    pub fn from_bytes(bytes: &[u8; HEADER_SIZE]) -> Result<MsgHeader, Error> {
        MsgHeader::decode(&mut Reader::new(bytes))
    }
}

/// The identification text the server sends first: `PLAYER_IDENT_STRING` + version.
pub const BANNER_TEXT: &str = "Player v.3.0.2";

/// The 32 banner bytes: [`BANNER_TEXT`] then NULs (`PLAYER_IDENT_STRLEN`), sent in one write
/// immediately after accepting a connection. libplayerc gives up unless one `recv` yields all 32.
pub const BANNER: [u8; PLAYER_IDENT_STRLEN] = {
    let mut out = [0u8; PLAYER_IDENT_STRLEN];
    let text = BANNER_TEXT.as_bytes();
    let mut i = 0;
    while i < text.len() {
        out[i] = text[i];
        i += 1;
    }
    out
};

/// The text of a received banner (up to the first NUL), for a client's "connected" message.
/// libplayerc does not check the contents; neither does this.
pub fn banner_text(banner: &[u8; PLAYER_IDENT_STRLEN]) -> String {
    let end = banner.iter().position(|&b| b == 0).unwrap_or(banner.len());
    String::from_utf8_lossy(&banner[..end]).into_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn banner_is_32_bytes_of_text_then_nul() {
        assert_eq!(&BANNER[..14], b"Player v.3.0.2");
        assert!(BANNER[14..].iter().all(|&b| b == 0));
        assert_eq!(banner_text(&BANNER), "Player v.3.0.2");
    }

    #[test]
    fn header_layout_matches_spec_3_8_1() {
        let h = MsgHeader {
            addr: DeviceAddr::new(LOCALHOST_ADDR, 6665, InterfaceCode::POSITION2D, 0),
            msg_type: 1,
            subtype: 1,
            timestamp: 12.3,
            seq: 0,
            size: 52,
        };
        let bytes = h.to_bytes();
        let expect = [
            0x01, 0x00, 0x00, 0x7f, 0x00, 0x00, 0x1a, 0x09, 0, 0, 0, 4, 0, 0, 0, 0, 0, 0, 0, 1, 0,
            0, 0, 1, 0x40, 0x28, 0x99, 0x99, 0x99, 0x99, 0x99, 0x9a, 0, 0, 0, 0, 0, 0, 0, 0x34,
        ];
        assert_eq!(bytes, expect);
        assert_eq!(MsgHeader::from_bytes(&bytes).unwrap(), h);
    }

    #[test]
    fn non_canonical_header_words_are_refused() {
        let mut bytes = [0u8; HEADER_SIZE];
        bytes[9] = 1; // interf word 0x00010000
        let err = MsgHeader::from_bytes(&bytes).unwrap_err();
        assert!(
            err.to_string().contains("player_msghdr_t.addr.interf"),
            "{err}"
        );
    }

    #[test]
    fn same_device_rule() {
        let a = DeviceAddr::new(LOCALHOST_ADDR, 6665, InterfaceCode::RANGER, 1);
        let mut b = a;
        assert!(a.same_device(&b));
        b.host = 0;
        assert!(a.same_device(&b) && b.same_device(&a));
        b.host = 0x0200_007f;
        assert!(!a.same_device(&b));
        b = a;
        b.robot = 6666;
        assert!(!a.same_device(&b));
        b = a;
        b.index = 0;
        assert!(!a.same_device(&b));
        let zero = DeviceAddr::new(0, 0, InterfaceCode(0), 0);
        assert!(!zero.same_device(&zero));
    }

    #[test]
    fn msg_types() {
        assert_eq!(MsgType::from_u8(0), None);
        assert_eq!(MsgType::from_u8(7), None);
        for t in MsgType::ALL {
            assert_eq!(MsgType::from_u8(t.code()), Some(t));
        }
        assert_eq!(MsgType::RespAck.short_name(), "RESP_ACK");
        assert_eq!(MsgType::Synch.name(), "sync");
    }
}
