//! The framed protocol between the interface and its `frontseat driver-host` child, over the
//! child's stdin (interface → host: [`ToHost`]) and stdout (host → interface: [`FromHost`]).
//! A frame is a 4-byte little-endian length and that many bytes of one protobuf message; frames
//! over [`MAX_FRAME`] are refused, so a confused peer cannot make us allocate without bound.
#![forbid(unsafe_code)]

use std::io::{Read, Write};

use prost::Message;

use crate::Error;

/// Largest frame either side accepts (16 MiB).
pub const MAX_FRAME: usize = 16 << 20;

/// Interface → driver host.
#[derive(Clone, PartialEq, Message)]
pub struct ToHost {
    #[prost(oneof = "to_host::Op", tags = "1, 2, 3, 4, 5, 6")]
    pub op: Option<to_host::Op>,
}

pub mod to_host {
    /// One operation; the host answers Load with Loaded or LoadFailed and Tick with TickDone.
    #[derive(Clone, PartialEq, prost::Oneof)]
    pub enum Op {
        /// The config bytes for `frontseat_driver_load`; always the first frame.
        #[prost(bytes, tag = "1")]
        Load(Vec<u8>),
        /// An encoded CommandRequest.
        #[prost(bytes, tag = "2")]
        Command(Vec<u8>),
        /// An encoded InterfaceData.
        #[prost(bytes, tag = "3")]
        Data(Vec<u8>),
        /// An encoded Raw.
        #[prost(bytes, tag = "4")]
        Raw(Vec<u8>),
        /// `loop()` at this simulated time (µs).
        #[prost(uint64, tag = "5")]
        Tick(u64),
        /// Unload the driver and exit.
        #[prost(bool, tag = "6")]
        Unload(bool),
    }
}

/// Driver host → interface.
#[derive(Clone, PartialEq, Message)]
pub struct FromHost {
    #[prost(oneof = "from_host::Event", tags = "1, 2, 3, 4, 5, 6, 7, 8, 9, 10")]
    pub event: Option<from_host::Event>,
}

pub mod from_host {
    #[derive(Clone, PartialEq, prost::Oneof)]
    pub enum Event {
        #[prost(message, tag = "1")]
        Loaded(super::Loaded),
        #[prost(message, tag = "2")]
        LoadFailed(super::LoadFailed),
        #[prost(bytes, tag = "3")]
        CommandResponse(Vec<u8>),
        #[prost(bytes, tag = "4")]
        DataFromFrontseat(Vec<u8>),
        #[prost(bytes, tag = "5")]
        RawFromFrontseat(Vec<u8>),
        #[prost(bytes, tag = "6")]
        RawToFrontseat(Vec<u8>),
        #[prost(message, tag = "7")]
        State(super::State),
        /// The simulated time (µs) of the tick just run.
        #[prost(uint64, tag = "8")]
        TickDone(u64),
        #[prost(message, tag = "9")]
        OpFailed(super::OpFailed),
        #[prost(message, tag = "10")]
        Log(super::Log),
    }
}

#[derive(Clone, PartialEq, Message)]
pub struct Loaded {
    #[prost(uint32, tag = "1")]
    pub abi_version: u32,
}

/// Why the library or the driver could not be loaded; `kind` is [`Error::exit_code`].
#[derive(Clone, PartialEq, Message)]
pub struct LoadFailed {
    #[prost(uint32, tag = "1")]
    pub kind: u32,
    #[prost(string, tag = "2")]
    pub path: String,
    /// The reason (config rejected, not loadable) or the missing symbol.
    #[prost(string, tag = "3")]
    pub detail: String,
    #[prost(uint32, tag = "4")]
    pub found_abi_version: u32,
}

#[derive(Clone, PartialEq, Message)]
pub struct State {
    #[prost(int32, tag = "1")]
    pub frontseat_state: i32,
    #[prost(bool, tag = "2")]
    pub providing_data: bool,
}

#[derive(Clone, PartialEq, Message)]
pub struct OpFailed {
    #[prost(string, tag = "1")]
    pub op: String,
    /// `FSD_ERR_*`.
    #[prost(int32, tag = "2")]
    pub code: i32,
}

#[derive(Clone, PartialEq, Message)]
pub struct Log {
    #[prost(int32, tag = "1")]
    pub level: i32,
    #[prost(string, tag = "2")]
    pub message: String,
}

impl LoadFailed {
    pub fn from_error(e: &Error) -> Self {
        let mut f = LoadFailed {
            kind: u32::from(e.exit_code()),
            detail: e.to_string(),
            ..Default::default()
        };
        match e {
            Error::LibraryMissing { path } => f.path = path.display().to_string(),
            Error::LibraryNotLoadable { path, reason } => {
                f.path = path.display().to_string();
                f.detail = reason.clone();
            }
            Error::SymbolMissing { path, symbol } => {
                f.path = path.display().to_string();
                f.detail = symbol.clone();
            }
            Error::AbiMismatch { path, found, .. } => {
                f.path = path.display().to_string();
                f.found_abi_version = *found;
            }
            Error::ConfigRejected { reason } => f.detail = reason.clone(),
            Error::Host(_) | Error::Frame(_) | Error::Io(_) => {}
        }
        f
    }

    /// The typed error back, on the interface's side.
    pub fn to_error(&self) -> Error {
        let path = std::path::PathBuf::from(&self.path);
        match self.kind {
            3 => Error::LibraryMissing { path },
            4 => Error::SymbolMissing {
                path,
                symbol: self.detail.clone(),
            },
            5 => Error::AbiMismatch {
                path,
                found: self.found_abi_version,
                expected: crate::abi::ABI_VERSION,
            },
            6 => Error::LibraryNotLoadable {
                path,
                reason: self.detail.clone(),
            },
            7 => Error::ConfigRejected {
                reason: self.detail.clone(),
            },
            _ => Error::Host(self.detail.clone()),
        }
    }
}

/// Encodes one frame.
pub fn encode(msg: &impl Message) -> Vec<u8> {
    let len = msg.encoded_len();
    let mut out = Vec::with_capacity(4 + len);
    out.extend_from_slice(&(len as u32).to_le_bytes());
    msg.encode_raw(&mut out);
    out
}

fn check_len(header: [u8; 4]) -> Result<usize, Error> {
    let len = u32::from_le_bytes(header) as usize;
    if len > MAX_FRAME {
        return Err(Error::Frame(format!(
            "frame of {len} bytes exceeds the {MAX_FRAME}-byte limit"
        )));
    }
    Ok(len)
}

fn decode<M: Message + Default>(body: &[u8]) -> Result<M, Error> {
    M::decode(body).map_err(|e| Error::Frame(format!("undecodable frame: {e}")))
}

/// Writes one frame and flushes.
pub fn write_frame(w: &mut impl Write, msg: &impl Message) -> Result<(), Error> {
    w.write_all(&encode(msg))?;
    w.flush()?;
    Ok(())
}

/// Reads one frame; Ok(None) at a clean end of stream (between frames).
pub fn read_frame<M: Message + Default>(r: &mut impl Read) -> Result<Option<M>, Error> {
    let mut header = [0u8; 4];
    let mut got = 0;
    while got < 4 {
        match r.read(&mut header[got..]) {
            Ok(0) if got == 0 => return Ok(None),
            Ok(0) => return Err(Error::Frame("stream ended inside a frame header".into())),
            Ok(n) => got += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e.into()),
        }
    }
    let len = check_len(header)?;
    let mut body = vec![0u8; len];
    r.read_exact(&mut body)?;
    decode(&body).map(Some)
}

/// Async [`read_frame`].
#[cfg(feature = "host")]
pub async fn read_frame_async<M: Message + Default>(
    r: &mut (impl tokio::io::AsyncRead + Unpin),
) -> Result<Option<M>, Error> {
    use tokio::io::AsyncReadExt;
    let mut header = [0u8; 4];
    let mut got = 0;
    while got < 4 {
        match r.read(&mut header[got..]).await? {
            0 if got == 0 => return Ok(None),
            0 => return Err(Error::Frame("stream ended inside a frame header".into())),
            n => got += n,
        }
    }
    let len = check_len(header)?;
    let mut body = vec![0u8; len];
    r.read_exact(&mut body).await?;
    decode(&body).map(Some)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_round_trip_and_end_cleanly() {
        let mut buf = Vec::new();
        let a = ToHost {
            op: Some(to_host::Op::Tick(123)),
        };
        let b = ToHost {
            op: Some(to_host::Op::Command(vec![1, 2, 3])),
        };
        write_frame(&mut buf, &a).unwrap();
        write_frame(&mut buf, &b).unwrap();
        let mut r = &buf[..];
        assert_eq!(read_frame::<ToHost>(&mut r).unwrap(), Some(a));
        assert_eq!(read_frame::<ToHost>(&mut r).unwrap(), Some(b));
        assert_eq!(read_frame::<ToHost>(&mut r).unwrap(), None);
    }

    #[test]
    fn oversized_truncated_and_garbage_frames_are_typed_errors() {
        let huge = ((MAX_FRAME + 1) as u32).to_le_bytes();
        assert!(matches!(
            read_frame::<ToHost>(&mut &huge[..]),
            Err(Error::Frame(_))
        ));
        assert!(matches!(
            read_frame::<ToHost>(&mut &[1u8, 0][..]),
            Err(Error::Frame(_))
        ));
        let short_body = [10u8, 0, 0, 0, 1, 2];
        assert!(matches!(
            read_frame::<ToHost>(&mut &short_body[..]),
            Err(Error::Io(_))
        ));
        let garbage = [2u8, 0, 0, 0, 0xff, 0xff];
        assert!(matches!(
            read_frame::<ToHost>(&mut &garbage[..]),
            Err(Error::Frame(_))
        ));
    }

    #[test]
    fn load_failures_keep_their_type_across_the_pipe() {
        let e = Error::AbiMismatch {
            path: "/x/lib.so".into(),
            found: 7,
            expected: crate::abi::ABI_VERSION,
        };
        let back = LoadFailed::from_error(&e).to_error();
        assert_eq!(back.to_string(), e.to_string());
        let e = Error::SymbolMissing {
            path: "/x/lib.so".into(),
            symbol: "frontseat_driver_loop".into(),
        };
        assert_eq!(
            LoadFailed::from_error(&e).to_error().to_string(),
            e.to_string()
        );
        let e = Error::ConfigRejected {
            reason: "no port".into(),
        };
        assert_eq!(
            LoadFailed::from_error(&e).to_error().to_string(),
            e.to_string()
        );
    }
}
