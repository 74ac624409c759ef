//! The Player 3.0.2 TCP wire protocol, as unmodified libplayerc/libplayerc++ speak it.
//!
//! Everything here is plain data and pure functions: no sockets, no async. The server and the
//! client library both build on it, so the byte layout of every message is declared once:
//!
//! * [`types`] — every message struct, declared with `xdr_struct!`, which generates the XDR
//!   encoder, the decoder and a [`Value`] view keyed by the C member names;
//! * [`message`] — upstream's (interface, type, subtype) → struct table, declared once with
//!   `message_table!`, which generates the typed enums ([`Position2dCmd::Vel`],
//!   [`RangerData::Range`], [`PlayerReq::Dev`], ...), [`Body`], and the decoder dispatch;
//! * [`header`] — the 40-byte [`MsgHeader`], [`DeviceAddr`], [`MsgType`] and the [`BANNER`];
//! * [`frame`] — the [`Framer`] that cuts a byte stream into messages, with [`DecodeLimits`].
//!
//! Decoding never trusts the peer: counts are checked against fixed C capacities and against the
//! bytes actually received before anything is allocated, bodies are capped, and every problem is
//! an [`Error`] naming the struct member involved.

#![warn(missing_docs)]

#[macro_use]
mod macros;

pub mod constants;
mod error;
pub mod frame;
#[cfg(test)]
mod fuzz;
pub mod header;
pub mod interface;
pub mod message;
pub mod types;
mod value;
pub mod xdr;

pub use error::{Error, Location, MessageKey, Problem};
pub use frame::{DecodeLimits, Frame, Framer};
pub use header::{BANNER, BANNER_TEXT, DeviceAddr, HEADER_SIZE, MsgHeader, MsgType, banner_text};
pub use interface::InterfaceCode;
pub use message::*;
pub use types::*;
pub use value::Value;
pub use xdr::{Text, Xdr, XdrStruct};
