//! Binding again on a port just let go: what every restartable part of the world (simulator, MOOS
//! broker, gobyd) needs to come back where its clients look for it.

use std::time::Duration;

/// Binds again on the same port; a few tries, since the old listener's socket may linger.
pub(crate) async fn rebind<T, E, F, Fut>(mut bind: F) -> Result<T, E>
where
    F: FnMut() -> Fut,
    Fut: std::future::Future<Output = Result<T, E>>,
{
    let mut tries = 0;
    loop {
        match bind().await {
            Ok(v) => return Ok(v),
            Err(e) if tries >= 40 => return Err(e),
            Err(_) => {
                tries += 1;
                tokio::time::sleep(Duration::from_millis(25)).await;
            }
        }
    }
}
