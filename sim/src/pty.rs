//! Pseudo-terminals for the vehicle emulators and the serial tests: the emulator holds the
//! master side and a driver opens the slave path exactly as it would open `/dev/ttyUSB0`.
//!
//! The master is non-blocking and driven by tokio's reactor. When no process has the slave open
//! (before the driver opens it, or after it closed it) Linux reports `EIO` on the master; that
//! is "nobody listening", not an error, so [`PtyMaster::read`] waits and tries again.

use std::io;
use std::os::fd::OwnedFd;
use std::path::PathBuf;
use std::time::Duration;

use rustix::fs::OFlags;
use rustix::pty::OpenptFlags;
use tokio::io::unix::AsyncFd;

/// How often a master without a slave peer is polled again.
const NO_PEER_RETRY: Duration = Duration::from_millis(20);

/// The master side of a fresh pseudo-terminal; the slave is in raw mode, so bytes pass
/// unchanged (no echo, no CR/LF translation) whatever the opener configures later.
pub struct PtyMaster {
    fd: AsyncFd<OwnedFd>,
    slave: PathBuf,
}

impl PtyMaster {
    /// Opens a new pseudo-terminal pair; needs a tokio runtime.
    pub fn open() -> io::Result<Self> {
        // CLOEXEC: a child process this one spawns (a test's `frontseat interface`) must not
        // inherit the master, or closing it here would not make the device vanish.
        let fd =
            rustix::pty::openpt(OpenptFlags::RDWR | OpenptFlags::NOCTTY | OpenptFlags::CLOEXEC)?;
        rustix::pty::grantpt(&fd)?;
        rustix::pty::unlockpt(&fd)?;
        let name = rustix::pty::ptsname(&fd, Vec::new())?;
        let slave = PathBuf::from(name.to_string_lossy().into_owned());
        // On Linux the master's termios is the slave's line discipline.
        let mut t = rustix::termios::tcgetattr(&fd)?;
        t.make_raw();
        rustix::termios::tcsetattr(&fd, rustix::termios::OptionalActions::Now, &t)?;
        let flags = rustix::fs::fcntl_getfl(&fd)?;
        rustix::fs::fcntl_setfl(&fd, flags | OFlags::NONBLOCK)?;
        // SAFETY: `register` needs the fd to stay open and unclosed by anyone else while
        // registered. `fd` is an OwnedFd we just created and move into the AsyncFd, which owns
        // it until it is dropped (it deregisters before closing); no copy of it exists.
        #[allow(unsafe_code)]
        let fd = unsafe { AsyncFd::register(fd) }?;
        Ok(Self { fd, slave })
    }

    /// The device path a driver opens (`/dev/pts/N`).
    pub fn slave_path(&self) -> &std::path::Path {
        &self.slave
    }

    /// Reads what the slave side wrote; waits while nobody has the slave open.
    pub async fn read(&self, buf: &mut [u8]) -> io::Result<usize> {
        loop {
            let mut guard = self.fd.readable().await?;
            match guard.try_io(|fd| rustix::io::read(fd, &mut *buf).map_err(io::Error::from)) {
                Ok(Ok(n)) if n > 0 => return Ok(n),
                Ok(Ok(_)) => {
                    guard.clear_ready();
                    tokio::time::sleep(NO_PEER_RETRY).await;
                }
                Ok(Err(e)) if e.raw_os_error() == Some(rustix::io::Errno::IO.raw_os_error()) => {
                    guard.clear_ready();
                    tokio::time::sleep(NO_PEER_RETRY).await;
                }
                Ok(Err(e)) => return Err(e),
                Err(_would_block) => {}
            }
        }
    }

    /// Writes all of `data`. Without a slave peer Linux still buffers (up to the tty's limit);
    /// a full buffer waits, bounded by `within`, and what cannot be written is dropped, as
    /// bytes on a serial cable with nobody listening are.
    pub async fn write_all(&self, mut data: &[u8], within: Duration) -> io::Result<()> {
        let deadline = tokio::time::Instant::now() + within;
        while !data.is_empty() {
            let ready = tokio::time::timeout_at(deadline, self.fd.writable()).await;
            let Ok(guard) = ready else {
                return Ok(());
            };
            let mut guard = guard?;
            match guard.try_io(|fd| rustix::io::write(fd, data).map_err(io::Error::from)) {
                Ok(Ok(n)) => data = &data[n..],
                Ok(Err(e)) if e.raw_os_error() == Some(rustix::io::Errno::IO.raw_os_error()) => {
                    return Ok(());
                }
                Ok(Err(e)) => return Err(e),
                Err(_would_block) => {}
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test]
    async fn bytes_cross_a_real_pty_unchanged() {
        let m = PtyMaster::open().unwrap();
        let path = m.slave_path().to_path_buf();
        let slave = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .open(&path)
            .unwrap();
        let data = b"$OSD,G,C,S,P,,,,*5F\r\n\x7e\x7d\x00\xff";
        m.write_all(data, Duration::from_secs(1)).await.unwrap();
        let got = tokio::task::spawn_blocking(move || {
            use std::io::Read;
            let mut s = slave;
            let mut buf = vec![0u8; data.len()];
            s.read_exact(&mut buf).map(|_| (buf, s))
        })
        .await
        .unwrap()
        .unwrap();
        assert_eq!(got.0, data);
        let mut slave = got.1;
        std::io::Write::write_all(&mut slave, b"back\n").unwrap();
        let mut buf = [0u8; 16];
        let n = tokio::time::timeout(Duration::from_secs(5), m.read(&mut buf))
            .await
            .unwrap()
            .unwrap();
        assert_eq!(&buf[..n], b"back\n");
    }
}
