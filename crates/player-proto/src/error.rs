//! The crate's one error type.
//!
//! Every way a peer's bytes can be wrong is a distinct, printable error, so the server can log
//! exactly what a client sent (and close or NACK) instead of panicking or guessing.

use std::fmt;

use crate::header::MsgType;
use crate::interface::InterfaceCode;

/// Where inside a body a problem was found: the outermost C struct and the member path down to
/// the failing member, as upstream names them (e.g. `player_ranger_data_rangestamped_t` and
/// `geom.element_poses`).
///
/// Built only on the error path, innermost member first, as the error travels outwards.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Location {
    /// The outermost C struct reached so far (empty when not yet known).
    pub structure: &'static str,
    /// Member names from that struct down to the failing member.
    pub path: Vec<&'static str>,
}

impl Location {
    /// True until a struct decoder has attached its name.
    pub fn is_unknown(&self) -> bool {
        self.structure.is_empty()
    }

    /// The location of a whole struct (no member).
    pub fn of_struct(structure: &'static str) -> Location {
        Location {
            structure,
            path: Vec::new(),
        }
    }
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.structure.is_empty() {
            return f.write_str("body");
        }
        f.write_str(self.structure)?;
        for member in &self.path {
            write!(f, ".{member}")?;
        }
        Ok(())
    }
}

/// The (interface, message type, subtype) triple that selects a body struct, as in a header.
///
/// Carried by dispatch errors so that the log line says which message was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct MessageKey {
    /// Interface code from the header's address.
    pub interf: InterfaceCode,
    /// Raw message type byte (1..=6 are the defined ones).
    pub msg_type: u8,
    /// Raw subtype byte.
    pub subtype: u8,
}

impl fmt::Display for MessageKey {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let ty = MsgType::from_u8(self.msg_type)
            .map(MsgType::name)
            .unwrap_or("unknown-type");
        write!(
            f,
            "{}({}) {}({}) subtype {}",
            self.interf, self.interf.0, ty, self.msg_type, self.subtype
        )
    }
}

/// What exactly is wrong with the bytes at a [`Location`].
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum Problem {
    /// The body ends before the member does.
    #[error("truncated: needs {needed} more bytes but only {available} remain")]
    Truncated {
        /// Bytes the member needs.
        needed: usize,
        /// Bytes left in the body.
        available: usize,
    },
    /// An array count above the C struct's fixed capacity (`PLAYER_..._MAX_...`).
    #[error("count {count} exceeds the maximum {max}")]
    CountAboveMax {
        /// The count read from the wire.
        count: u32,
        /// The fixed array size in the C struct.
        max: usize,
    },
    /// An array count that cannot possibly fit in the rest of the body (checked before allocating).
    #[error("count {count} needs at least {needed} bytes but only {available} remain")]
    CountBeyondBody {
        /// The count read from the wire.
        count: u32,
        /// Minimum bytes that many elements occupy.
        needed: u64,
        /// Bytes left in the body.
        available: usize,
    },
    /// The XDR length prefix differs from the struct's `*_count` member.
    #[error("array length word {prefix} differs from the count member {count}")]
    LengthMismatch {
        /// The `*_count` member.
        count: u32,
        /// The XDR array/bytes length prefix.
        prefix: u32,
    },
    /// A widened 8/16-bit value whose 32-bit word is not a zero/sign extension of it.
    #[error("word {word:#010x} is not a valid {ty}")]
    NotWidened {
        /// The raw word.
        word: u32,
        /// The C type it should hold.
        ty: &'static str,
    },
    /// XDR padding after a byte array that is not zero.
    #[error("non-zero padding after a byte array")]
    NonZeroPadding,
    /// Bytes left over after the body struct's last member.
    #[error("{0} trailing bytes after the last member")]
    Trailing(usize),
}

/// The error type of `player-proto`: decoding, encoding and field-map conversion failures.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum Error {
    /// The bytes do not form a valid XDR encoding of the expected struct.
    #[error("malformed {at}: {problem}")]
    Malformed {
        /// Struct and member where decoding stopped.
        at: Location,
        /// What was wrong.
        problem: Problem,
    },
    /// A message body larger than the configured [`crate::DecodeLimits::max_body`].
    #[error("message body of {size} bytes exceeds the limit of {max} bytes")]
    BodyTooLarge {
        /// The announced or actual body size.
        size: u64,
        /// The configured cap.
        max: usize,
    },
    /// The header's `size` does not match the number of body bytes supplied.
    #[error("header announces a {announced}-byte body but {actual} bytes were supplied")]
    SizeMismatch {
        /// `size` from the header.
        announced: u32,
        /// Body bytes given to the decoder.
        actual: usize,
    },
    /// A header type byte outside 1..=6.
    #[error("unknown message type {0}")]
    UnknownMsgType(u8),
    /// No row of the Player 3.0.2 function table matches (interface, type, subtype).
    #[error("no Player 3.0.2 message {0}")]
    UnknownMessage(MessageKey),
    /// A body was sent for a message whose `.def` struct is `NULL`.
    #[error("message {key} has no body struct but carries one")]
    UnexpectedBody {
        /// The message.
        key: MessageKey,
    },
    /// A DATA, CMD or SYNCH message with a body struct arrived without a body.
    #[error("message {key} requires a body but has none")]
    MissingBody {
        /// The message.
        key: MessageKey,
    },
    /// The header and the typed body disagree (type, subtype or interface).
    #[error("header says {header} but the body is {body}")]
    HeaderMismatch {
        /// What the header holds.
        header: MessageKey,
        /// What the body needs.
        body: MessageKey,
    },
    /// A value too long for its fixed C array (encoding never silently truncates).
    #[error("cannot encode {at}: {len} elements exceed the maximum {max}")]
    TooLong {
        /// Struct and member.
        at: Location,
        /// Elements present.
        len: usize,
        /// Fixed array size.
        max: usize,
    },
    /// A field map (see [`crate::Value`]) that does not describe the struct.
    #[error("field map {at}: {message}")]
    Value {
        /// Struct and member.
        at: Location,
        /// What was wrong.
        message: String,
    },
}

impl Error {
    /// A malformed-bytes error whose location the enclosing struct decoder will fill in.
    pub(crate) fn malformed(problem: Problem) -> Error {
        Error::Malformed {
            at: Location::default(),
            problem,
        }
    }

    /// A field-map error whose location the enclosing struct will fill in.
    pub(crate) fn value(message: impl Into<String>) -> Error {
        Error::Value {
            at: Location::default(),
            message: message.into(),
        }
    }

    /// Records that the error happened in `member` of `structure`; called by every enclosing
    /// struct on the way out, so the message names the full member path.
    pub(crate) fn locate(mut self, structure: &'static str, member: &'static str) -> Error {
        if let Error::Malformed { at, .. } | Error::TooLong { at, .. } | Error::Value { at, .. } =
            &mut self
        {
            at.structure = structure;
            if !member.is_empty() {
                at.path.insert(0, member);
            }
        }
        self
    }
}
