//! The front door stays true: every ```console block of README.md and the guide
//! (docs/guide/src) runs against the built binary and must print what it shows; no relative link
//! of theirs points at nothing; and everything generated from the code — the guide's reference
//! (every subcommand's --help, every config's --example_config, `frontseat interfaces`), the man
//! pages, the shell completions and the Debian copies of the units — matches the committed copy.
//!
//! Regenerate the committed copies after changing a flag, a config field, a group or a unit:
//!
//! ```sh
//! FRONTSEAT_BLESS=1 cargo test --test docs
//! ```
//!
//! A ```console block: `$ command` lines run in order in one fresh temporary directory, by `sh`,
//! with this build's `frontseat` first on PATH; the lines under a command are its output (stdout
//! and stderr together). `...` alone on a line matches any number of lines, `[..]` any text
//! within a line; `? N` right under a command expects exit code N (default 0). Commands that
//! serve until stopped belong in ```sh blocks, which are not run. A ```toml block with
//! `<!-- check: interface -->` (or another service) on the line above must pass that service's
//! `--check`.

use std::collections::{BTreeMap, BTreeSet};
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_frontseat");
const ROOT: &str = env!("CARGO_MANIFEST_DIR");
/// No shown command may take longer (the demo at --warp 50 takes a few seconds).
const COMMAND_TIMEOUT: Duration = Duration::from_secs(240);

fn root() -> PathBuf {
    PathBuf::from(ROOT)
}

/// README.md and every page of the guide.
fn markdown_files() -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        for e in entries.flatten() {
            let p = e.path();
            if p.is_dir() {
                walk(&p, out);
            } else if p.extension().is_some_and(|x| x == "md") {
                out.push(p);
            }
        }
    }
    let mut files = vec![root().join("README.md")];
    walk(&root().join("docs/guide/src"), &mut files);
    files.sort();
    files
}

fn rel(p: &Path) -> String {
    p.strip_prefix(root()).unwrap_or(p).display().to_string()
}

fn blessing() -> bool {
    std::env::var_os("FRONTSEAT_BLESS").is_some_and(|v| v != "0" && !v.is_empty())
}

// ---------------------------------------------------------------------------------------------
// Shown commands

#[derive(Debug)]
struct Shown {
    line: usize,
    command: String,
    code: i32,
    expected: Vec<String>,
}

/// The ```console blocks of one file, each a list of commands with their shown output.
fn console_blocks(text: &str) -> Vec<Vec<Shown>> {
    let mut blocks = Vec::new();
    let mut lines = text.lines().enumerate().peekable();
    while let Some((_, l)) = lines.next() {
        if l.trim_start() != "```console" {
            continue;
        }
        let mut block: Vec<Shown> = Vec::new();
        while let Some((n, l)) = lines.next() {
            if l.trim_start().starts_with("```") {
                break;
            }
            if let Some(cmd) = l.strip_prefix("$ ") {
                let mut command = cmd.to_string();
                while command.ends_with('\\') {
                    command.pop();
                    match lines.next() {
                        Some((_, more)) => command.push_str(more),
                        None => break,
                    }
                }
                block.push(Shown {
                    line: n + 1,
                    command,
                    code: 0,
                    expected: Vec::new(),
                });
            } else if let Some(last) = block.last_mut() {
                match l.strip_prefix("? ") {
                    Some(code) if last.expected.is_empty() => {
                        last.code = code.trim().parse().expect("`? N` needs a number");
                    }
                    _ => last.expected.push(l.trim_end().to_string()),
                }
            }
        }
        blocks.push(block);
    }
    blocks
}

/// `expected` (with `...` lines and `[..]` spans) against `actual`: memoised over (pattern line,
/// output line), so several `...` over a long output stay linear in their product.
fn matches(expected: &[String], actual: &[&str]) -> bool {
    let (p, n) = (expected.len(), actual.len());
    // ok[i][j]: expected[i..] matches actual[j..].
    let mut ok = vec![vec![false; n + 1]; p + 1];
    ok[p][n] = true;
    for i in (0..p).rev() {
        for j in (0..=n).rev() {
            ok[i][j] = if expected[i] == "..." {
                ok[i + 1][j] || (j < n && ok[i][j + 1])
            } else {
                j < n && line_matches(&expected[i], actual[j].trim_end()) && ok[i + 1][j + 1]
            };
        }
    }
    ok[0][0]
}

fn line_matches(pattern: &str, line: &str) -> bool {
    let parts: Vec<&str> = pattern.split("[..]").collect();
    if parts.len() == 1 {
        return pattern == line;
    }
    let (first, last) = (parts[0], parts[parts.len() - 1]);
    if !line.starts_with(first) || line.len() < first.len() + last.len() || !line.ends_with(last) {
        return false;
    }
    let mut at = first.len();
    let end = line.len() - last.len();
    for mid in &parts[1..parts.len() - 1] {
        match line[at..end].find(mid) {
            Some(i) => at += i + mid.len(),
            None => return false,
        }
    }
    true
}

/// Runs `command` by sh in `dir`; returns exit code and the merged output.
fn run_shown(command: &str, dir: &Path) -> Result<(i32, String), String> {
    let bin_dir = Path::new(BIN).parent().unwrap();
    let path = format!(
        "{}:{}",
        bin_dir.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let mut child = Command::new("sh")
        .arg("-c")
        .arg(format!("exec 2>&1\n{command}"))
        .current_dir(dir)
        .env("PATH", path)
        .env("NO_COLOR", "1")
        .env_remove("RUST_LOG")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .spawn()
        .map_err(|e| format!("sh: {e}"))?;
    let mut out = child.stdout.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut s = Vec::new();
        let _ = out.read_to_end(&mut s);
        s
    });
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().map_err(|e| e.to_string())? {
            break s;
        }
        if start.elapsed() > COMMAND_TIMEOUT {
            let _ = child.kill();
            let _ = child.wait();
            return Err(format!("still running after {COMMAND_TIMEOUT:?}"));
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let output = String::from_utf8_lossy(&reader.join().unwrap()).into_owned();
    Ok((status.code().unwrap_or(-1), output))
}

#[test]
fn shown_commands_work_as_shown() {
    let mut failures = Vec::new();
    let mut ran = 0;
    for file in markdown_files() {
        let text = std::fs::read_to_string(&file).unwrap();
        for (i, block) in console_blocks(&text).into_iter().enumerate() {
            let dir = std::env::temp_dir().join(format!(
                "frontseat-docs-{}-{}-{i}",
                std::process::id(),
                rel(&file).replace('/', "_")
            ));
            let _ = std::fs::remove_dir_all(&dir);
            std::fs::create_dir_all(&dir).unwrap();
            for shown in block {
                ran += 1;
                let at = format!("{}:{}: $ {}", rel(&file), shown.line, shown.command);
                match run_shown(&shown.command, &dir) {
                    Err(e) => failures.push(format!("{at}\n  {e}")),
                    Ok((code, out)) => {
                        let actual: Vec<&str> = out.lines().collect();
                        if code != shown.code {
                            failures
                                .push(format!("{at}\n  exit {code}, shown {}\n{out}", shown.code));
                        } else if !matches(&shown.expected, &actual) {
                            failures.push(format!(
                                "{at}\n  output differs from the one shown:\n--- shown\n{}\n--- printed\n{out}",
                                shown.expected.join("\n")
                            ));
                        }
                    }
                }
            }
            let _ = std::fs::remove_dir_all(&dir);
        }
    }
    assert!(
        ran >= 5,
        "only {ran} shown commands found: the README lost its console blocks?"
    );
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

#[test]
fn the_matcher_can_fail() {
    let e = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    assert!(matches(&e(&["a", "...", "z"]), &["a", "b", "c", "z"]));
    assert!(matches(&e(&["a[..]c"]), &["abbbc"]));
    assert!(!matches(&e(&["a[..]c"]), &["abbbd"]));
    assert!(!matches(&e(&["a", "z"]), &["a", "b", "z"]));
    assert!(!matches(&e(&["a"]), &[]));
    assert!(matches(&e(&["..."]), &[]));
    let blocks =
        console_blocks("```console\n$ echo a \\\nb\n? 3\nx\n$ true\n```\n```sh\n$ no\n```\n");
    assert_eq!(blocks.len(), 1);
    assert_eq!(blocks[0][0].command, "echo a b");
    assert_eq!(blocks[0][0].code, 3);
    assert_eq!(blocks[0][0].expected, vec!["x"]);
    assert_eq!(blocks[0][1].command, "true");
}

/// ```toml blocks marked `<!-- check: SERVICE -->` on the line above: (line, service, text).
fn checked_toml_blocks(text: &str) -> Vec<(usize, String, String)> {
    let lines: Vec<&str> = text.lines().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < lines.len() {
        let service = lines[i]
            .trim()
            .strip_prefix("<!-- check: ")
            .and_then(|r| r.strip_suffix(" -->"));
        if let Some(service) = service
            && lines.get(i + 1).map(|l| l.trim()) == Some("```toml")
        {
            let body: Vec<&str> = lines[i + 2..]
                .iter()
                .take_while(|l| l.trim() != "```")
                .copied()
                .collect();
            out.push((i + 2, service.to_string(), body.join("\n") + "\n"));
            i += body.len() + 2;
        }
        i += 1;
    }
    out
}

#[test]
fn only_marked_toml_blocks_are_checked() {
    let t = "<!-- check: sim -->\n```toml\nport = 1\n```\n```toml\nx = 1\n```\n";
    let found = checked_toml_blocks(t);
    assert_eq!(found.len(), 1);
    assert_eq!(found[0].1, "sim");
    assert_eq!(found[0].2, "port = 1\n");
}

/// A config shown as a complete file loads: `frontseat SERVICE --check` passes on it.
#[test]
fn shown_configs_pass_check() {
    let mut failures = Vec::new();
    let mut checked = 0;
    let dir = std::env::temp_dir().join(format!("frontseat-docs-toml-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for file in markdown_files() {
        let text = std::fs::read_to_string(&file).unwrap();
        for (line, service, body) in checked_toml_blocks(&text) {
            checked += 1;
            let path = dir.join("shown.toml");
            std::fs::write(&path, &body).unwrap();
            let out = Command::new(BIN)
                .args([service.as_str(), "--check", "-c"])
                .arg(&path)
                .output()
                .unwrap();
            if !out.status.success() {
                failures.push(format!(
                    "{}:{line}: `frontseat {service} --check` refuses the config shown:\n{}",
                    rel(&file),
                    String::from_utf8_lossy(&out.stderr)
                ));
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    assert!(checked >= 5, "only {checked} checked configs found");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

// ---------------------------------------------------------------------------------------------
// Links

/// Targets of `[text](target)` and `[label]: target` outside code blocks and code spans.
fn link_targets(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    let mut in_code = false;
    for (n, line) in text.lines().enumerate() {
        if line.trim_start().starts_with("```") {
            in_code = !in_code;
            continue;
        }
        if in_code {
            continue;
        }
        // Code spans may show link syntax without being links.
        let mut plain = String::new();
        for (i, part) in line.split('`').enumerate() {
            if i % 2 == 0 {
                plain.push_str(part);
            }
        }
        let mut rest = plain.as_str();
        while let Some(i) = rest.find("](") {
            let after = &rest[i + 2..];
            let end = after.find(')').unwrap_or(after.len());
            let target = after[..end].split_whitespace().next().unwrap_or("");
            out.push((n + 1, target.to_string()));
            rest = &after[end..];
        }
        let t = plain.trim_start();
        if t.starts_with('[')
            && let Some(i) = t.find("]: ")
        {
            out.push((n + 1, t[i + 3..].trim().to_string()));
        }
    }
    out
}

#[test]
fn no_relative_link_points_at_nothing() {
    let mut broken = Vec::new();
    let mut checked = 0;
    for file in markdown_files() {
        let text = std::fs::read_to_string(&file).unwrap();
        for (line, target) in link_targets(&text) {
            if target.is_empty()
                || target.starts_with('#')
                || target.contains("://")
                || target.starts_with("mailto:")
            {
                continue;
            }
            let path = target.split('#').next().unwrap_or("");
            checked += 1;
            let resolved = file.parent().unwrap().join(path);
            if !resolved.exists() {
                broken.push(format!("{}:{line}: {target}", rel(&file)));
            }
        }
    }
    assert!(checked >= 20, "only {checked} relative links found");
    assert!(
        broken.is_empty(),
        "links to nothing:\n{}",
        broken.join("\n")
    );
}

#[test]
fn the_link_finder_sees_links_and_skips_code() {
    let t = "see [a](x.md#y) and `[b](no.md)`\n```\n[c](no2.md)\n```\n[d]: ref.md\n";
    let found: Vec<String> = link_targets(t).into_iter().map(|(_, t)| t).collect();
    assert_eq!(found, vec!["x.md#y", "ref.md"]);
}

// ---------------------------------------------------------------------------------------------
// Generated from the code

fn run_bin(args: &[&str]) -> String {
    let out = Command::new(BIN)
        .args(args)
        // The help's width, should clap ever wrap to the terminal: the same everywhere.
        .env("COLUMNS", "100")
        .env("NO_COLOR", "1")
        .env_remove("RUST_LOG")
        .stdin(Stdio::null())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "frontseat {}: {:?}\n{}",
        args.join(" "),
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// The subcommands a `--help` lists (clap's "Commands:" section), without `help`.
fn subcommands(help: &str) -> Vec<String> {
    help.lines()
        .skip_while(|l| l.trim_end() != "Commands:")
        .skip(1)
        .take_while(|l| !l.trim().is_empty())
        .filter(|l| l.starts_with("  ") && !l.starts_with("   "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|n| *n != "help")
        .map(str::to_string)
        .collect()
}

/// Every (sub)command path, depth first: [], [interface], [log], [log, info], ...
fn command_paths() -> Vec<(Vec<String>, String)> {
    fn walk(path: Vec<String>, out: &mut Vec<(Vec<String>, String)>) {
        let mut args: Vec<&str> = path.iter().map(String::as_str).collect();
        args.push("--help");
        let help = run_bin(&args);
        let subs = subcommands(&help);
        out.push((path.clone(), help));
        for s in subs {
            let mut p = path.clone();
            p.push(s);
            walk(p, out);
        }
    }
    let mut out = Vec::new();
    walk(Vec::new(), &mut out);
    out
}

const GENERATED_NOTE: &str = "<!-- Generated by tests/docs.rs from the binary; do not edit. \
Regenerate: FRONTSEAT_BLESS=1 cargo test --test docs -->";

/// Every generated file, by path relative to the repository root.
fn generated() -> BTreeMap<String, Vec<u8>> {
    let mut files = BTreeMap::new();
    let paths = command_paths();

    let mut cli = format!(
        "{GENERATED_NOTE}\n\n# Commands\n\nEvery subcommand's `--help`, as this build prints it.\n"
    );
    for (path, help) in &paths {
        let name = std::iter::once("frontseat".to_string())
            .chain(path.iter().cloned())
            .collect::<Vec<_>>()
            .join(" ");
        cli.push_str(&format!(
            "\n## {name}\n\n```text\n$ {name} --help\n{help}```\n"
        ));
    }
    files.insert(
        "docs/guide/src/reference/commands.md".into(),
        cli.into_bytes(),
    );

    // Every subcommand that takes a config prints its complete example.
    for (path, help) in &paths {
        if path.len() != 1 || !help.contains("--example_config") {
            continue;
        }
        let sub = &path[0];
        let example = run_bin(&[sub, "--example_config"]);
        let page = format!(
            "{GENERATED_NOTE}\n\n# {sub} config\n\n`frontseat {sub} --example_config` prints every field \
with its default, unit and description:\n\n```toml\n{example}```\n"
        );
        files.insert(
            format!("docs/guide/src/reference/config-{sub}.md"),
            page.into_bytes(),
        );
    }

    let interfaces = run_bin(&["interfaces"]);
    files.insert(
        "docs/guide/src/reference/interfaces.md".into(),
        format!(
            "{GENERATED_NOTE}\n\n# Interfaces\n\n`frontseat interfaces`: every application's groups \
(layer, direction, type, actor), compiled from `interface_yaml/`, then the supervision tree.\n\n```text\n{interfaces}```\n"
        )
        .into_bytes(),
    );

    // Man pages and completions, as the package ships them.
    let man_dir = std::env::temp_dir().join(format!("frontseat-man-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&man_dir);
    run_bin(&["man-pages", man_dir.to_str().unwrap()]);
    for e in std::fs::read_dir(&man_dir).unwrap().flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        files.insert(
            format!("deploy/debian/man/{name}"),
            std::fs::read(e.path()).unwrap(),
        );
    }
    let _ = std::fs::remove_dir_all(&man_dir);
    for (shell, file) in [
        ("bash", "frontseat.bash"),
        ("zsh", "_frontseat"),
        ("fish", "frontseat.fish"),
    ] {
        files.insert(
            format!("deploy/debian/completions/{file}"),
            run_bin(&["completions", shell]).into_bytes(),
        );
    }

    // /etc/frontseat/moos-gateway.toml of the package: the complete example (there is no smaller
    // working one: the gateway needs only a MOOSDB and the interface, both at their defaults).
    files.insert(
        "deploy/debian/etc/moos-gateway.toml".into(),
        run_bin(&["moos-gateway", "--example_config"]).into_bytes(),
    );

    // The units as the package installs them: the binary in /usr/bin, the docs in /usr/share.
    for e in std::fs::read_dir(root().join("deploy/systemd"))
        .unwrap()
        .flatten()
    {
        let name = e.file_name().to_string_lossy().into_owned();
        let text = std::fs::read_to_string(e.path())
            .unwrap()
            .replace("/usr/local/bin/", "/usr/bin/")
            .replace("/usr/local/share/", "/usr/share/");
        files.insert(format!("deploy/debian/systemd/{name}"), text.into_bytes());
    }
    files
}

/// The directories whose every file is generated (a file no longer generated is stale).
const GENERATED_DIRS: [&str; 5] = [
    "docs/guide/src/reference",
    "deploy/debian/etc",
    "deploy/debian/man",
    "deploy/debian/completions",
    "deploy/debian/systemd",
];

#[test]
fn generated_reference_matches_the_binary() {
    let want = generated();
    let mut present = BTreeSet::new();
    for d in GENERATED_DIRS {
        for e in std::fs::read_dir(root().join(d))
            .into_iter()
            .flatten()
            .flatten()
        {
            let name = e.file_name().to_string_lossy().into_owned();
            // The hand-written index of the reference is not generated.
            if d == "docs/guide/src/reference" && name == "README.md" {
                continue;
            }
            present.insert(format!("{d}/{name}"));
        }
    }
    if blessing() {
        for stale in present.iter().filter(|p| !want.contains_key(*p)) {
            std::fs::remove_file(root().join(stale)).unwrap();
        }
        for (path, bytes) in &want {
            let p = root().join(path);
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            if std::fs::read(&p).ok().as_ref() != Some(bytes) {
                std::fs::write(&p, bytes).unwrap();
                eprintln!("blessed {path}");
            }
        }
        return;
    }
    let mut differ = Vec::new();
    for (path, bytes) in &want {
        match std::fs::read(root().join(path)) {
            Ok(have) if &have == bytes => {}
            Ok(_) => differ.push(format!("{path}: differs from what the binary prints")),
            Err(_) => differ.push(format!("{path}: missing")),
        }
    }
    for stale in present.iter().filter(|p| !want.contains_key(*p)) {
        differ.push(format!("{stale}: no longer generated"));
    }
    assert!(
        differ.is_empty(),
        "the committed reference is not what this build generates:\n{}\n\
         Regenerate with: FRONTSEAT_BLESS=1 cargo test --test docs",
        differ.join("\n")
    );
    // Every generated page of the guide is in its table of contents.
    let summary = std::fs::read_to_string(root().join("docs/guide/src/SUMMARY.md")).unwrap();
    for path in want.keys() {
        if let Some(page) = path.strip_prefix("docs/guide/src/") {
            assert!(
                summary.contains(&format!("({page})")),
                "{page} is generated but not listed in docs/guide/src/SUMMARY.md"
            );
        }
    }
}

#[test]
fn version_names_the_commit_and_the_build() {
    let v = run_bin(&["--version"]);
    let mut lines = v.lines();
    assert_eq!(
        lines.next().unwrap(),
        format!("frontseat {}", env!("CARGO_PKG_VERSION"))
    );
    let commit = lines.next().unwrap();
    assert!(commit.starts_with("commit: "), "{v}");
    assert!(commit.len() > "commit: ".len(), "{v}");
    let build = lines.next().unwrap();
    assert!(build.starts_with("build: debug, 20"), "{v}");
    // -V stays the version alone (scripts parse it).
    assert_eq!(
        run_bin(&["-V"]).trim(),
        format!("frontseat {}", env!("CARGO_PKG_VERSION"))
    );
}
