//! What Goby3 prints with `-e` (`--example_config`) that is not protobuf text: the line it
//! writes as it loads the driver library ("Loading frontseat driver library: …", first), and a
//! field printed with no value (`lat:   #  (required)`), Goby3's placeholder for a value the user
//! must give. Goby3 itself refuses both when it reads the file back. Here each is found, with its
//! line, column and Goby3 path, and blanked out of the text (same lengths, so every other error
//! keeps its line and column); what becomes of each blank value is the import rules' decision.

use std::borrow::Cow;

/// The line goby_frontseat_interface writes as it loads `FRONTSEAT_DRIVER_LIBRARY`.
pub const BANNER: &str = "Loading frontseat driver library: ";

/// A field printed with no value.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Blank {
    /// Goby3's dotted path (`frontseat_cfg.origin.lat`), extensions in brackets.
    pub path: String,
    /// 1-based line and column of the field's name.
    pub line: usize,
    pub column: usize,
}

/// The text with Goby3's banner and blank fields blanked out, the banner (when the text started
/// with it) and the blank fields in file order.
pub struct Scanned<'a> {
    pub text: Cow<'a, str>,
    pub banner: Option<String>,
    pub blanks: Vec<Blank>,
}

/// Deeper nesting than this is not tracked (paths of blanks beyond it are cut); the parser still
/// reads the file as it is.
const MAX_DEPTH: usize = 64;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Tok {
    /// A name, number, enum value or bracketed extension name.
    Word,
    Str,
    Punct(u8),
}

/// Tokens of protobuf text format with their byte ranges; comments and white space dropped. A
/// byte the format does not know is a one-byte punctuation: the parser reports it.
fn tokens(text: &str) -> Vec<(Tok, usize, usize)> {
    let b = text.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let c = b[i];
        if c.is_ascii_whitespace() {
            i += 1;
        } else if c == b'#' {
            while i < b.len() && b[i] != b'\n' {
                i += 1;
            }
        } else if c == b'"' || c == b'\'' {
            let start = i;
            i += 1;
            while i < b.len() && b[i] != c && b[i] != b'\n' {
                i += if b[i] == b'\\' { 2 } else { 1 };
            }
            i = (i + 1).min(b.len());
            out.push((Tok::Str, start, i));
        } else if c == b'[' {
            let start = i;
            while i < b.len() && b[i] != b']' && b[i] != b'\n' {
                i += 1;
            }
            i = (i + 1).min(b.len());
            out.push((Tok::Word, start, i));
        } else if c.is_ascii_alphanumeric() || matches!(c, b'_' | b'.' | b'-' | b'+') {
            let start = i;
            while i < b.len()
                && (b[i].is_ascii_alphanumeric() || matches!(b[i], b'_' | b'.' | b'-' | b'+'))
            {
                i += 1;
            }
            out.push((Tok::Word, start, i));
        } else {
            let len = text[i..].chars().next().map_or(1, char::len_utf8);
            out.push((Tok::Punct(c), i, i + len));
            i += len;
        }
    }
    out
}

/// Finds Goby3's banner and blank fields (see the module's text).
pub fn scan(text: &str) -> Scanned<'_> {
    let mut edits: Vec<(usize, usize)> = Vec::new();
    let mut banner = None;
    if let Some(rest) = text.strip_prefix(BANNER) {
        let line = rest.lines().next().unwrap_or_default();
        banner = Some(format!("{BANNER}{line}"));
        // `#` over its first byte: the line becomes a comment of the same length.
        edits.push((0, 0));
    }
    let toks = tokens(text);
    let word = |k: usize| toks.get(k).is_some_and(|t| t.0 == Tok::Word);
    let punct = |k: usize, p: u8| toks.get(k).is_some_and(|t| t.0 == Tok::Punct(p));
    let mut stack: Vec<&str> = Vec::new();
    let mut blanks = Vec::new();
    let mut k = 0;
    // Tokens of the banner line are not config.
    if banner.is_some() {
        let end = text.find('\n').unwrap_or(text.len());
        while toks.get(k).is_some_and(|t| t.1 < end) {
            k += 1;
        }
    }
    while k < toks.len() {
        let (tok, s, e) = toks[k];
        match tok {
            Tok::Word if punct(k + 1, b'{') || punct(k + 1, b'<') => {
                if stack.len() < MAX_DEPTH {
                    stack.push(&text[s..e]);
                }
                k += 2;
            }
            Tok::Word if punct(k + 1, b':') && (punct(k + 2, b'{') || punct(k + 2, b'<')) => {
                if stack.len() < MAX_DEPTH {
                    stack.push(&text[s..e]);
                }
                k += 3;
            }
            Tok::Word if punct(k + 1, b':') => {
                // A value follows, unless what follows is the next field, a block's end or
                // the end: then the field was printed with no value.
                let v = k + 2;
                let next_is_field =
                    word(v) && (punct(v + 1, b':') || punct(v + 1, b'{') || punct(v + 1, b'<'));
                let none = v >= toks.len() || punct(v, b'}') || punct(v, b'>') || next_is_field;
                if none
                    && text[s..e]
                        .bytes()
                        .all(|c| c.is_ascii_alphanumeric() || c == b'_')
                {
                    let (line, column) = super::super::line_column(text, s).unwrap_or((0, 0));
                    let mut path: Vec<&str> = stack.clone();
                    path.push(&text[s..e]);
                    blanks.push(Blank {
                        path: path.join("."),
                        line,
                        column,
                    });
                    // The name and its colon become spaces.
                    edits.push((s, toks[k + 1].2));
                    k += 2;
                } else {
                    k += 3;
                }
            }
            Tok::Punct(b'}') | Tok::Punct(b'>') => {
                stack.pop();
                k += 1;
            }
            _ => k += 1,
        }
    }
    if edits.is_empty() {
        return Scanned {
            text: Cow::Borrowed(text),
            banner,
            blanks,
        };
    }
    let mut bytes = text.as_bytes().to_vec();
    for (s, e) in edits {
        if s == e {
            bytes[s] = b'#';
        } else {
            bytes[s..e].fill(b' ');
        }
    }
    // ASCII replaced ASCII (the banner's `L`, a plain name and its colon): still UTF-8.
    let text = String::from_utf8(bytes).map_or(Cow::Borrowed(text), Cow::Owned);
    Scanned {
        text,
        banner,
        blanks,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blank_fields_are_found_with_their_path_and_blanked_in_place() {
        let text = "Loading frontseat driver library: libx.so\n\
                    frontseat_cfg {\n  origin {\n    lat:   #  (required)\n    lon:\n  }\n  \
                    type: AUV\n  [a.b] { tcp_address: \"\" start { lat: } }\n}\nname: \"x:\" # a: b\n";
        let s = scan(text);
        assert_eq!(
            s.banner.as_deref(),
            Some("Loading frontseat driver library: libx.so")
        );
        let got: Vec<(&str, usize, usize)> = s
            .blanks
            .iter()
            .map(|b| (b.path.as_str(), b.line, b.column))
            .collect();
        assert_eq!(
            got,
            [
                ("frontseat_cfg.origin.lat", 4, 5),
                ("frontseat_cfg.origin.lon", 5, 5),
                ("frontseat_cfg.[a.b].start.lat", 8, 35),
            ]
        );
        assert_eq!(s.text.len(), text.len());
        assert_eq!(s.text.lines().count(), text.lines().count());
        assert!(s.text.starts_with("#oading"));
        assert!(
            s.text
                .contains(&format!("\n{}#  (required)\n", " ".repeat(11)))
        );
    }

    #[test]
    fn a_value_on_the_next_line_or_an_enum_value_is_not_blank() {
        for text in [
            "frontseat_cfg {\n  status_period:\n    5\n}\n",
            "frontseat_cfg { type:\n AUV require_helm: true }\n",
            "frontseat_cfg { origin: { lat: 1 lon: 2 } }\n",
            "a: \"#:\" b: 'x' c: -1.5e3 d: nan",
        ] {
            let s = scan(text);
            assert!(s.blanks.is_empty(), "{text:?}: {:?}", s.blanks);
            assert!(matches!(s.text, Cow::Borrowed(_)));
        }
    }

    #[test]
    fn arbitrary_text_never_panics() {
        for text in [
            "", ":", "a:", "}}}", "[", "\"", "a { b: ", "é: ", "[x]:", "a:\u{0}",
        ] {
            let _ = scan(text);
        }
    }
}
