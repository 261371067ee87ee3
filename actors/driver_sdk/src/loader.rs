//! The host side of the ABI: opens a driver library with `libloading`, checks its ABI version
//! before anything else, looks up every symbol, and wraps a loaded driver in a safe
//! [`Instance`] whose callbacks arrive as [`Signal`]s.
//!
//! Loading a library runs its code in this process. The interface does that only inside the
//! `frontseat driver-host` child (or in-process when told the driver is trusted), so a crashing
//! driver takes down at most that child. Every `unsafe` below rests on the library honouring
//! frontseat_driver.h, which its ABI version symbol claims.
#![allow(unsafe_code)]

use std::ffi::{c_char, c_void};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};
use std::ptr::NonNull;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use crate::abi::{self, FsdHost, symbols};
use crate::driver::{LogLevel, SignalKind};
use crate::error::Error;

/// What a loaded driver emitted, from whichever thread it chose.
#[derive(Debug, Clone, PartialEq)]
pub enum Signal {
    Bytes(SignalKind, Vec<u8>),
    State { state: i32, providing_data: bool },
    Log { level: LogLevel, message: String },
}

pub type SignalSink = Arc<dyn Fn(Signal) + Send + Sync>;

#[derive(Clone, Copy)]
struct Fns {
    load: abi::LoadFn,
    send_command: abi::OpFn,
    send_data: abi::OpFn,
    send_raw: abi::OpFn,
    do_loop: abi::LoopFn,
    state: abi::QueryFn,
    providing: abi::QueryFn,
    unload: abi::UnloadFn,
}

/// An opened driver library whose ABI version matched.
pub struct Plugin {
    path: PathBuf,
    lib: Arc<libloading::Library>,
    fns: Fns,
}

fn symbol<T: Copy>(lib: &libloading::Library, path: &Path, name: &str) -> Result<T, Error> {
    // SAFETY: `T` is the function type frontseat_driver.h declares for `name`; the copied
    // pointer is used only while `lib` is alive (Plugin and Instance hold it).
    unsafe { lib.get::<T>(name.as_bytes()) }
        .map(|s| *s)
        .map_err(|_| Error::SymbolMissing {
            path: path.to_path_buf(),
            symbol: name.to_string(),
        })
}

impl Plugin {
    /// Opens `path`: file missing, not loadable, symbol missing and ABI mismatch are told apart.
    pub fn open(path: &Path) -> Result<Plugin, Error> {
        if !path.exists() {
            return Err(Error::LibraryMissing {
                path: path.to_path_buf(),
            });
        }
        // SAFETY: this runs the library's initialisers; see the module comment for why that is
        // acceptable here.
        let lib =
            unsafe { libloading::Library::new(path) }.map_err(|e| Error::LibraryNotLoadable {
                path: path.to_path_buf(),
                reason: e.to_string(),
            })?;
        let version: abi::AbiVersionFn = symbol(&lib, path, symbols::ABI_VERSION)?;
        // SAFETY: frontseat_driver_abi_version takes nothing and returns a u32 in every version.
        let found = unsafe { version() };
        if found != abi::ABI_VERSION {
            return Err(Error::AbiMismatch {
                path: path.to_path_buf(),
                found,
                expected: abi::ABI_VERSION,
            });
        }
        let fns = Fns {
            load: symbol(&lib, path, symbols::LOAD)?,
            send_command: symbol(&lib, path, symbols::SEND_COMMAND)?,
            send_data: symbol(&lib, path, symbols::SEND_DATA)?,
            send_raw: symbol(&lib, path, symbols::SEND_RAW)?,
            do_loop: symbol(&lib, path, symbols::LOOP)?,
            state: symbol(&lib, path, symbols::FRONTSEAT_STATE)?,
            providing: symbol(&lib, path, symbols::PROVIDING_DATA)?,
            unload: symbol(&lib, path, symbols::UNLOAD)?,
        };
        Ok(Plugin {
            path: path.to_path_buf(),
            lib: Arc::new(lib),
            fns,
        })
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// `frontseat_driver_load`: a running driver, or the reason it rejected `config`.
    pub fn load(&self, config: &[u8], sink: SignalSink) -> Result<Instance, Error> {
        // Leaked on purpose: a driver that (wrongly) calls back after unload must find live
        // memory; `live` turns such calls into no-ops. A few dozen bytes per load.
        let ctx: &'static mut HostCtx = Box::leak(Box::new(HostCtx {
            sink,
            live: AtomicBool::new(true),
            table: FsdHost {
                abi_version: abi::ABI_VERSION,
                struct_size: std::mem::size_of::<FsdHost>() as u32,
                ctx: std::ptr::null_mut(),
                command_response: Some(cb_command_response),
                data_from_frontseat: Some(cb_data_from_frontseat),
                raw_from_frontseat: Some(cb_raw_from_frontseat),
                raw_to_frontseat: Some(cb_raw_to_frontseat),
                state_changed: Some(cb_state_changed),
                log: Some(cb_log),
            },
        }));
        ctx.table.ctx = (ctx as *mut HostCtx).cast();
        let ctx: &'static HostCtx = ctx;
        let mut err = vec![0u8; abi::ERROR_CAP];
        // SAFETY: the table and its ctx live forever; config and err are valid for the call,
        // err with ERROR_CAP writable bytes.
        let driver = unsafe {
            (self.fns.load)(
                &ctx.table,
                config.as_ptr(),
                config.len(),
                err.as_mut_ptr().cast::<c_char>(),
                err.len(),
            )
        };
        match NonNull::new(driver) {
            Some(driver) => Ok(Instance {
                _lib: self.lib.clone(),
                fns: self.fns,
                driver,
                ctx,
            }),
            None => {
                ctx.live.store(false, Ordering::SeqCst);
                let end = err.iter().position(|&b| b == 0).unwrap_or(err.len());
                let reason = String::from_utf8_lossy(&err[..end]).into_owned();
                Err(Error::ConfigRejected {
                    reason: if reason.is_empty() {
                        "(no reason given)".into()
                    } else {
                        reason
                    },
                })
            }
        }
    }
}

/// A loaded driver. Its calls go to the library one at a time (`&mut self`); dropping it
/// unloads the driver.
pub struct Instance {
    _lib: Arc<libloading::Library>,
    fns: Fns,
    driver: NonNull<c_void>,
    ctx: &'static HostCtx,
}

// SAFETY: frontseat_driver.h lets the host call the driver from any thread as long as calls
// never overlap; `&mut self` on every call guarantees that.
unsafe impl Send for Instance {}

impl Instance {
    fn op(&mut self, f: abi::OpFn, msg: &[u8]) -> i32 {
        // SAFETY: `driver` is live until Drop; `msg` is valid for the call.
        unsafe { f(self.driver.as_ptr(), msg.as_ptr(), msg.len()) }
    }
    /// An encoded CommandRequest → `FSD_*` code.
    pub fn send_command(&mut self, msg: &[u8]) -> i32 {
        self.op(self.fns.send_command, msg)
    }
    pub fn send_data(&mut self, msg: &[u8]) -> i32 {
        self.op(self.fns.send_data, msg)
    }
    pub fn send_raw(&mut self, msg: &[u8]) -> i32 {
        self.op(self.fns.send_raw, msg)
    }
    pub fn do_loop(&mut self, now_us: u64) -> i32 {
        // SAFETY: `driver` is live until Drop.
        unsafe { (self.fns.do_loop)(self.driver.as_ptr(), now_us) }
    }
    /// The raw FrontSeatState number (unknown numbers are the caller's to judge).
    pub fn frontseat_state(&mut self) -> i32 {
        // SAFETY: `driver` is live until Drop.
        unsafe { (self.fns.state)(self.driver.as_ptr()) }
    }
    pub fn frontseat_providing_data(&mut self) -> bool {
        // SAFETY: `driver` is live until Drop.
        unsafe { (self.fns.providing)(self.driver.as_ptr()) != 0 }
    }
}

impl Drop for Instance {
    fn drop(&mut self) {
        // SAFETY: `driver` came from load and is unloaded exactly once, here.
        unsafe { (self.fns.unload)(self.driver.as_ptr()) };
        self.ctx.live.store(false, Ordering::SeqCst);
    }
}

struct HostCtx {
    sink: SignalSink,
    live: AtomicBool,
    table: FsdHost,
}

/// # Safety
/// `ctx` is the pointer we put in the table: a leaked, never-freed HostCtx.
unsafe fn host_ctx<'a>(ctx: *mut c_void) -> Option<&'a HostCtx> {
    // SAFETY: the caller's contract; null is tolerated.
    let c = unsafe { ctx.cast::<HostCtx>().as_ref() }?;
    c.live.load(Ordering::SeqCst).then_some(c)
}

fn deliver(c: &HostCtx, s: Signal) {
    // A panic must not unwind into the driver's C frames.
    let _ = catch_unwind(AssertUnwindSafe(|| (c.sink)(s)));
}

/// # Safety
/// As [`host_ctx`]; `(msg, len)` readable for the call.
unsafe fn emit_bytes(ctx: *mut c_void, kind: SignalKind, msg: *const u8, len: usize) {
    // SAFETY: the caller's contract.
    let Some(c) = (unsafe { host_ctx(ctx) }) else {
        return;
    };
    if len > crate::frame::MAX_FRAME - 64 {
        deliver(
            c,
            Signal::Log {
                level: LogLevel::Warn,
                message: format!("{kind:?} of {len} bytes is too large; dropped"),
            },
        );
        return;
    }
    let bytes = if msg.is_null() || len == 0 {
        Vec::new()
    } else {
        // SAFETY: the caller's contract.
        unsafe { std::slice::from_raw_parts(msg, len) }.to_vec()
    };
    deliver(c, Signal::Bytes(kind, bytes));
}

unsafe extern "C" fn cb_command_response(ctx: *mut c_void, msg: *const u8, len: usize) {
    // SAFETY: called by the driver per frontseat_driver.h.
    unsafe { emit_bytes(ctx, SignalKind::CommandResponse, msg, len) }
}
unsafe extern "C" fn cb_data_from_frontseat(ctx: *mut c_void, msg: *const u8, len: usize) {
    // SAFETY: called by the driver per frontseat_driver.h.
    unsafe { emit_bytes(ctx, SignalKind::DataFromFrontseat, msg, len) }
}
unsafe extern "C" fn cb_raw_from_frontseat(ctx: *mut c_void, msg: *const u8, len: usize) {
    // SAFETY: called by the driver per frontseat_driver.h.
    unsafe { emit_bytes(ctx, SignalKind::RawFromFrontseat, msg, len) }
}
unsafe extern "C" fn cb_raw_to_frontseat(ctx: *mut c_void, msg: *const u8, len: usize) {
    // SAFETY: called by the driver per frontseat_driver.h.
    unsafe { emit_bytes(ctx, SignalKind::RawToFrontseat, msg, len) }
}
unsafe extern "C" fn cb_state_changed(ctx: *mut c_void, state: i32, providing: i32) {
    // SAFETY: called by the driver per frontseat_driver.h.
    if let Some(c) = unsafe { host_ctx(ctx) } {
        deliver(
            c,
            Signal::State {
                state,
                providing_data: providing != 0,
            },
        );
    }
}
unsafe extern "C" fn cb_log(ctx: *mut c_void, level: i32, msg: *const c_char, len: usize) {
    // SAFETY: called by the driver per frontseat_driver.h.
    let Some(c) = (unsafe { host_ctx(ctx) }) else {
        return;
    };
    let len = len.min(64 * 1024);
    let text = if msg.is_null() {
        String::new()
    } else {
        // SAFETY: (msg, len) readable for the call, per the header.
        String::from_utf8_lossy(unsafe { std::slice::from_raw_parts(msg.cast::<u8>(), len) })
            .into_owned()
    };
    deliver(
        c,
        Signal::Log {
            level: LogLevel::from_abi(level),
            message: text,
        },
    );
}
