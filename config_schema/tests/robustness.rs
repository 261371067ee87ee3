//! Arbitrary text never panics the loader: every prefix of the example, and every single-byte
//! corruption of its first lines, gives Ok or a typed error.

use frontseat_config::{ConfigError, InterfaceConfig, SimConfig, example, parse};

#[test]
fn every_prefix_of_the_example_parses_or_errors() {
    let text = example::<InterfaceConfig>();
    let mut errors = 0;
    for (i, _) in text.char_indices() {
        match parse::<InterfaceConfig>(&text[..i], "p.toml") {
            Ok(_) => {}
            Err(ConfigError::Parse { .. } | ConfigError::Invalid { .. }) => errors += 1,
            Err(e) => panic!("unexpected {e}"),
        }
    }
    assert!(errors > 0, "some prefixes cut a value in half");
}

#[test]
fn corrupted_bytes_give_typed_errors() {
    let text = example::<SimConfig>();
    let bytes = text.as_bytes();
    for i in (0..bytes.len()).step_by(7) {
        for b in [b'[', b'"', b'=', b'\n', b'x', b'9'] {
            let mut m = bytes.to_vec();
            m[i] = b;
            if let Ok(s) = String::from_utf8(m) {
                let _ = parse::<SimConfig>(&s, "c.toml");
            }
        }
    }
}

#[test]
fn error_messages_are_one_line_each() {
    for text in [
        "name = \"x\n",
        "[origin\n",
        "a = = 1\n",
        "[[origin]]\n",
        "type = 3\n",
    ] {
        let e = parse::<InterfaceConfig>(text, "c.toml").unwrap_err();
        let shown = e.to_string();
        assert!(shown.starts_with("c.toml:1:"), "{shown}");
        assert!(!shown.contains('\n'), "{shown:?}");
    }
}
