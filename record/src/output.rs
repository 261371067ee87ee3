//! Every file this crate writes for a user (`log export|plot|import`, `demo --record --force`):
//! created under a fresh temporary name in the target's own directory (`O_CREAT|O_EXCL`,
//! `O_NOFOLLOW`: a name planted there, a symlink included, is never opened, only stepped
//! around), written, synced, then renamed onto the target — without replacing an existing file
//! unless the user said `--force` (`renameat2(RENAME_NOREPLACE)`), and never when the target is
//! the input itself (same device and inode, whatever the path text says: `./in.mcap`, a hard
//! link, a symlink to it). An output that is dropped unfinished removes its temporary file.
//!
//! The recorder creates its files in place with the same `O_EXCL|O_NOFOLLOW` open
//! ([`create_new`]): a recording must be readable under its own name after a crash, so it has no
//! temporary name to rename from.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::os::unix::fs::{MetadataExt, OpenOptionsExt};
use std::path::{Path, PathBuf};

/// Temporary names tried beside one target before giving up (each taken one is stepped over).
const TEMP_TRIES: u32 = 64;

#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    #[error("{out}: this is the input file {input} (the same file on disk); write elsewhere")]
    SameFile { out: PathBuf, input: PathBuf },
    #[error("{0} exists (--force to replace it)")]
    Exists(PathBuf),
    #[error("cannot {what} {path}: {source}")]
    Io {
        what: &'static str,
        path: PathBuf,
        source: std::io::Error,
    },
}

impl OutputError {
    /// Whether the request itself was refused (exit 2) rather than failed.
    pub fn is_usage(&self) -> bool {
        matches!(self, Self::SameFile { .. } | Self::Exists(_))
    }
}

fn io_err(what: &'static str, path: &Path) -> impl FnOnce(std::io::Error) -> OutputError {
    let path = path.to_path_buf();
    move |source| OutputError::Io { what, path, source }
}

/// Opens `path` for writing only if nothing (not even a dangling symlink) has that name.
pub fn create_new(path: &Path) -> std::io::Result<File> {
    std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .custom_flags((rustix::fs::OFlags::NOFOLLOW | rustix::fs::OFlags::CLOEXEC).bits() as i32)
        .mode(0o644)
        .open(path)
}

/// A new file beside `target`, named `<target>.part` or, when that name is taken (a leftover,
/// something planted), `<target>.<pid>.<n>.part`: never an existing name, never through a symlink.
pub fn create_temp_beside(target: &Path) -> Result<(PathBuf, File), OutputError> {
    let name = target
        .file_name()
        .ok_or_else(|| OutputError::Io {
            what: "write",
            path: target.to_path_buf(),
            source: std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a file name"),
        })?
        .to_os_string();
    let pid = std::process::id();
    let mut last = None;
    for n in 0..TEMP_TRIES {
        let mut t = name.clone();
        match n {
            0 => t.push(".part"),
            n => t.push(format!(".{pid}.{n}.part")),
        }
        let temp = target.with_file_name(t);
        match create_new(&temp) {
            Ok(f) => return Ok((temp, f)),
            Err(e) if taken(&e) => last = Some(e),
            Err(e) => return Err(io_err("create", &temp)(e)),
        }
    }
    Err(io_err("create a temporary file beside", target)(
        last.unwrap_or_else(|| std::io::Error::other("no free temporary name")),
    ))
}

/// Whether [`create_new`] failed because the name is taken (a file, or a symlink that
/// `O_NOFOLLOW` refused to open).
pub fn taken(e: &std::io::Error) -> bool {
    e.kind() == std::io::ErrorKind::AlreadyExists
        || e.raw_os_error() == Some(rustix::io::Errno::LOOP.raw_os_error())
}

/// Refuses `out` when it is (or resolves to) one of `inputs`, compared by device and inode.
pub fn check_not_input(out: &Path, inputs: &[&Path]) -> Result<(), OutputError> {
    let ids = |m: std::fs::Metadata| (m.dev(), m.ino());
    let outs = [std::fs::symlink_metadata(out), std::fs::metadata(out)]
        .into_iter()
        .filter_map(Result::ok)
        .map(ids)
        .collect::<Vec<_>>();
    if outs.is_empty() {
        return Ok(());
    }
    for input in inputs {
        if let Ok(m) = std::fs::metadata(input)
            && outs.contains(&ids(m))
        {
            return Err(OutputError::SameFile {
                out: out.to_path_buf(),
                input: input.to_path_buf(),
            });
        }
    }
    Ok(())
}

/// A file being written under a temporary name; [`Output::commit`] puts it in place.
pub struct Output {
    target: PathBuf,
    temp: PathBuf,
    file: Option<BufWriter<File>>,
    force: bool,
    inputs: Vec<PathBuf>,
}

impl std::fmt::Debug for Output {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Output")
            .field("target", &self.target)
            .field("temp", &self.temp)
            .finish_non_exhaustive()
    }
}

impl Output {
    /// Starts writing `target`: refused when it is one of `inputs`, or exists and not `force`.
    pub fn create(target: &Path, force: bool, inputs: &[&Path]) -> Result<Self, OutputError> {
        check_not_input(target, inputs)?;
        if !force && std::fs::symlink_metadata(target).is_ok() {
            return Err(OutputError::Exists(target.to_path_buf()));
        }
        let (temp, f) = create_temp_beside(target)?;
        Ok(Self {
            target: target.to_path_buf(),
            temp,
            file: Some(BufWriter::with_capacity(256 * 1024, f)),
            force,
            inputs: inputs.iter().map(|p| p.to_path_buf()).collect(),
        })
    }

    /// The temporary file's path (while writing).
    pub fn temp_path(&self) -> &Path {
        &self.temp
    }

    /// Writes, syncs and renames the file onto its target; the target's path.
    pub fn commit(mut self) -> Result<PathBuf, OutputError> {
        let Some(mut w) = self.file.take() else {
            return Err(io_err("write", &self.target)(std::io::Error::other(
                "already committed",
            )));
        };
        w.flush().map_err(io_err("write", &self.temp))?;
        let f = w
            .into_inner()
            .map_err(|e| io_err("write", &self.temp)(e.into_error()))?;
        f.sync_all().map_err(io_err("sync", &self.temp))?;
        drop(f);
        // The input may have been linked to the target while we wrote.
        let inputs: Vec<&Path> = self.inputs.iter().map(PathBuf::as_path).collect();
        check_not_input(&self.target, &inputs)?;
        place(&self.temp, &self.target, self.force)?;
        // Renamed: nothing left to remove on drop.
        self.temp = PathBuf::new();
        Ok(self.target.clone())
    }
}

/// Renames `temp` onto `target`; without `force`, never over an existing name.
pub fn place(temp: &Path, target: &Path, force: bool) -> Result<(), OutputError> {
    if force {
        return std::fs::rename(temp, target).map_err(io_err("rename onto", target));
    }
    let cwd = rustix::fs::CWD;
    match rustix::fs::renameat_with(cwd, temp, cwd, target, rustix::fs::RenameFlags::NOREPLACE) {
        Ok(()) => Ok(()),
        Err(rustix::io::Errno::EXIST) => Err(OutputError::Exists(target.to_path_buf())),
        // A file system without RENAME_NOREPLACE: a hard link never replaces either.
        Err(rustix::io::Errno::INVAL | rustix::io::Errno::NOSYS) => {
            match std::fs::hard_link(temp, target) {
                Ok(()) => {
                    let _ = std::fs::remove_file(temp);
                    Ok(())
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                    Err(OutputError::Exists(target.to_path_buf()))
                }
                Err(e) => Err(io_err("rename onto", target)(e)),
            }
        }
        Err(e) => Err(io_err("rename onto", target)(e.into())),
    }
}

impl Write for Output {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        match &mut self.file {
            Some(f) => f.write(buf),
            None => Err(std::io::Error::other("already committed")),
        }
    }
    fn flush(&mut self) -> std::io::Result<()> {
        match &mut self.file {
            Some(f) => f.flush(),
            None => Ok(()),
        }
    }
}

impl std::io::Seek for Output {
    fn seek(&mut self, pos: std::io::SeekFrom) -> std::io::Result<u64> {
        match &mut self.file {
            Some(f) => f.seek(pos),
            None => Err(std::io::Error::other("already committed")),
        }
    }
}

impl Drop for Output {
    fn drop(&mut self) {
        self.file = None;
        if !self.temp.as_os_str().is_empty() {
            let _ = std::fs::remove_file(&self.temp);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_output_never_replaces_without_force_and_never_follows_a_planted_part() {
        let d = tempfile::tempdir().unwrap();
        let target = d.path().join("out.csv");
        let victim = d.path().join("victim");
        std::fs::write(&victim, b"precious").unwrap();
        std::os::unix::fs::symlink(&victim, d.path().join("out.csv.part")).unwrap();
        let mut o = Output::create(&target, false, &[]).unwrap();
        assert_ne!(o.temp_path(), d.path().join("out.csv.part"));
        o.write_all(b"new").unwrap();
        assert_eq!(o.commit().unwrap(), target);
        assert_eq!(std::fs::read(&target).unwrap(), b"new");
        assert_eq!(std::fs::read(&victim).unwrap(), b"precious");
        // Exists: refused without force, replaced with it.
        assert!(matches!(
            Output::create(&target, false, &[]),
            Err(OutputError::Exists(_))
        ));
        let mut o = Output::create(&target, true, &[]).unwrap();
        o.write_all(b"newer").unwrap();
        o.commit().unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"newer");
        // Dropped unfinished: no temporary file left.
        let o = Output::create(&d.path().join("gone"), false, &[]).unwrap();
        let t = o.temp_path().to_path_buf();
        drop(o);
        assert!(!t.exists() && !d.path().join("gone").exists());
    }

    #[test]
    fn the_input_is_refused_by_inode_not_by_path_text() {
        let d = tempfile::tempdir().unwrap();
        let input = d.path().join("in.mcap");
        std::fs::write(&input, b"recording").unwrap();
        let link = d.path().join("hard");
        std::fs::hard_link(&input, &link).unwrap();
        let dotted = d.path().join(".").join("in.mcap");
        for out in [&input, &link, &dotted] {
            let e = Output::create(out, true, &[&input]).unwrap_err();
            assert!(matches!(e, OutputError::SameFile { .. }), "{out:?}: {e}");
            assert!(e.is_usage());
        }
        assert_eq!(std::fs::read(&input).unwrap(), b"recording");
    }
}
