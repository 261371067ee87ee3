//! The readers against the crafted files of issue 37 (`frontseat_record::crafted`), in process:
//! what they keep is bounded by a limit that does not grow with what the file declares (the
//! reader's public `retained_bytes`), the excess is skipped and counted with a message, and
//! every command body finishes. Peak memory of the real binary on the same files:
//! `tests/hostile_recordings.rs`.

use frontseat_record::crafted;
use frontseat_record::reader::{MAX_RETAINED, Recording};
use frontseat_record::{export, import, info};

#[test]
fn definitions_with_huge_names_across_chunks_are_kept_within_the_limit() {
    // 30 chunks × 3 schemas and channels of 6 MiB names: 1.6 GiB declared in ~57 KB.
    let f = crafted::huge_definitions(30, 3, 6 << 20, 6 << 20);
    assert!(f.len() < 70_000, "{}", f.len());
    let mut r = Recording::new(f.as_slice());
    let mut n = 0;
    let mut peak = 0;
    while r.next_message().unwrap().is_some() {
        n += 1;
        peak = peak.max(r.retained_bytes());
    }
    assert_eq!(n, 90, "every message is still read");
    assert!(peak <= MAX_RETAINED, "{peak}");
    assert_eq!(
        r.skipped_definitions(),
        180,
        "every huge name skipped and counted"
    );
    let i = info::info(Recording::new(f.as_slice())).unwrap();
    assert_eq!(i.messages, 90);
    assert_eq!(i.skipped_definitions, 180);
    let note = i.render();
    assert!(
        note.contains("180 schema/channel/metadata records skipped"),
        "{note}"
    );
}

#[test]
fn many_small_definitions_stop_at_the_retained_limit() {
    // 60 chunks × 3 schemas of 200 KiB with short names: each under every per-record limit,
    // 36 MiB in all.
    let f = crafted::huge_definitions(60, 3, 8, 200 << 10);
    let mut r = Recording::new(f.as_slice());
    let mut peak = 0;
    while r.next_message().unwrap().is_some() {
        peak = peak.max(r.retained_bytes());
    }
    assert!(peak <= MAX_RETAINED, "{peak}");
    assert!(
        peak > MAX_RETAINED / 2,
        "definitions under the limit are kept: {peak}"
    );
    assert!(r.skipped_definitions() > 0);
}

#[test]
fn a_type_containing_itself_exports_a_bounded_header() {
    let f = crafted::self_referencing_type(8);
    assert!(f.len() < 1000, "{}", f.len());
    let mut out = Vec::new();
    let done = export::export(
        Recording::new(f.as_slice()),
        "t",
        export::Format::Csv,
        &mut out,
    )
    .unwrap();
    assert_eq!(done.rows, 1);
    // Each self-typed field is one JSON cell: 8 columns, not 8^8.
    assert_eq!((done.columns, done.json_cells), (8, 8));
    let text = String::from_utf8(out).unwrap();
    assert_eq!(
        text.lines().next().unwrap(),
        "log_time,f0,f1,f2,f3,f4,f5,f6,f7"
    );
}

#[test]
fn a_huge_topic_is_skipped_and_counted_and_its_messages_still_counted() {
    let f = crafted::huge_topic(48 << 20, 300);
    assert!(f.len() < 12_000, "{}", f.len());
    let i = info::info(Recording::new(f.as_slice())).unwrap();
    assert_eq!(i.messages, 300);
    assert_eq!(i.skipped_definitions, 1);
    assert_eq!(i.groups.len(), 1);
    assert_eq!(i.groups[0].group, "<unknown channel 1>");
}

#[test]
fn a_goby_group_name_of_megabytes_is_not_kept_and_its_entries_import_under_a_placeholder() {
    let f = crafted::goby_long_group(8 << 20, 2000);
    let mut out = std::io::Cursor::new(Vec::new());
    let s = import::import(f.as_slice(), &mut out, "long.goby").unwrap();
    assert_eq!(s.read.names_skipped, 1);
    assert_eq!(s.written, 2000);
    let i = info::info(Recording::new(out.into_inner().as_slice())).unwrap();
    assert_eq!(i.groups.len(), 1);
    assert_eq!(i.groups[0].group, "_unknown1_");
}
