//! A config from an older version: a key standing where this version does not have it, but has
//! it under another table, is refused with the path where it lives now (`moved.rs`).

use frontseat_config::{ConfigError, InterfaceConfig, SimConfig, parse};

fn parse_message<T: frontseat_config::ServiceConfig + std::fmt::Debug>(text: &str) -> String {
    match parse::<T>(text, "old.toml") {
        Err(e @ ConfigError::Parse { .. }) => e.to_string(),
        other => panic!("expected a parse error, got {other:?}"),
    }
}

#[test]
fn a_key_at_the_top_level_that_moved_into_a_table_names_its_new_place() {
    let msg =
        parse_message::<InterfaceConfig>("name = \"auv1\"\nhuxley_tcp_address = \"10.0.0.2\"\n");
    assert!(
        msg.starts_with("old.toml:2:1: unknown field `huxley_tcp_address`"),
        "{msg}"
    );
    assert!(
        msg.contains(
            "This version has `huxley_tcp_address` at `driver.bluefin.huxley_tcp_address`:"
        ),
        "{msg}"
    );
    assert!(msg.contains("older version"), "{msg}");
    assert!(msg.contains("Move it to [driver.bluefin]"), "{msg}");
}

#[test]
fn a_key_with_several_homes_names_each() {
    let msg = parse_message::<InterfaceConfig>("tcp_port = 54321\n");
    assert!(msg.contains("unknown field `tcp_port`"), "{msg}");
    assert!(msg.contains("`driver.basic_simulator.tcp_port`"), "{msg}");
    assert!(msg.contains("`goby3.tcp_port`"), "{msg}");
}

#[test]
fn a_key_in_the_wrong_table_names_the_right_one() {
    let msg = parse_message::<InterfaceConfig>(
        "[driver]\nname = \"basic_simulator\"\ntcp_address = \"127.0.0.1\"\n",
    );
    assert!(msg.contains("unknown field `tcp_address`"), "{msg}");
    assert!(
        msg.contains("`driver.basic_simulator.tcp_address`"),
        "{msg}"
    );
}

#[test]
fn a_table_key_that_moved_out_to_the_top_level_is_found_too() {
    // The simulator's `port` is a top-level key; written under a table, it is found there.
    let msg = parse_message::<SimConfig>("[current]\nport = 1\n");
    assert!(msg.contains("unknown field `port`"), "{msg}");
    assert!(msg.contains("at `port`"), "{msg}");
    assert!(msg.contains("Move it to the top level"), "{msg}");
}

#[test]
fn a_plain_typo_gets_no_moved_hint() {
    let msg = parse_message::<InterfaceConfig>("requre_helm = true\n");
    assert!(msg.contains("unknown field `requre_helm`"), "{msg}");
    assert!(!msg.contains("older version"), "{msg}");
}
