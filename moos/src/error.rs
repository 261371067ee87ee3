//! The one error type of this crate: wire decoding failures, handshake refusals, I/O and API misuse.
//!
//! Decode errors carry the offending numbers so that a log line says exactly what was wrong with
//! the bytes; after any decode error the byte stream is out of step and the connection is closed.

use thiserror::Error;

/// Everything that can go wrong in the MOOS codec, client or broker.
#[derive(Debug, Error)]
pub enum MoosError {
    /// A packet's length field is smaller than the 9-byte header or negative.
    #[error("bad packet length {0} (must be at least 9)")]
    BadPacketLength(i64),
    /// A packet's length field exceeds the configured maximum; nothing was allocated for it.
    #[error("packet of {len} bytes exceeds the maximum of {max} bytes")]
    PacketTooLarge { len: usize, max: usize },
    /// The message count of a packet is negative or cannot fit in the packet.
    #[error("bad message count {count} for a packet of {len} bytes")]
    BadMessageCount { count: i64, len: usize },
    /// A message length field is impossible (below the 54-byte minimum or past the packet end).
    #[error("bad message length {len} ({available} bytes available)")]
    BadMessageLength { len: i64, available: usize },
    /// A string length field inside a message is negative or runs past the message end.
    #[error("bad length {len} of field `{field}` ({available} bytes left in the message)")]
    BadFieldLength {
        field: &'static str,
        len: i64,
        available: usize,
    },
    /// The fields of a message do not add up to its declared length.
    #[error("message declares {declared} bytes but its fields use {used}")]
    MessageLengthMismatch { declared: usize, used: usize },
    /// The messages of a packet do not add up to its declared length.
    #[error("packet declares {declared} bytes but its messages use {used}")]
    PacketLengthMismatch { declared: usize, used: usize },
    /// Unknown message type character.
    #[error("unknown message type 0x{0:02x}")]
    UnknownMessageType(u8),
    /// Unknown data type character.
    #[error("unknown data type 0x{0:02x}")]
    UnknownDataType(u8),
    /// The 32-byte protocol banner is not `ELKS CAN'T DANCE 2/8/10`.
    #[error("incompatible wire protocol banner {0:?}")]
    BadBanner(String),
    /// The DB refused the handshake with a POISON message (e.g. the name is already in use).
    #[error("handshake refused by the DB: {0}")]
    Poisoned(String),
    /// The handshake reply was neither WELCOME nor POISON, or held not exactly one message.
    #[error("unexpected handshake reply: {0}")]
    UnexpectedHandshake(String),
    /// A handshake or read did not finish in time.
    #[error("timed out: {0}")]
    Timeout(&'static str),
    /// The peer closed the connection.
    #[error("connection closed by peer")]
    Closed,
    /// An outgoing message would not fit in the maximum packet size (or an i32 length field).
    #[error("message of {len} bytes exceeds the maximum packet size of {max} bytes")]
    MessageTooLarge { len: usize, max: usize },
    /// A configuration value or call argument is invalid.
    #[error("invalid argument: {0}")]
    InvalidArgument(String),
    /// The client or broker has been shut down.
    #[error("shut down")]
    Shutdown,
    /// Socket error.
    #[error("I/O error: {0}")]
    Io(#[from] std::io::Error),
}

/// Result alias of this crate.
pub type Result<T, E = MoosError> = std::result::Result<T, E>;
