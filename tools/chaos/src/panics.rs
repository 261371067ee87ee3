//! Panic accounting for one run: a process-wide hook counts the panics the harness injected
//! (silently) apart from any other (passed on to the previous hook), and refuses a second run
//! in the same process.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

use crate::options::ChaosHarnessError;

/// The message of the panic the DriverActor raises on a chaos DriverPanic.
const INJECTED_PANIC: &str = "chaos: injected driver panic";

static RUNNING: AtomicBool = AtomicBool::new(false);
static INJECTED_PANICS_SEEN: AtomicU64 = AtomicU64::new(0);
static OTHER_PANICS: AtomicU64 = AtomicU64::new(0);
/// Injected panics of the translation and of simulated vehicles ("chaos: … panic injected").
static INJECTED_OTHER_SEEN: AtomicU64 = AtomicU64::new(0);
static OTHER_PANIC_TEXT: Mutex<Vec<String>> = Mutex::new(Vec::new());

type Hook = dyn Fn(&std::panic::PanicHookInfo<'_>) + Send + Sync + 'static;

/// Counts panics for the run and restores the previous hook when dropped. The injected driver
/// panics are counted silently (hundreds of backtraces would bury the report); any other panic
/// is counted and passed to the previous hook as usual.
pub(crate) struct PanicWatch {
    prev: Arc<Hook>,
}

impl PanicWatch {
    pub(crate) fn install() -> Result<Self, ChaosHarnessError> {
        if RUNNING.swap(true, Ordering::SeqCst) {
            return Err(ChaosHarnessError::AlreadyRunning);
        }
        INJECTED_PANICS_SEEN.store(0, Ordering::SeqCst);
        OTHER_PANICS.store(0, Ordering::SeqCst);
        INJECTED_OTHER_SEEN.store(0, Ordering::SeqCst);
        OTHER_PANIC_TEXT
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .clear();
        let prev: Arc<Hook> = Arc::from(std::panic::take_hook());
        let chained = prev.clone();
        std::panic::set_hook(Box::new(move |info| {
            let p = info.payload();
            let msg = p
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| p.downcast_ref::<String>().cloned())
                .unwrap_or_default();
            if msg == INJECTED_PANIC {
                INJECTED_PANICS_SEEN.fetch_add(1, Ordering::SeqCst);
            } else if msg.starts_with("chaos: ") && msg.ends_with("panic injected") {
                INJECTED_OTHER_SEEN.fetch_add(1, Ordering::SeqCst);
            } else {
                OTHER_PANICS.fetch_add(1, Ordering::SeqCst);
                let at = info
                    .location()
                    .map(|l| format!(" at {}:{}", l.file(), l.line()))
                    .unwrap_or_default();
                if let Ok(mut v) = OTHER_PANIC_TEXT.lock()
                    && v.len() < 10
                {
                    v.push(format!("{msg}{at}"));
                }
                chained(info);
            }
        }));
        Ok(Self { prev })
    }
}

impl Drop for PanicWatch {
    fn drop(&mut self) {
        let prev = self.prev.clone();
        let _ = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| prev(info)));
        RUNNING.store(false, Ordering::SeqCst);
    }
}

/// What the hook counted since the last `install`; still readable after the watch is dropped.
pub(crate) struct PanicCounts {
    /// Panics the harness did not inject.
    pub(crate) other: u64,
    /// Injected driver panics raised.
    pub(crate) injected_driver: u64,
    /// Injected translation and vehicle panics raised.
    pub(crate) injected_other: u64,
    /// The first few other panics, with where they happened.
    pub(crate) other_texts: Vec<String>,
}

pub(crate) fn counts() -> PanicCounts {
    PanicCounts {
        other: OTHER_PANICS.load(Ordering::SeqCst),
        injected_driver: INJECTED_PANICS_SEEN.load(Ordering::SeqCst),
        injected_other: INJECTED_OTHER_SEEN.load(Ordering::SeqCst),
        other_texts: OTHER_PANIC_TEXT
            .lock()
            .map(|v| v.clone())
            .unwrap_or_default(),
    }
}
