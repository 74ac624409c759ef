//! Framing: cutting a byte stream into (header, body) messages.
//!
//! TCP delivers arbitrary chunks; a message is 40 header bytes plus `size` body bytes with no
//! delimiters. The framer buffers only what it has been given and refuses a header announcing a
//! body over the cap as soon as the header is complete, so a hostile `size` costs nothing.

use crate::constants::PLAYERXDR_MAX_MESSAGE_SIZE;
use crate::error::Error;
use crate::header::{HEADER_SIZE, MsgHeader};
use crate::message::Message;

/// Decoding limits applied to untrusted peers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DecodeLimits {
    /// Largest body accepted, in bytes. The default is upstream's encoded-message bound
    /// (`PLAYERXDR_MAX_MESSAGE_SIZE`, 32 MiB): room for any camera image or map tile a 3.0.2
    /// server could send, yet finite.
    pub max_body: usize,
}

impl Default for DecodeLimits {
    fn default() -> Self {
        DecodeLimits {
            max_body: PLAYERXDR_MAX_MESSAGE_SIZE,
        }
    }
}

/// One complete message as cut from the stream: decoded header, raw body bytes.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// The header (its `size` equals `body.len()`).
    pub header: MsgHeader,
    /// Exactly `header.size` body bytes.
    pub body: Vec<u8>,
}

impl Frame {
    /// A frame from a header and raw body bytes; the header's `size` is set to the body length.
    ///
    /// This is how to send what the typed [`Body`](crate::Body) cannot express, e.g. the
    /// bodyless NACK upstream returns for a request subtype that is not in the table.
    pub fn new(header: MsgHeader, body: Vec<u8>) -> Result<Frame, Error> {
        let size = u32::try_from(body.len()).map_err(|_| Error::BodyTooLarge {
            size: body.len() as u64,
            max: u32::MAX as usize,
        })?;
        Ok(Frame {
            header: MsgHeader { size, ..header },
            body,
        })
    }

    /// Decodes the body into a typed [`Message`].
    pub fn decode(&self, limits: &DecodeLimits) -> Result<Message, Error> {
        Message::decode(self.header, &self.body, limits)
    }

    /// Appends the 40 header bytes and the body to `out`.
    pub fn encode_into(&self, out: &mut Vec<u8>) {
        out.extend_from_slice(&self.header.to_bytes());
        out.extend_from_slice(&self.body);
    }
}

impl TryFrom<&Message> for Frame {
    type Error = Error;

    /// Encodes a typed message's body (checking it against the header, as
    /// [`Message::encode`] does).
    fn try_from(msg: &Message) -> Result<Frame, Error> {
        let mut bytes = msg.encode()?;
        let body = bytes.split_off(HEADER_SIZE);
        let header = MsgHeader {
            size: body.len() as u32,
            ..msg.header
        };
        Ok(Frame { header, body })
    }
}

/// Accumulates received chunks and yields complete frames.
///
/// A framing error (oversized or malformed header) leaves the stream without a known message
/// boundary, so it is sticky: every later call returns it again and the connection should close.
#[derive(Debug)]
pub struct Framer {
    buf: Vec<u8>,
    start: usize,
    limits: DecodeLimits,
    failed: Option<Error>,
}

impl Framer {
    /// An empty framer with the given limits.
    pub fn new(limits: DecodeLimits) -> Framer {
        Framer {
            buf: Vec::new(),
            start: 0,
            limits,
            failed: None,
        }
    }

    /// Appends received bytes.
    pub fn push(&mut self, chunk: &[u8]) {
        // Drop consumed bytes before growing, so the buffer stays about one message long.
        if self.start > 0 && (self.start == self.buf.len() || self.start >= self.buf.len() / 2) {
            self.buf.drain(..self.start);
            self.start = 0;
        }
        self.buf.extend_from_slice(chunk);
    }

    /// Bytes received but not yet returned in a frame.
    pub fn buffered(&self) -> usize {
        self.buf.len() - self.start
    }

    /// The next complete frame, `Ok(None)` if more bytes are needed, or the framing error.
    pub fn next_frame(&mut self) -> Result<Option<Frame>, Error> {
        if let Some(e) = &self.failed {
            return Err(e.clone());
        }
        let pending = &self.buf[self.start..];
        let Some(head) = pending.first_chunk::<HEADER_SIZE>() else {
            return Ok(None);
        };
        let header = match MsgHeader::from_bytes(head) {
            Ok(h) => h,
            Err(e) => return Err(self.fail(e)),
        };
        let size = header.size as usize;
        if size > self.limits.max_body {
            return Err(self.fail(Error::BodyTooLarge {
                size: u64::from(header.size),
                max: self.limits.max_body,
            }));
        }
        if pending.len() - HEADER_SIZE < size {
            return Ok(None);
        }
        let body = pending[HEADER_SIZE..HEADER_SIZE + size].to_vec();
        self.start += HEADER_SIZE + size;
        Ok(Some(Frame { header, body }))
    }

    fn fail(&mut self, e: Error) -> Error {
        self.failed = Some(e.clone());
        e
    }
}

impl Default for Framer {
    fn default() -> Self {
        Framer::new(DecodeLimits::default())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::constants::LOCALHOST_ADDR;
    use crate::header::{DeviceAddr, MsgType};
    use crate::interface::InterfaceCode;
    use crate::message::{Body, PlayerMsg, PlayerSynch, RangerData};
    use crate::types::RangerDataRange;

    fn stream() -> (Vec<u8>, Vec<Message>) {
        let addr = DeviceAddr::new(LOCALHOST_ADDR, 6665, InterfaceCode::RANGER, 0);
        let msgs = vec![
            Message::new(
                addr,
                1.0,
                RangerData::Range(RangerDataRange {
                    ranges: vec![1.0, 2.5, 4.0],
                }),
            ),
            Message::new(
                DeviceAddr::new(0, 0, InterfaceCode::PLAYER, 0),
                2.0,
                Body::Player(PlayerMsg::Synch(PlayerSynch::Ok)),
            ),
            Message::new(addr, 3.0, RangerData::Range(RangerDataRange::default())),
        ];
        let mut bytes = Vec::new();
        for m in &msgs {
            m.encode_into(&mut bytes).unwrap();
        }
        (bytes, msgs)
    }

    #[test]
    fn frames_any_chunking() {
        let (bytes, msgs) = stream();
        for chunk in [1, 3, 7, 40, 41, 1000] {
            let mut framer = Framer::default();
            let mut got = Vec::new();
            for piece in bytes.chunks(chunk) {
                framer.push(piece);
                while let Some(frame) = framer.next_frame().unwrap() {
                    got.push(frame.decode(&DecodeLimits::default()).unwrap());
                }
            }
            assert_eq!(framer.buffered(), 0);
            assert_eq!(got.len(), msgs.len());
            for (g, m) in got.iter().zip(&msgs) {
                assert_eq!(g.body, m.body);
                assert_eq!(g.header.addr, m.header.addr);
                assert_eq!(g.header.kind().unwrap(), m.body.msg_type());
            }
        }
    }

    #[test]
    fn frames_carry_what_bodies_cannot() {
        // A NACK to a request subtype the table does not have: header only.
        let h = MsgHeader::new(
            DeviceAddr::new(LOCALHOST_ADDR, 6665, InterfaceCode::PLAYER, 0),
            MsgType::RespNack,
            99,
            0.0,
        );
        let frame = Frame::new(h, Vec::new()).unwrap();
        let mut out = Vec::new();
        frame.encode_into(&mut out);
        assert_eq!(out.len(), HEADER_SIZE);
        let mut framer = Framer::default();
        framer.push(&out);
        assert_eq!(framer.next_frame().unwrap(), Some(frame));

        let (bytes, msgs) = stream();
        let frame = Frame::try_from(&msgs[0]).unwrap();
        let mut out = Vec::new();
        frame.encode_into(&mut out);
        assert_eq!(out, bytes[..out.len()]);
        assert_eq!(
            frame.decode(&DecodeLimits::default()).unwrap().body,
            msgs[0].body
        );
    }

    #[test]
    fn partial_message_waits() {
        let (bytes, _) = stream();
        let mut framer = Framer::default();
        framer.push(&bytes[..39]);
        assert_eq!(framer.next_frame().unwrap(), None);
        framer.push(&bytes[39..71]);
        assert_eq!(framer.next_frame().unwrap(), None);
        framer.push(&bytes[71..72]);
        let frame = framer.next_frame().unwrap().unwrap();
        assert_eq!(frame.body.len(), 32);
        assert_eq!(frame.header.msg_type, MsgType::Data.code());
    }

    #[test]
    fn oversized_body_is_refused_from_the_header_alone() {
        let mut header = [0u8; HEADER_SIZE];
        header[36..].copy_from_slice(&0xffff_fff0u32.to_be_bytes());
        let mut framer = Framer::new(DecodeLimits { max_body: 1 << 20 });
        framer.push(&header);
        let err = framer.next_frame().unwrap_err();
        assert_eq!(
            err.to_string(),
            "message body of 4294967280 bytes exceeds the limit of 1048576 bytes"
        );
        // Sticky: the stream has no usable boundary any more.
        framer.push(&[0; 100]);
        assert_eq!(framer.next_frame().unwrap_err(), err);
        assert!(framer.buffered() < 200);
    }
}
