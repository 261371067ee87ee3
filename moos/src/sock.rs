//! Writing to a TCP write half that a writer task shares with direct writes from other threads
//! (the client's posts, the MOOSDB's routed packets: issue 49). Only `try_write` works through a
//! shared reference, so the writer task's `write_all` is spelled out here once.

use tokio::net::tcp::OwnedWriteHalf;

/// `write_all` on a write half shared with direct (`try_write`) writers.
pub(crate) async fn write_shared(wr: &OwnedWriteHalf, mut buf: &[u8]) -> std::io::Result<()> {
    while !buf.is_empty() {
        match wr.try_write(buf) {
            Ok(0) => return Err(std::io::ErrorKind::WriteZero.into()),
            Ok(n) => buf = &buf[n..],
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => wr.writable().await?,
            Err(e) => return Err(e),
        }
    }
    Ok(())
}
