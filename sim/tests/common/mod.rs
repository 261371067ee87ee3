//! Test helpers: an in-process simulator on 127.0.0.1 and a line client with timeouts.
#![allow(dead_code)]

use std::net::{Ipv4Addr, SocketAddr};
use std::time::Duration;

use frontseat_sim::codec::{Nav, Outbound, parse_outbound};
use frontseat_sim::{SimHandle, SimOptions, SimServer, Truth};
use tokio::io::{AsyncBufReadExt, AsyncWriteExt, BufReader};
use tokio::net::TcpStream;
use tokio::net::tcp::{OwnedReadHalf, OwnedWriteHalf};
use tokio::sync::broadcast;

pub const WAIT: Duration = Duration::from_secs(20);

pub async fn sim(opts: SimOptions) -> SimHandle {
    SimServer::bind(SocketAddr::from((Ipv4Addr::LOCALHOST, 0)), opts)
        .await
        .unwrap()
}

pub struct Client {
    rd: BufReader<OwnedReadHalf>,
    wr: OwnedWriteHalf,
}

pub fn is_nav(l: &str) -> bool {
    l.starts_with("NAV,")
}

pub fn nav_of(l: &str) -> Nav {
    match parse_outbound(l) {
        Ok(Outbound::Nav(n)) => n,
        other => panic!("not a NAV line: {l:?} ({other:?})"),
    }
}

impl Client {
    pub async fn connect(h: &SimHandle) -> Self {
        let s = tokio::time::timeout(WAIT, TcpStream::connect(h.local_addr()))
            .await
            .unwrap()
            .unwrap();
        let (rd, wr) = s.into_split();
        Self {
            rd: BufReader::new(rd),
            wr,
        }
    }

    /// Send one line with its `\r\n`.
    pub async fn send(&mut self, line: &str) {
        self.send_raw(format!("{line}\r\n").as_bytes()).await;
    }

    pub async fn send_raw(&mut self, b: &[u8]) {
        self.wr.write_all(b).await.unwrap();
    }

    /// Like `send_raw` but tolerates the server having closed the connection.
    pub async fn try_send_raw(&mut self, b: &[u8]) -> bool {
        self.wr.write_all(b).await.is_ok()
    }

    /// The next line as bytes without its terminator; `None` at EOF (or reset).
    pub async fn raw_line(&mut self) -> Option<Vec<u8>> {
        let mut buf = Vec::new();
        let n = tokio::time::timeout(WAIT, self.rd.read_until(b'\n', &mut buf))
            .await
            .expect("timed out waiting for a line");
        match n {
            Ok(0) | Err(_) => None,
            Ok(_) => {
                assert!(buf.ends_with(b"\r\n"), "line not ended by CR LF: {buf:?}");
                buf.truncate(buf.len() - 2);
                Some(buf)
            }
        }
    }

    pub async fn line(&mut self) -> Option<String> {
        self.raw_line()
            .await
            .map(|b| String::from_utf8_lossy(&b).into_owned())
    }

    pub async fn must_line(&mut self) -> String {
        self.line().await.expect("unexpected EOF")
    }

    pub async fn nav(&mut self) -> Nav {
        let l = self.must_line().await;
        nav_of(&l)
    }

    /// The next line that is not a NAV.
    pub async fn non_nav(&mut self) -> Option<String> {
        loop {
            let l = self.line().await?;
            if !is_nav(&l) {
                return Some(l);
            }
        }
    }

    pub async fn expect(&mut self, want: &str) {
        let got = self.non_nav().await;
        assert_eq!(got.as_deref(), Some(want));
    }

    /// Non-NAV lines seen until `k` NAV lines have been read.
    pub async fn others_until_navs(&mut self, k: usize) -> Vec<String> {
        let mut others = Vec::new();
        let mut navs = 0;
        while navs < k {
            let l = self.must_line().await;
            if is_nav(&l) {
                navs += 1;
            } else {
                others.push(l);
            }
        }
        others
    }

    /// Read until EOF; the non-NAV lines seen.
    pub async fn until_eof(&mut self) -> Vec<String> {
        let mut others = Vec::new();
        while let Some(l) = self.line().await {
            if !is_nav(&l) {
                others.push(l);
            }
        }
        others
    }
}

/// The next truth of `vehicle`.
pub async fn truth_of(rx: &mut broadcast::Receiver<Truth>, vehicle: u64) -> Truth {
    tokio::time::timeout(WAIT, async {
        loop {
            match rx.recv().await {
                Ok(t) if t.vehicle == vehicle => return t,
                Ok(_) => {}
                Err(broadcast::error::RecvError::Lagged(n)) => panic!("truth lagged by {n}"),
                Err(e) => panic!("truth stream: {e}"),
            }
        }
    })
    .await
    .expect("timed out waiting for truth")
}

/// Id of the only vehicle that is not in `known`.
pub async fn new_vehicle(h: &SimHandle, known: &[u64]) -> u64 {
    tokio::time::timeout(WAIT, async {
        loop {
            if let Some(id) = h.vehicles().into_iter().find(|v| !known.contains(v)) {
                return id;
            }
            tokio::task::yield_now().await;
        }
    })
    .await
    .expect("vehicle never registered")
}

/// Metres between two positions (small distances).
pub fn metres(a: (f64, f64), b: (f64, f64)) -> f64 {
    let dn = (b.0 - a.0) * 111_132.0;
    let de = (b.1 - a.1) * 111_320.0 * a.0.to_radians().cos();
    dn.hypot(de)
}
