//! The crate's one error type.

use std::io;

use player_proto::InterfaceCode;

/// What can go wrong talking to a Player server.
#[derive(Debug, thiserror::Error)]
pub enum ClientError {
    /// The TCP connection could not be made.
    #[error("connect call on [{addr}] failed: {source}")]
    Connect {
        /// `host:port`.
        addr: String,
        /// The OS error.
        source: io::Error,
    },
    /// The server did not send its 32-byte banner at once.
    #[error("incomplete initialization string from {addr}")]
    Banner {
        /// `host:port`.
        addr: String,
    },
    /// A socket error.
    #[error("i/o error: {0}")]
    Io(#[from] io::Error),
    /// The server closed the connection.
    #[error("the server closed the connection")]
    Closed,
    /// The server sent bytes that are not a valid message.
    #[error("malformed message from the server: {0}")]
    Protocol(#[from] player_proto::Error),
    /// No reply within the request timeout.
    #[error("timed out waiting for the reply to {what}")]
    Timeout {
        /// The request.
        what: String,
    },
    /// The server answered NACK.
    #[error("got NACK from request {what}")]
    Nack {
        /// The request.
        what: String,
    },
    /// The reply lacked the body the request needs, or had another one.
    #[error("unexpected reply to {what}")]
    BadReply {
        /// The request.
        what: String,
    },
    /// Subscribing failed (the device does not exist, or its driver refused).
    #[error("could not subscribe to {interf}:{index}")]
    Subscribe {
        /// Interface.
        interf: InterfaceCode,
        /// Index.
        index: u16,
    },
    /// A PULL round ended without any DATA.
    #[error("no data received with SYNCH")]
    NoData,
    /// The server dropped messages for this client (its queue was full): the data of this
    /// round is incomplete. The count is reset once reported.
    #[error("overflow on server: {dropped} message(s) dropped")]
    Overflow {
        /// Messages the server reported dropped.
        dropped: u32,
    },
    /// A message the client did not expect here (e.g. a NACK outside a request).
    #[error("unexpected message: {0}")]
    Unexpected(String),
}
