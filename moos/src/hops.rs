//! A bench-only hook on this crate's data-path hops: `frontseat bench` run with
//! `FRONTSEAT_BENCH_HOPS=1` installs a function that stamps the instant each named hop is
//! passed, to show where a path's time goes (BENCHMARKS.md, "Helm-side paths: where the time
//! goes"). Nothing installs it otherwise, and then a hop costs one atomic load.

use std::sync::OnceLock;

/// Called with the hop's name and what passes it (a group, a MOOS key, a client's name).
pub type Hook = fn(&'static str, &str);

static HOOK: OnceLock<Hook> = OnceLock::new();

/// Installs `hook` for the life of the process; false when one already was.
pub fn install(hook: Hook) -> bool {
    HOOK.set(hook).is_ok()
}

#[inline]
pub(crate) fn hop(name: &'static str, what: &str) {
    if let Some(h) = HOOK.get() {
        h(name, what);
    }
}
