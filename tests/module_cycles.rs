//! No module pair imports each other: in every crate of the workspace, for every two sibling
//! modules a and b, not both "a uses b" and "b uses a". A mutual pair is the start of a tangle
//! that no later split can undo without touching both sides, so the build refuses it early.
//!
//! The check reads the sources (no compiler help): every `crate::…` and `super::…` path outside a
//! line comment, brace groups expanded, is resolved to the longest module it names, then lifted to
//! the two siblings under the common ancestor (a reference into a child of b counts as "uses b").
//! A parent and its own child may reference each other — that is how `mod` trees work.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

type Module = Vec<String>;

/// Every crate source folder of the workspace (a folder with a Cargo.toml and a src/).
fn crate_sources(root: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(dir) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        if dir.join("Cargo.toml").is_file() && dir.join("src").is_dir() {
            out.push(dir.join("src"));
        }
        for e in entries.flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            // Build output, the out-of-workspace fuzz crate, and hidden folders are not ours.
            if e.path().is_dir()
                && !name.starts_with('.')
                && !matches!(name.as_str(), "target" | "fuzz" | "node_modules" | "src")
            {
                stack.push(e.path());
            }
        }
    }
    out.sort();
    out
}

/// The module path of every .rs file under `src` (`lib.rs`/`main.rs`/`mod.rs` name their folder).
fn modules(src: &Path) -> BTreeMap<Module, PathBuf> {
    let mut out = BTreeMap::new();
    let mut stack = vec![src.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for e in std::fs::read_dir(&dir).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
                continue;
            }
            if p.extension().and_then(|x| x.to_str()) != Some("rs") {
                continue;
            }
            let rel = p.strip_prefix(src).unwrap().with_extension("");
            let mut m: Module = rel
                .components()
                .map(|c| c.as_os_str().to_string_lossy().into_owned())
                .collect();
            // src/bin/* are crate roots of their own, not modules of this crate.
            if m.first().is_some_and(|f| f == "bin") {
                continue;
            }
            if m.last()
                .is_some_and(|l| matches!(l.as_str(), "lib" | "main" | "mod"))
            {
                m.pop();
            }
            out.insert(m, p);
        }
    }
    out
}

#[derive(Debug, PartialEq)]
enum Tok {
    Ident(String),
    Sep,
    Open,
    Close,
    Comma,
    Star,
    Other,
}

fn tokens(text: &str) -> Vec<Tok> {
    let mut toks = Vec::new();
    for line in text.lines() {
        // Doc and line comments name modules in prose; they are not imports.
        let code = line.split("//").next().unwrap_or("");
        let b: Vec<char> = code.chars().collect();
        let mut i = 0;
        while i < b.len() {
            let c = b[i];
            if c.is_alphanumeric() || c == '_' {
                let s = i;
                while i < b.len() && (b[i].is_alphanumeric() || b[i] == '_') {
                    i += 1;
                }
                toks.push(Tok::Ident(b[s..i].iter().collect()));
                continue;
            }
            if c == ':' && b.get(i + 1) == Some(&':') {
                toks.push(Tok::Sep);
                i += 2;
                continue;
            }
            toks.push(match c {
                '{' => Tok::Open,
                '}' => Tok::Close,
                ',' => Tok::Comma,
                '*' => Tok::Star,
                c if c.is_whitespace() => {
                    i += 1;
                    continue;
                }
                _ => Tok::Other,
            });
            i += 1;
        }
    }
    toks
}

/// Parses the rest of a path after `prefix::` at `toks[i]`, brace groups included; pushes every
/// full path it names to `out` and returns the index after it.
fn tree(toks: &[Tok], mut i: usize, prefix: Module, out: &mut Vec<Module>) -> usize {
    match toks.get(i) {
        Some(Tok::Open) => {
            i += 1;
            loop {
                match toks.get(i) {
                    Some(Tok::Close) | None => return i + 1,
                    Some(Tok::Comma) => i += 1,
                    Some(Tok::Ident(s)) if s == "self" => {
                        out.push(prefix.clone());
                        i += 1;
                    }
                    Some(Tok::Ident(_)) => i = tree(toks, i, prefix.clone(), out),
                    Some(_) => i += 1,
                }
            }
        }
        Some(Tok::Ident(s)) => {
            let mut p = prefix;
            p.push(s.clone());
            if toks.get(i + 1) == Some(&Tok::Sep) {
                tree(toks, i + 2, p, out)
            } else {
                out.push(p);
                i + 1
            }
        }
        Some(Tok::Star) => {
            out.push(prefix);
            i + 1
        }
        _ => {
            out.push(prefix);
            i
        }
    }
}

/// Every module path a file's `crate::` and `super::` paths name, as absolute paths.
fn references(this: &Module, text: &str) -> Vec<Module> {
    let toks = tokens(text);
    let mut out = Vec::new();
    let mut i = 0;
    while i < toks.len() {
        let start = match &toks[i] {
            Tok::Ident(s) if s == "crate" && toks.get(i + 1) == Some(&Tok::Sep) => {
                i += 2;
                Vec::new()
            }
            Tok::Ident(s) if s == "super" && toks.get(i + 1) == Some(&Tok::Sep) => {
                let mut base = this.clone();
                while matches!(&toks.get(i), Some(Tok::Ident(s)) if s == "super")
                    && toks.get(i + 1) == Some(&Tok::Sep)
                {
                    base.pop();
                    i += 2;
                }
                base
            }
            _ => {
                i += 1;
                continue;
            }
        };
        i = tree(&toks, i, start, &mut out);
    }
    out
}

/// The mutual pairs of sibling modules in one crate, as "a <-> b".
fn mutual_pairs(src: &Path) -> Vec<String> {
    let mods = modules(src);
    let mut edges: BTreeSet<(Module, Module)> = BTreeSet::new();
    for (m, path) in &mods {
        let text = std::fs::read_to_string(path).unwrap();
        for r in references(m, &text) {
            let Some(t) = (1..=r.len())
                .rev()
                .map(|k| r[..k].to_vec())
                .find(|p| mods.contains_key(p))
            else {
                continue;
            };
            let common = m.iter().zip(&t).take_while(|(a, b)| a == b).count();
            // An ancestor or descendant (or itself): not a sibling pair.
            if common == m.len() || common == t.len() {
                continue;
            }
            edges.insert((m[..=common].to_vec(), t[..=common].to_vec()));
        }
    }
    edges
        .iter()
        .filter(|(a, b)| a < b && edges.contains(&(b.clone(), a.clone())))
        .map(|(a, b)| format!("{}: {} <-> {}", src.display(), a.join("::"), b.join("::")))
        .collect()
}

#[test]
fn no_two_modules_import_each_other() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let srcs = crate_sources(root);
    // The workspace has a dozen crates; finding only a few means the walk is broken.
    assert!(srcs.len() >= 10, "found only {srcs:?}");
    let pairs: Vec<String> = srcs.iter().flat_map(|s| mutual_pairs(s)).collect();
    assert!(
        pairs.is_empty(),
        "modules that import each other:\n{}",
        pairs.join("\n")
    );
}

#[test]
fn the_checker_sees_a_mutual_pair() {
    let dir = std::env::temp_dir().join(format!("module_cycles_{}", std::process::id()));
    let src = dir.join("src");
    std::fs::create_dir_all(src.join("b")).unwrap();
    std::fs::write(src.join("lib.rs"), "mod a;\nmod b;\n").unwrap();
    std::fs::write(src.join("a.rs"), "use crate::{x, b::{inner::Y, self}};\n").unwrap();
    std::fs::write(src.join("b/mod.rs"), "mod inner;\n").unwrap();
    // A child of b importing a counts as b importing a; a comment naming a does not count.
    std::fs::write(
        src.join("b/inner.rs"),
        "// crate::a is only named here\nuse super::super::a::Thing;\n",
    )
    .unwrap();
    let pairs = mutual_pairs(&src);
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(pairs.len(), 1, "{pairs:?}");
    assert!(pairs[0].ends_with("a <-> b"), "{pairs:?}");
}
