//! `[record]` for any kind of process in a few lines: [`RecordService::spawn`] starts what the
//! section enables on a bus — the MCAP recorder, the Foxglove live server, the periodic drop
//! warning — and [`RecordService::stop`] ends them, closing the file with its summary.
//!
//! ```no_run
//! # async fn run(bus: &frontseat_actors::bus::Bus, cfg: &frontseat_config::RecordConfig) {
//! use frontseat_record::service::RecordService;
//! use frontseat_record::recorder::RecordMeta;
//! let meta = RecordMeta { vehicle: "auv1".into(), ..Default::default() };
//! let rec = RecordService::spawn(bus, cfg, "auv1", meta).expect("[record] starts");
//! // ... run the process ...
//! if let Some(r) = rec { r.stop().await; }
//! # }
//! ```

use std::net::SocketAddr;
use std::path::PathBuf;
use std::time::Duration;

use frontseat_actors::bus::Bus;
use frontseat_actors::groups::ALL;
use frontseat_config::RecordConfig;

use crate::foxglove::{FoxgloveError, FoxgloveOptions, FoxgloveServer, FoxgloveStats};
use crate::recorder::{RecordMeta, Recorder, RecorderError, RecorderOptions, RecorderStats};

/// How often a recorder that dropped messages says so.
const DROP_WARNING: Duration = Duration::from_secs(10);

#[derive(Debug, thiserror::Error)]
pub enum ServiceError {
    #[error(transparent)]
    Recorder(#[from] RecorderError),
    #[error(transparent)]
    Foxglove(#[from] FoxgloveError),
}

/// What `[record]` runs in a process.
#[derive(Debug)]
pub struct RecordService {
    recorder: Option<Recorder>,
    foxglove: Option<FoxgloveServer>,
}

impl RecordService {
    /// Starts the recorder (`record.enabled`) and the live server (`record.foxglove.enabled`)
    /// on `bus`; `Ok(None)` when neither is on. `name` names the files and the live server (the
    /// vehicle). Call inside a tokio runtime. A disk that cannot be written does not fail this
    /// (the recorder degrades and counts); a bad regex, an address in use or an open bind
    /// without a token does.
    pub fn spawn(
        bus: &Bus,
        cfg: &RecordConfig,
        name: &str,
        meta: RecordMeta,
    ) -> Result<Option<Self>, ServiceError> {
        Self::spawn_adjusted(bus, cfg, name, meta, |_| {})
    }

    /// [`RecordService::spawn`] with the recorder's options changed by `adjust` first (the
    /// demo's `--force`: [`RecorderOptions::replace`]).
    pub fn spawn_adjusted(
        bus: &Bus,
        cfg: &RecordConfig,
        name: &str,
        meta: RecordMeta,
        adjust: impl FnOnce(&mut RecorderOptions),
    ) -> Result<Option<Self>, ServiceError> {
        if !cfg.enabled && !cfg.foxglove.enabled {
            return Ok(None);
        }
        let mut opts = RecorderOptions::from_config(cfg, name)?;
        adjust(&mut opts);
        let foxglove = if cfg.foxglove.enabled {
            let fo = FoxgloveOptions::from_config(&cfg.foxglove);
            let shown = if name.is_empty() { "frontseat" } else { name };
            Some(FoxgloveServer::start(
                bus,
                ALL,
                |g| opts.wants(g),
                &fo,
                shown,
            )?)
        } else {
            None
        };
        let recorder = if cfg.enabled {
            let r = Recorder::start(bus, opts, meta)?;
            // Ends by itself once the recorder stops.
            drop(r.spawn_drop_watch(DROP_WARNING));
            Some(r)
        } else {
            None
        };
        Ok(Some(Self { recorder, foxglove }))
    }

    pub fn recorder(&self) -> Option<&Recorder> {
        self.recorder.as_ref()
    }

    /// The live server's address (its port when 0 was asked).
    pub fn foxglove_addr(&self) -> Option<SocketAddr> {
        self.foxglove.as_ref().map(FoxgloveServer::local_addr)
    }

    pub fn current_file(&self) -> Option<PathBuf> {
        self.recorder.as_ref().and_then(Recorder::current_file)
    }

    /// Stops the live server, then the recorder off the async threads (it joins its writer,
    /// which closes the file), and logs what each counted.
    pub async fn stop(self) -> (Option<RecorderStats>, Option<FoxgloveStats>) {
        let fox = self.foxglove.map(FoxgloveServer::stop);
        if let Some(s) = fox {
            tracing::info!(
                clients = s.clients,
                sent = s.sent,
                lagged = s.lagged,
                refused = s.refused,
                "foxglove live server stopped"
            );
        }
        let Some(rec) = self.recorder else {
            return (None, fox);
        };
        let file = rec.current_file();
        match tokio::task::spawn_blocking(move || rec.stop()).await {
            Ok(s) => {
                tracing::info!(
                    written = s.written,
                    dropped = s.dropped(),
                    files = s.files_opened,
                    removed = s.files_removed,
                    write_errors = s.write_errors,
                    last_file = %file.map(|f| f.display().to_string()).unwrap_or_default(),
                    "recorder stopped"
                );
                (Some(s), fox)
            }
            Err(e) => {
                tracing::error!(error = %e, "the recorder did not stop cleanly");
                (None, fox)
            }
        }
    }
}
