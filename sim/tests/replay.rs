//! Replays the client side of the real Goby3 simulator transcript
//! (`shared/protocol/goby3_sim/goby_sim_transcript.txt`) against our simulator over loopback and
//! checks our replies line by line.
//!
//! Runs at 10× the transcript's WARP (simulated dt stays 1/FREQ, so the numbers are the same,
//! only sooner). Where Goby3's simulator is wrong, our documented behaviour (PROTOCOL.md,
//! "Differences from Goby3") is expected instead, listed in `deviation()`. Positions are compared
//! in metres with a tolerance of 1 cm + 3 % of the distance from START: Goby3 projects in the
//! standard UTM zone (grid north 1.4° off true north at Boston), we in a transverse Mercator
//! centred on START.

mod common;

use common::*;
use frontseat_sim::SimOptions;
use frontseat_sim::codec::{Nav, Outbound, format_nav, parse_outbound};
use frontseat_sim::vehicle::wrap_heading;

const WARP_FACTOR: f64 = 10.0;

#[derive(Debug, Clone)]
enum Event {
    Connect(char),
    Close(char),
    Send {
        client: char,
        bytes: Vec<u8>,
        comment: String,
    },
    Recv(char, String),
    /// Anything else said about a client (elided NAV lines, a summary): ends a run of NAVs.
    Note(char),
}

fn decode_escaped(s: &str) -> Vec<u8> {
    let b = s.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'\\' && i + 1 < b.len() {
            match b[i + 1] {
                b'r' => out.push(b'\r'),
                b'n' => out.push(b'\n'),
                b't' => out.push(b'\t'),
                b'x' => {
                    out.push(u8::from_str_radix(&s[i + 2..i + 4], 16).unwrap());
                    i += 2;
                }
                other => out.push(other),
            }
            i += 2;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    out
}

/// A Python bytes repr body (between the quotes), with `...<N bytes total>...` expanded by
/// repeating the byte before the marker.
fn decode_repr(body: &str) -> Vec<u8> {
    if let Some(a) = body.find("...<") {
        let b = body[a..].find(">...").unwrap() + a;
        let total: usize = body[a + 4..b]
            .split_whitespace()
            .next()
            .unwrap()
            .parse()
            .unwrap();
        let prefix = decode_escaped(&body[..a]);
        let suffix = decode_escaped(&body[b + 4..]);
        let fill = *prefix.last().unwrap();
        let mut v = prefix.clone();
        v.resize(total - suffix.len(), fill);
        v.extend_from_slice(&suffix);
        assert_eq!(v.len(), total);
        v
    } else {
        decode_escaped(body)
    }
}

fn parse_transcript(text: &str) -> Vec<Event> {
    let mut events = Vec::new();
    for line in text.lines() {
        let t = line.trim_start();
        if let Some(rest) = t.strip_prefix("t=") {
            let rest = rest.trim_start();
            let (_, rest) = rest.split_once(' ').unwrap();
            let rest = rest.trim_start();
            let client = rest.chars().next().unwrap();
            let rest = rest[1..].trim_start();
            if rest == "CONNECT" {
                events.push(Event::Connect(client));
            } else if rest == "CLOSE" {
                events.push(Event::Close(client));
            } else if let Some(r) = rest.strip_prefix("RECV ") {
                events.push(Event::Recv(client, r.to_string()));
            } else if let Some(r) = rest.strip_prefix("SEND b'") {
                let bytes = r.as_bytes();
                let mut i = 0;
                while bytes[i] != b'\'' {
                    i += if bytes[i] == b'\\' { 2 } else { 1 };
                }
                let comment = r[i + 1..]
                    .split_once('#')
                    .map(|(_, c)| c.trim().to_string())
                    .unwrap_or_default();
                events.push(Event::Send {
                    client,
                    bytes: decode_repr(&r[..i]),
                    comment,
                });
            } else {
                events.push(Event::Note(client));
            }
        } else if let Some(c) = t.chars().next().filter(|c| c.is_ascii_uppercase())
            && t.as_bytes().get(1) == Some(&b' ')
        {
            events.push(Event::Note(c));
        }
    }
    events
}

/// Reference replies (non-NAV) to the send at `i`, for its client, up to the next send/connect/
/// close; and the run of consecutive NAV lines right after the first reply.
fn reference_after(events: &[Event], i: usize, client: char) -> (Vec<String>, Vec<Nav>) {
    let mut replies = Vec::new();
    let mut navs = Vec::new();
    let mut in_run = true;
    for e in &events[i + 1..] {
        match e {
            Event::Send { .. } | Event::Connect(_) | Event::Close(_) => break,
            Event::Recv(c, l) if *c == client => {
                if is_nav(l) {
                    // Goby's inf/nan NAV lines do not parse; they are never compared.
                    if let (false, true, Ok(Outbound::Nav(n))) =
                        (replies.is_empty(), in_run, parse_outbound(l))
                    {
                        navs.push(n);
                    }
                } else {
                    replies.push(l.clone());
                }
            }
            Event::Note(c) if *c == client && !replies.is_empty() => in_run = false,
            _ => {}
        }
    }
    (replies, navs)
}

#[derive(Debug, PartialEq)]
enum Expect {
    Lines(Vec<String>),
    /// An `ERROR,REASON:` line starting with this.
    ErrorStarting(&'static str),
    Closed,
}

/// Where we deliberately differ from Goby3's simulator (PROTOCOL.md lists each).
fn deviation(comment: &str) -> Option<Expect> {
    let err = || Expect::Lines(vec!["CMD,RESULT:ERROR".into()]);
    let ok = || Expect::Lines(vec!["CMD,RESULT:OK".into()]);
    Some(match comment {
        // Goby: silently ignored. Ours: CMD before START is refused.
        "CMD before START" | "CMD after IDLE (not started)" => err(),
        // B never sent START: in ours it is its own vehicle, not started.
        "command from second client B" => err(),
        // Goby: "Invalid line", no reply. Ours: HEADING has no value → refused.
        "key without ':value'" => err(),
        // Goby takes '90' from '90:5'. Ours: '90:5' is not a number.
        "extra ':' in a field" => err(),
        // Goby: "Invalid line", no reply. Ours: the empty last field is ignored.
        "trailing comma" => ok(),
        // Goby: OK, then NaN heading forever. Ours: not a number → refused.
        "non-numeric HEADING (goby::util::as<double> -> NaN, no exception)" => err(),
        // Goby waits for CR LF and joins lines. Ours: LF alone ends a line.
        "LF only" => ok(),
        // Goby: CTRL,STATE:IDLE. Ours: refused, the running vehicle stays as it was.
        "START missing LAT (simulator already started)" => {
            Expect::ErrorStarting("ERROR,REASON:invalid START: LAT")
        }
        // Lines over 1 KiB close the connection.
        c if c.contains("100 KB") || c.contains("1 MB") => Expect::Closed,
        _ => return None,
    })
}

fn check_nav_sane(n: &Nav) {
    assert!(n.lat.is_finite() && n.lon.is_finite() && n.depth.is_finite());
    assert!((-90.0..=90.0).contains(&n.lat) && (-180.0..180.0).contains(&n.lon));
    assert!((0.0..360.0).contains(&n.heading), "{n:?}");
    assert!(n.speed.is_finite());
}

fn rewrite_warp(bytes: &[u8]) -> Vec<u8> {
    let s = String::from_utf8(bytes.to_vec()).unwrap();
    let Some(rest) = s.strip_suffix("\r\n") else {
        return bytes.to_vec();
    };
    if !rest.starts_with("START,") {
        return bytes.to_vec();
    }
    let fields: Vec<String> = rest
        .split(',')
        .map(|f| match f.strip_prefix("WARP:") {
            Some(w) => format!("WARP:{}", w.parse::<f64>().unwrap() * WARP_FACTOR),
            None => f.to_string(),
        })
        .collect();
    let mut line = fields.join(",");
    if !line.contains("WARP:") {
        line.push_str(&format!(",WARP:{WARP_FACTOR}"));
    }
    format!("{line}\r\n").into_bytes()
}

struct Peer {
    client: Client,
    id: u64,
    running: bool,
    last_start: Option<Vec<u8>>,
}

async fn connect(h: &frontseat_sim::SimHandle, known: &mut Vec<u64>) -> Peer {
    let client = Client::connect(h).await;
    let id = new_vehicle(h, known).await;
    known.push(id);
    Peer {
        client,
        id,
        running: false,
        last_start: None,
    }
}

fn metres_between(a: &Nav, b: &Nav) -> f64 {
    metres((a.lat, a.lon), (b.lat, b.lon))
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn replay_goby3_transcript() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/fixtures/goby3_sim/goby_sim_transcript.txt"
    );
    let text = std::fs::read_to_string(path).unwrap();
    let events = parse_transcript(&text);
    assert!(
        events.len() > 300,
        "transcript parsed to {} events",
        events.len()
    );

    let h = sim(SimOptions::default()).await;
    let mut known = Vec::new();
    let mut peers: std::collections::HashMap<char, Peer> = Default::default();
    let origin = Nav {
        lat: 42.358456,
        lon: -71.087589,
        depth: 0.0,
        heading: 0.0,
        speed: 0.0,
    };
    let mut sends = 0;
    let mut deep_checks = 0;
    for (i, e) in events.iter().enumerate() {
        match e {
            Event::Connect(c) => {
                let p = connect(&h, &mut known).await;
                peers.insert(*c, p);
            }
            Event::Close(c) => {
                peers.remove(c);
            }
            Event::Send {
                client,
                bytes,
                comment,
            } => {
                sends += 1;
                let (ref_replies, ref_navs) = reference_after(&events, i, *client);
                let expect =
                    deviation(comment).unwrap_or_else(|| Expect::Lines(ref_replies.clone()));
                let bytes = rewrite_warp(bytes);
                let line = String::from_utf8_lossy(&bytes).trim().to_string();
                let p = peers.get_mut(client).unwrap();
                let mut truth = h.subscribe_truth();
                if expect == Expect::Closed {
                    p.client.try_send_raw(&bytes).await;
                    assert!(p.client.until_eof().await.is_empty(), "{comment}");
                    // Adaptation: reconnect and START again, so the rest can be replayed.
                    let last = p.last_start.clone().unwrap();
                    let mut np = connect(&h, &mut known).await;
                    np.client.send_raw(&last).await;
                    np.client.expect("CTRL,STATE:PAYLOAD").await;
                    np.running = true;
                    np.last_start = Some(last);
                    peers.insert(*client, np);
                    continue;
                }
                p.client.send_raw(&bytes).await;
                if line.starts_with("START,") && !matches!(expect, Expect::ErrorStarting(_)) {
                    p.last_start = Some(bytes.clone());
                }
                let want_n = match &expect {
                    Expect::Lines(v) => v.len(),
                    _ => 1,
                };
                // Our lines in order until the expected replies are in.
                let mut got = Vec::new();
                let mut navs_between = Vec::new();
                let mut first_after_reply: Vec<Nav> = Vec::new();
                while got.len() < want_n {
                    let l = p.client.must_line().await;
                    if is_nav(&l) {
                        let n = nav_of(&l);
                        check_nav_sane(&n);
                        navs_between.push(n);
                        if got.len() == 1 && first_after_reply.is_empty() {
                            first_after_reply.push(n);
                        }
                    } else {
                        got.push(l);
                    }
                }
                match &expect {
                    Expect::Lines(v) => assert_eq!(&got, v, "send {sends} ({comment}): {line}"),
                    Expect::ErrorStarting(p) => assert!(got[0].starts_with(p), "{}", got[0]),
                    Expect::Closed => unreachable!(),
                }
                for l in &got {
                    match l.as_str() {
                        "CTRL,STATE:PAYLOAD" => p.running = true,
                        "CTRL,STATE:IDLE" => p.running = false,
                        _ => {}
                    }
                }

                if comment == "re-START with DURATION:2 (no ACCEL etc -> defaults)" {
                    // Ours: exactly DURATION·FREQ = 20 NAV lines, at rest at START (reset).
                    let skipped = h.stats().skipped_ticks as usize;
                    assert!(navs_between.len() <= 20 && navs_between.len() + skipped >= 20);
                    for n in &navs_between {
                        assert_eq!(n, &origin);
                    }
                    deep_checks += 1;
                }
                if comment == "re-START does not reset vehicle x/y/z/v/hdg"
                    || (sends == 2 && line.starts_with("START,"))
                {
                    let n = match first_after_reply.first() {
                        Some(n) => *n,
                        None => p.client.nav().await,
                    };
                    assert_eq!(n, origin, "START puts the vehicle at rest at START");
                    deep_checks += 1;
                }
                let cmd_deep = (sends == 3 && line == "CMD,HEADING:90,SPEED:1.5,DEPTH:0")
                    || line == "CMD,HEADING:270,SPEED:2,DEPTH:5";
                if cmd_deep && p.running {
                    assert!(ref_navs.len() >= 6, "{}", ref_navs.len());
                    // Pair each of our NAV lines with its tick through the truth stream.
                    let mut ours: Vec<(f64, Nav)> = Vec::new();
                    let mut pending = first_after_reply.clone();
                    let freq = if line.contains("270") { 20.0 } else { 10.0 };
                    while ours.last().map(|(t, _)| *t).unwrap_or(0.0)
                        < ours.first().map(|(t, _)| *t).unwrap_or(0.0)
                            + (ref_navs.len() as f64 - 1.0) / freq
                            - 1e-9
                        || ours.is_empty()
                    {
                        let n = match pending.pop() {
                            Some(n) => n,
                            None => p.client.nav().await,
                        };
                        let want = format_nav(&n);
                        let t = loop {
                            let t = truth_of(&mut truth, p.id).await;
                            let as_nav = Nav {
                                lat: t.lat,
                                lon: t.lon,
                                depth: t.depth,
                                heading: t.heading,
                                speed: t.speed,
                            };
                            if format_nav(&as_nav) == want {
                                break t;
                            }
                        };
                        ours.push((t.sim_time, n));
                    }
                    let t0 = ours[0].0;
                    for (t, n) in &ours {
                        let j = ((t - t0) * freq).round() as usize;
                        let Some(r) = ref_navs.get(j) else { break };
                        assert!((n.depth - r.depth).abs() < 1e-6, "tick {j}: {n:?} vs {r:?}");
                        if freq == 10.0 {
                            // From rest at START, exactly as the transcript.
                            assert!((n.heading - r.heading).abs() < 1e-6, "{j}: {n:?} {r:?}");
                            assert!((n.speed - r.speed).abs() < 1e-6, "{j}: {n:?} {r:?}");
                            let dist = metres_between(&origin, r);
                            let err = metres_between(n, r);
                            assert!(err <= 0.01 + 0.03 * dist, "{j}: {err} m off at {dist} m");
                        } else {
                            // Goby did not reset at this START (heading 90, 1.5 m/s); ours did
                            // (heading 0, at rest): same rates, from a different state.
                            let turned = r.heading - 90.0;
                            assert!((n.heading - wrap_heading(-turned)).abs() < 1e-6, "{j}");
                            assert!((n.speed - (r.speed - 1.5)).abs() < 1e-6, "{j}");
                        }
                    }
                    deep_checks += 1;
                }
                // Nothing more than expected: a few more ticks bring no other line.
                if p.running {
                    let extra = p.client.others_until_navs(3).await;
                    assert!(
                        extra.is_empty(),
                        "send {sends} ({comment}): extra {extra:?}"
                    );
                }
            }
            Event::Recv(..) | Event::Note(_) => {}
        }
    }
    assert_eq!(sends, 42, "every SEND of the transcript replayed");
    assert_eq!(deep_checks, 5);
    h.shutdown().await;
}
