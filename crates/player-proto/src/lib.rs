//! The Player 3.0.2 TCP wire protocol, as unmodified libplayerc/libplayerc++ speak it.
//!
//! Everything here is plain data and pure functions: no sockets, no async. The server and the
//! client library both build on it, so the byte layout of every message is declared once.

pub mod interface;

pub use interface::InterfaceCode;
