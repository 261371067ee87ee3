//! `frontseat log import` in the real binary, on a goby_logger file laid out as Goby3 writes it
//! (record/tests/fixtures/README.md): every PROTOBUF message arrives in the MCAP, including a type
//! this binary was never compiled with (decoded with the descriptors the .goby file carried), the
//! CSTR and DCCL entries are skipped and counted per group (in the output and in the MCAP
//! metadata), and damaged or hostile files never panic the importer.

mod common;

use std::path::PathBuf;
use std::process::Command;

use common::procs::scratch;
use frontseat_record::{Recording, info};
use prost_reflect::{DescriptorPool, DynamicMessage};

const NODE_STATUS: &str = "goby::middleware::frontseat::node_status";
const DESIRED: &str = "goby::middleware::frontseat::desired_course";
const SALINITY: &str = "example::science::salinity";

fn frontseat() -> Command {
    Command::new(env!("CARGO_BIN_EXE_frontseat"))
}

fn fixture() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("record/tests/fixtures/goby3_v3_sample.goby")
}

#[test]
fn a_goby_logger_file_imports_with_its_own_descriptors() {
    let dir = scratch("record", "import");
    let out = dir.join("sample.mcap");
    let _ = std::fs::remove_file(&out);
    let run = frontseat()
        .args(["log", "import"])
        .arg(fixture())
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{err}");
    assert!(err.contains("6 CSTR entries skipped"), "{err}");
    assert!(
        err.contains(
            "9 DCCL entries skipped (no DCCL codec here; by group: example::acomms::modem_status 3, example::acomms::usbl_fix 6)"
        ),
        "{err}"
    );
    assert!(err.contains("42 messages written"), "{err}");

    let i = info::info(Recording::open(&out).unwrap()).unwrap();
    assert_eq!(i.truncated, None);
    let count = |g: &str| i.groups.iter().find(|x| x.group == g).map(|x| x.count);
    assert_eq!(count(NODE_STATUS), Some(30));
    assert_eq!(count(DESIRED), Some(6));
    assert_eq!(count(SALINITY), Some(6));
    assert_eq!(i.run.get("source").map(String::as_str), Some("goby_logger"));
    // The file itself says what was left out, per group, and `log info` shows it.
    let skipped: Vec<(&str, u64)> = i
        .not_imported
        .iter()
        .map(|(k, n)| (k.as_str(), *n))
        .collect();
    assert_eq!(
        skipped,
        [
            ("CSTR example::operator_note", 6),
            ("DCCL example::acomms::modem_status", 3),
            ("DCCL example::acomms::usbl_fix", 6),
        ]
    );
    let shown = frontseat()
        .args(["log", "info"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        String::from_utf8_lossy(&shown.stdout)
            .contains("not imported (no codec or schema here): DCCL example::acomms::usbl_fix: 6"),
        "{}",
        String::from_utf8_lossy(&shown.stdout)
    );
    // Goby3's microsecond stamps are kept: 29 s from the first to the last node_status.
    let ns = i.groups.iter().find(|g| g.group == NODE_STATUS).unwrap();
    assert_eq!(ns.last - ns.first, 29_000_000_000);
    assert_eq!(ns.first, 1_764_000_000_000_000_000);

    // The salinity type exists only in the .goby file's descriptors: decode it with nothing but
    // the schema the MCAP file now carries.
    let mut rec = Recording::open(&out).unwrap();
    let mut psu = Vec::new();
    while let Some(m) = rec.next_message().unwrap() {
        let ch = rec.channel(m.channel_id).unwrap().clone();
        assert_eq!(
            ch.metadata.get("origin").map(String::as_str),
            Some("imported")
        );
        if &*ch.topic == SALINITY {
            let schema = rec.schema(ch.schema_id).unwrap();
            let pool = DescriptorPool::decode(&*schema.data).unwrap();
            let d = pool
                .get_message_by_name("example.science.Salinity")
                .unwrap();
            let msg = DynamicMessage::decode(d, m.data.as_slice()).unwrap();
            psu.push(msg.get_field_by_name("psu").unwrap().as_f64().unwrap());
        }
    }
    assert_eq!(psu.len(), 6);
    assert!((psu[0] - 34.5).abs() < 1e-9, "{psu:?}");

    // The reference Python reader opens the imported file from its schemas alone (as in
    // record_e2e.rs: CI installs it and sets FRONTSEAT_REQUIRE_PYTHON_HELM, so it cannot skip there).
    let has_py = Command::new("python3")
        .args(["-c", "import mcap, mcap_protobuf, google.protobuf"])
        .output()
        .is_ok_and(|o| o.status.success());
    if has_py {
        let py = Command::new("python3")
            .arg(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/python/read_mcap.py"))
            .arg(&out)
            .output()
            .unwrap();
        assert!(
            py.status.success(),
            "{}",
            String::from_utf8_lossy(&py.stderr)
        );
        let v: serde_json::Value = serde_json::from_slice(&py.stdout).unwrap();
        assert_eq!(v["messages"].as_u64(), Some(42));
        assert_eq!(v["first"][SALINITY]["psu"].as_f64(), Some(34.5));
    } else {
        assert!(
            std::env::var_os("FRONTSEAT_REQUIRE_PYTHON_HELM").is_none(),
            "FRONTSEAT_REQUIRE_PYTHON_HELM is set but python3 cannot import mcap/mcap_protobuf"
        );
        println!("SKIPPED the Python reader part: python3 cannot import mcap/mcap_protobuf");
    }

    // An existing output is not replaced silently.
    let again = frontseat()
        .args(["log", "import"])
        .arg(fixture())
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    assert_eq!(again.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&again.stderr).contains("--force"));
}

#[test]
fn damaged_goby_files_lose_only_the_damaged_entries() {
    let good = std::fs::read(fixture()).unwrap();
    let whole = {
        let mut out = std::io::Cursor::new(Vec::new());
        frontseat_record::import::import(good.as_slice(), &mut out, "x")
            .unwrap()
            .written
    };
    assert_eq!(whole, 42);
    // Flip a byte at many places: never a panic, never more messages than the intact file,
    // and every flipped data byte costs at most the entry it is in.
    let mut lost_one = 0;
    for at in (4..good.len()).step_by(131) {
        let mut bad = good.clone();
        bad[at] ^= 0x5a;
        frontseat_record::fuzz_import(&bad);
        let mut out = std::io::Cursor::new(Vec::new());
        if let Ok(s) = frontseat_record::import::import(bad.as_slice(), &mut out, "x") {
            assert!(s.written <= whole, "at {at}: {} > {whole}", s.written);
            if s.written == whole - 1 && s.read.crc_errors == 1 {
                lost_one += 1;
            }
        }
    }
    assert!(
        lost_one > 5,
        "a flipped data byte loses one entry ({lost_one} cases)"
    );
    // Cut anywhere: the entries before the cut still import.
    for cut in (0..good.len()).step_by(211) {
        frontseat_record::fuzz_import(&good[..cut]);
    }
    let mut out = std::io::Cursor::new(Vec::new());
    // The last 100 bytes hold the last few small entries: only those are lost.
    let cut = frontseat_record::import::import(&good[..good.len() - 100], &mut out, "x").unwrap();
    assert!(
        cut.written < whole && cut.written + 5 >= whole,
        "{}",
        cut.written
    );
    assert!(cut.read.torn_tail);
    // Hostile sizes: a 4 GiB entry length is passed over, not allocated.
    let mut hostile = good.clone();
    hostile[8..12].copy_from_slice(&u32::MAX.to_be_bytes());
    frontseat_record::fuzz_import(&hostile);
    // Not a goby file: a typed refusal in the binary, exit 1.
    let dir = scratch("record", "import_bad");
    let junk = dir.join("junk.goby");
    std::fs::write(&junk, b"this is a text file, not a log").unwrap();
    let run = frontseat()
        .args(["log", "import", "--force"])
        .arg(&junk)
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(1));
    assert!(
        String::from_utf8_lossy(&run.stderr).contains("not a goby_logger file"),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(
        !dir.join("junk.mcap").exists(),
        "no output from a refused file"
    );
    assert!(!dir.join("junk.mcap.part").exists());
}
