//! Shell completions and man pages, generated from the same clap definitions that parse the
//! command line (clap_complete, clap_mangen), so neither can disagree with the binary. The Debian
//! package ships the committed copies under deploy/debian/; tests/docs.rs regenerates them and
//! fails when they differ.

use std::io::Write;
use std::path::{Path, PathBuf};

/// The command tree `cli` as the pages show it: built (so subcommands inherit the version), with
/// the version alone, since a page that names a commit would change with every commit.
fn command(cli: clap::Command) -> clap::Command {
    let mut cmd = cli.long_version(None::<&str>);
    cmd.build();
    cmd
}

/// Writes the completion script of `shell` for `frontseat`.
pub fn completions(cli: clap::Command, shell: clap_complete::Shell, out: &mut dyn Write) {
    let mut cmd = command(cli);
    clap_complete::generate(shell, &mut cmd, "frontseat", out);
}

/// Writes `frontseat.1` and `frontseat-<sub>[-<sub>].1` for every visible subcommand into `dir`;
/// returns the files written, in order.
pub fn man_pages(cli: clap::Command, dir: &Path) -> std::io::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir)?;
    let mut written = Vec::new();
    page(&command(cli), "frontseat", dir, &mut written)?;
    Ok(written)
}

fn page(
    cmd: &clap::Command,
    name: &str,
    dir: &Path,
    written: &mut Vec<PathBuf>,
) -> std::io::Result<()> {
    // The page's title and NAME section are its own name (frontseat-log-info), as git's are; the
    // synopsis keeps the words typed (`frontseat log info`), which build() set as the bin name.
    let named = cmd.clone().name(name.to_string());
    let mut buf = Vec::new();
    clap_mangen::Man::new(named).render(&mut buf)?;
    let path = dir.join(format!("{name}.1"));
    std::fs::write(&path, buf)?;
    written.push(path);
    for sub in cmd.get_subcommands() {
        if sub.is_hide_set() || sub.get_name() == "help" {
            continue;
        }
        page(sub, &format!("{name}-{}", sub.get_name()), dir, written)?;
    }
    Ok(())
}
