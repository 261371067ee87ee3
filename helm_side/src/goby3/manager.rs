//! gobyd's manager handshake, pure: the `ManagerRequest` bodies a client sends on its REQ socket
//! and the checks on the `ManagerResponse` it gets back (echoed name and pid, the transport, the
//! proto2 `hold` default of true), and the endpoints it then connects its PUB and SUB to.

use prost::Message;

/// Goby3's `goby.zeromq.protobuf` messages, compiled from `proto/` by build.rs.
#[allow(clippy::all, missing_docs)]
pub mod pb {
    include!(concat!(env!("OUT_DIR"), "/goby.zeromq.protobuf.rs"));
}

use pb::{ManagerRequest, ManagerResponse, Request, socket::Transport as PbTransport};

/// A manager response is ~100 bytes; anything far bigger is not one.
pub const MAX_RESPONSE: usize = 4096;

/// Where gobyd is and how to reach the sockets it hands out.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Transport {
    /// Unix-domain sockets `<base>.manager`, `.xsub`, `.xpub`; base `/tmp/goby_<platform>` unless
    /// Goby3's `socket_name` sets it.
    Ipc { base: String },
    /// The manager on `address:port`; the publish/subscribe ports come in the response.
    Tcp { address: String, port: u16 },
}

impl Transport {
    /// The base of the IPC socket paths for a platform (Goby3's default).
    pub fn ipc_for_platform(platform: &str, socket_name: &str) -> Self {
        let base = if socket_name.is_empty() {
            format!("/tmp/goby_{platform}")
        } else {
            socket_name.to_string()
        };
        Transport::Ipc { base }
    }

    /// The manager's REP endpoint.
    pub fn manager_endpoint(&self) -> String {
        match self {
            Transport::Ipc { base } => format!("ipc://{base}.manager"),
            Transport::Tcp { address, port } => tcp_endpoint(address, *port),
        }
    }
}

fn tcp_endpoint(address: &str, port: u16) -> String {
    if address.contains(':') && !address.starts_with('[') {
        format!("tcp://[{address}]:{port}")
    } else {
        format!("tcp://{address}:{port}")
    }
}

/// What the handshake got wrong.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ManagerError {
    #[error("response of {0} bytes is larger than any manager response")]
    Oversized(usize),
    #[error("response is not a ManagerResponse: {0}")]
    Decode(String),
    #[error("response answers {got:?}, not {want:?}")]
    WrongRequest { got: Option<Request>, want: Request },
    #[error("response is for client {name:?} pid {pid}, not us")]
    NotOurs { name: String, pid: i32 },
    #[error("response has no {0} socket")]
    MissingSocket(&'static str),
    #[error("{which} socket: transport {got:?} does not match ours ({want:?})")]
    WrongTransport {
        which: &'static str,
        got: Option<PbTransport>,
        want: PbTransport,
    },
    #[error("{which} socket: no {field}")]
    MissingField {
        which: &'static str,
        field: &'static str,
    },
}

/// The two endpoints gobyd hands out: publish on its XSUB, subscribe on its XPUB.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PubSub {
    pub publish: String,
    pub subscribe: String,
}

/// `PROVIDE_PUB_SUB_SOCKETS` for `name`/`pid`.
pub fn sockets_request(name: &str, pid: i32) -> Vec<u8> {
    ManagerRequest {
        request: Request::ProvidePubSubSockets as i32,
        client_name: name.to_string(),
        client_pid: pid,
        ready: None,
    }
    .encode_to_vec()
}

/// `PROVIDE_HOLD_STATE`, saying whether our subscriptions are in place.
pub fn hold_request(name: &str, pid: i32, ready: bool) -> Vec<u8> {
    ManagerRequest {
        request: Request::ProvideHoldState as i32,
        client_name: name.to_string(),
        client_pid: pid,
        ready: Some(ready),
    }
    .encode_to_vec()
}

fn decode_ours(
    bytes: &[u8],
    want: Request,
    name: &str,
    pid: i32,
) -> Result<ManagerResponse, ManagerError> {
    if bytes.len() > MAX_RESPONSE {
        return Err(ManagerError::Oversized(bytes.len()));
    }
    let r = ManagerResponse::decode(bytes).map_err(|e| ManagerError::Decode(e.to_string()))?;
    let got = Request::try_from(r.request).ok();
    if got != Some(want) {
        return Err(ManagerError::WrongRequest { got, want });
    }
    if r.client_name != name || r.client_pid != pid {
        return Err(ManagerError::NotOurs {
            name: r.client_name.chars().take(64).collect(),
            pid: r.client_pid,
        });
    }
    Ok(r)
}

/// The endpoints in a `PROVIDE_PUB_SUB_SOCKETS` response, and its hold state. Under TCP the
/// response carries ports only: the address is the manager's, as Goby3 clients do.
pub fn parse_sockets_response(
    bytes: &[u8],
    name: &str,
    pid: i32,
    transport: &Transport,
) -> Result<(PubSub, bool), ManagerError> {
    let r = decode_ours(bytes, Request::ProvidePubSubSockets, name, pid)?;
    let endpoint = |which: &'static str, s: Option<&pb::Socket>| -> Result<String, ManagerError> {
        let s = s.ok_or(ManagerError::MissingSocket(which))?;
        let got = PbTransport::try_from(s.transport.unwrap_or(PbTransport::Epgm as i32)).ok();
        match transport {
            Transport::Ipc { .. } => {
                if got != Some(PbTransport::Ipc) {
                    return Err(ManagerError::WrongTransport {
                        which,
                        got,
                        want: PbTransport::Ipc,
                    });
                }
                match s.socket_name.as_deref() {
                    Some(n) if !n.is_empty() => Ok(format!("ipc://{n}")),
                    _ => Err(ManagerError::MissingField {
                        which,
                        field: "socket_name",
                    }),
                }
            }
            Transport::Tcp { address, .. } => {
                if got != Some(PbTransport::Tcp) {
                    return Err(ManagerError::WrongTransport {
                        which,
                        got,
                        want: PbTransport::Tcp,
                    });
                }
                match s.ethernet_port.and_then(|p| u16::try_from(p).ok()) {
                    Some(p) if p != 0 => Ok(tcp_endpoint(address, p)),
                    _ => Err(ManagerError::MissingField {
                        which,
                        field: "ethernet_port",
                    }),
                }
            }
        }
    };
    let pubsub = PubSub {
        publish: endpoint("publish", r.publish_socket.as_ref())?,
        subscribe: endpoint("subscribe", r.subscribe_socket.as_ref())?,
    };
    Ok((pubsub, r.hold()))
}

/// The hold state in a `PROVIDE_HOLD_STATE` response: absent means held (proto2 default true).
pub fn parse_hold_response(bytes: &[u8], name: &str, pid: i32) -> Result<bool, ManagerError> {
    decode_ours(bytes, Request::ProvideHoldState, name, pid).map(|r| r.hold())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn endpoints_for_ipc_and_tcp() {
        assert_eq!(
            Transport::ipc_for_platform("zp3", "").manager_endpoint(),
            "ipc:///tmp/goby_zp3.manager"
        );
        assert_eq!(
            Transport::ipc_for_platform("zp3", "/run/g/S").manager_endpoint(),
            "ipc:///run/g/S.manager"
        );
        let tcp = Transport::Tcp {
            address: "::1".into(),
            port: 11144,
        };
        assert_eq!(tcp.manager_endpoint(), "tcp://[::1]:11144");
    }

    #[test]
    fn a_response_for_someone_else_is_refused() {
        let r = ManagerResponse {
            request: Request::ProvideHoldState as i32,
            client_name: "other".into(),
            client_pid: 1,
            hold: Some(false),
            ..Default::default()
        }
        .encode_to_vec();
        assert!(matches!(
            parse_hold_response(&r, "me", 1),
            Err(ManagerError::NotOurs { .. })
        ));
        assert!(matches!(
            parse_hold_response(&r, "other", 2),
            Err(ManagerError::NotOurs { .. })
        ));
        assert_eq!(parse_hold_response(&r, "other", 1), Ok(false));
        assert!(matches!(
            parse_hold_response(&[0xff, 0xff], "other", 1),
            Err(ManagerError::Decode(_))
        ));
        assert!(matches!(
            parse_hold_response(&vec![0; MAX_RESPONSE + 1], "other", 1),
            Err(ManagerError::Oversized(_))
        ));
    }
}
