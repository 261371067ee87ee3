//! The topside's `[record]` against a real Zenoh session on loopback: two vehicles publish
//! node_status (and one a garbage payload), the topside records what it takes in, and the closed
//! MCAP file holds each vehicle's messages on its own channel `<platform>/<group>`, decoded with
//! the file's own schemas by this crate's reader and by the reference Python reader.

mod common;

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use common::{free_port, publisher};
use frontseat_actors::groups;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CartesianCoordinate, NodeStatus,
};
use frontseat_helm_side::{key_for, put_message};
use frontseat_record::{CHANNEL_PLATFORM, Recording};
use frontseat_topside::{Topside, TopsideConfig};
use prost::Message as _;

const BOUND: Duration = Duration::from_secs(15);

struct Dir(PathBuf);
impl Drop for Dir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn scratch(what: &str) -> Dir {
    let p = std::env::temp_dir().join(format!(
        "frontseat-topside-record-{what}-{}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&p);
    std::fs::create_dir_all(&p).unwrap();
    Dir(p)
}

fn node_status(name: &str, x: f64) -> NodeStatus {
    NodeStatus {
        name: Some(name.into()),
        local_fix: Some(CartesianCoordinate {
            x,
            y: -x,
            ..Default::default()
        }),
        ..Default::default()
    }
}

fn python_has_mcap() -> bool {
    Command::new("python3")
        .args(["-c", "import mcap, mcap_protobuf, google.protobuf"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// What the reference Python reader (mcap + mcap-protobuf-support) decodes of `file`; `None`
/// when it is not installed (and CI, which installs it, did not ask for it).
fn python_read(file: &Path) -> Option<serde_json::Value> {
    if !python_has_mcap() {
        assert!(
            std::env::var_os("FRONTSEAT_REQUIRE_PYTHON_HELM").is_none(),
            "FRONTSEAT_REQUIRE_PYTHON_HELM is set but python3 cannot import mcap/mcap_protobuf"
        );
        println!(
            "SKIPPED the Python half: python3 cannot import mcap/mcap_protobuf \
             (pip install -r tests/python/requirements.txt)"
        );
        return None;
    }
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/python/read_mcap.py");
    let out = Command::new("python3")
        .arg(script)
        .arg(file)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "python reader: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    Some(serde_json::from_slice(&out.stdout).unwrap())
}

#[tokio::test(flavor = "multi_thread")]
async fn the_topside_records_each_vehicle_on_its_own_channel_and_both_readers_decode_them() {
    let dir = scratch("two");
    let file = dir.0.join("topside.mcap");
    let port = free_port();
    let z = publisher(port).await;

    let mut cfg = TopsideConfig::default();
    cfg.zenoh.connect = vec![format!("tcp/127.0.0.1:{port}")];
    cfg.web.listen = "127.0.0.1:0".into();
    cfg.record.enabled = true;
    cfg.record.path = Some(file.display().to_string());
    cfg.record.flush_s = 0.1;
    // Not a test of the disk guard: record however little the test machine's disk has free.
    cfg.record.min_free_mb = 0;
    use frontseat_config::ServiceConfig as _;
    assert!(cfg.validate().is_empty(), "{:?}", cfg.validate());

    let seen: Arc<Mutex<BTreeSet<String>>> = Arc::default();
    let observer = {
        let seen = seen.clone();
        Arc::new(move |p: &str, _: &NodeStatus| {
            seen.lock().unwrap().insert(p.to_string());
        })
    };
    let top = Topside::start_observed(&cfg, Some(observer)).await.unwrap();
    assert_eq!(top.record_file().as_deref(), Some(file.as_path()));

    let group = groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS.name();
    let ns_type = groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS.type_name();
    // auv1 at x = 1, 2, 3...; auv2 at x = -1, -2, ... so each message says whose it is. Zenoh
    // drops a put made before the topside's subscription matched: put until both are taken in.
    let deadline = tokio::time::Instant::now() + BOUND;
    let mut n = 0.0;
    loop {
        n += 1.0;
        for (p, x) in [("auv1", n), ("auv2", -n)] {
            put_message(&z, &key_for(p, group), ns_type, &node_status(p, x), None).unwrap();
        }
        // Not a node_status: counted by the topside, never a channel of the file.
        z.put(key_for("auv3", group), vec![0xff_u8; 7])
            .await
            .unwrap();
        let both = seen.lock().unwrap().len() == 2;
        let garbage = top
            .counters
            .undecodable
            .load(std::sync::atomic::Ordering::Relaxed)
            > 0;
        if both && garbage && n >= 5.0 {
            break;
        }
        assert!(
            tokio::time::Instant::now() < deadline,
            "the topside did not take in both vehicles and the garbage: {:?}",
            seen.lock().unwrap()
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    // Counted after the stop: the session is closed first, then the recorder drains its queue,
    // so every sample the model took in is in the file.
    let counters = top.counters.clone();
    top.shutdown().await;
    z.close().await.unwrap();
    let accepted = counters.accepted.load(std::sync::atomic::Ordering::Relaxed);

    // This crate's reader: every message on a `<platform>/<group>` channel with the platform in
    // its metadata, decoded as the NodeStatus its schema names.
    let mut rec = Recording::open(&file).unwrap();
    let mut by_platform: std::collections::BTreeMap<String, Vec<f64>> = Default::default();
    let mut messages = 0u64;
    while let Some(m) = rec.next_message().unwrap() {
        messages += 1;
        let ch = rec.channel(m.channel_id).unwrap().clone();
        let platform = ch.metadata.get(CHANNEL_PLATFORM).unwrap().clone();
        assert_eq!(&*ch.topic, format!("{platform}/{group}"));
        let schema = rec.schema(ch.schema_id).unwrap();
        assert_eq!(schema.name, ns_type);
        assert!(!schema.data.is_empty(), "the FileDescriptorSet is embedded");
        let ns = NodeStatus::decode(m.data.as_slice()).unwrap();
        assert_eq!(ns.name.as_deref(), Some(platform.as_str()));
        by_platform
            .entry(platform)
            .or_default()
            .push(ns.local_fix.unwrap().x);
    }
    assert_eq!(rec.truncated(), None, "the stop closed the file");
    assert_eq!(
        by_platform.keys().map(String::as_str).collect::<Vec<_>>(),
        ["auv1", "auv2"],
        "no channel for the undecodable auv3 payload"
    );
    assert!(by_platform["auv1"].iter().all(|x| *x > 0.0));
    assert!(by_platform["auv2"].iter().all(|x| *x < 0.0));
    assert_eq!(messages, accepted, "every sample taken in is recorded");

    // `log info` sees two groups; `log plot` two vehicles, each with its own track.
    let info = frontseat_record::info::info(Recording::open(&file).unwrap()).unwrap();
    assert_eq!(info.groups.len(), 2);
    assert_eq!(info.dropped, Some(0));
    assert_eq!(info.run.get("vehicle").map(String::as_str), Some("topside"));
    let series = frontseat_record::plot::series(Recording::open(&file).unwrap()).unwrap();
    // In order of first appearance, which is whichever vehicle's sample the topside heard first.
    let mut vehicles = series.vehicles.clone();
    vehicles.sort();
    assert_eq!(vehicles, ["auv1", "auv2"]);
    assert_eq!(series.actual.len() as u64, messages);

    // The reference Python reader decodes every message with the file's schemas.
    if let Some(v) = python_read(&file) {
        assert_eq!(v["messages"].as_u64(), Some(messages), "{v}");
        for p in ["auv1", "auv2"] {
            let topic = format!("{p}/{group}");
            assert_eq!(
                v["topics"][&topic].as_u64(),
                Some(by_platform[p].len() as u64),
                "{v}"
            );
            assert_eq!(v["first"][&topic]["name"], p, "{v}");
        }
    }
}

#[test]
fn a_topside_record_section_is_checked_and_foxglove_is_refused() {
    use frontseat_config::ServiceConfig as _;
    let mut cfg = TopsideConfig::default();
    cfg.record.enabled = true;
    cfg.record.flush_s = 0.0;
    cfg.record.include = vec!["(".into()];
    cfg.record.foxglove.enabled = true;
    let e: Vec<String> = cfg.validate().iter().map(|e| e.to_string()).collect();
    let e = e.join("\n");
    for field in [
        "record.flush_s",
        "record.include[0]",
        "record.foxglove.enabled",
    ] {
        assert!(e.contains(field), "{field} not in {e}");
    }
}
