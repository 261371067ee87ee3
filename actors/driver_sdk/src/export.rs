//! The plugin side of the ABI: what [`crate::export_driver!`] expands to calls these. They turn
//! the C calls into [`FrontseatDriver`] calls (decoding the protobuf buffers, catching panics so
//! that none unwinds into C) and the [`Host`] back into the `fsd_host` callbacks.
//!
//! Every `unsafe` here rests on the contract of frontseat_driver.h: pointers and lengths come in
//! pairs that describe readable memory for the duration of the call, `driver` is what `load`
//! returned and not yet unloaded, and the `fsd_host` table stays valid and its callbacks are
//! callable from any thread until `unload` returns.
#![allow(unsafe_code)]

use std::ffi::{c_char, c_void};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::Arc;
use std::time::Duration;

use prost::Message;

use crate::abi::{self, FsdHost};
use crate::driver::{DriverFailure, Emit, FrontseatDriver, Host, LogLevel, SignalKind};
use crate::proto::goby::middleware::frontseat::protobuf::FrontSeatState;

/// The host's callback table, copied at load.
struct CHost {
    table: FsdHost,
}

// SAFETY: frontseat_driver.h requires the host's callbacks to be callable from any thread,
// concurrently, with the `ctx` it gave; the table itself is plain data copied at load.
unsafe impl Send for CHost {}
// SAFETY: as above; `&CHost` only reads the table.
unsafe impl Sync for CHost {}

impl Emit for CHost {
    fn signal(&self, kind: SignalKind, msg: &[u8]) {
        let f = match kind {
            SignalKind::CommandResponse => self.table.command_response,
            SignalKind::DataFromFrontseat => self.table.data_from_frontseat,
            SignalKind::RawFromFrontseat => self.table.raw_from_frontseat,
            SignalKind::RawToFrontseat => self.table.raw_to_frontseat,
        };
        if let Some(f) = f {
            // SAFETY: the header's contract (module comment); `msg` is valid for the call.
            unsafe { f(self.table.ctx, msg.as_ptr(), msg.len()) }
        }
    }
    fn state_changed(&self, state: FrontSeatState, providing_data: bool) {
        if let Some(f) = self.table.state_changed {
            // SAFETY: the header's contract (module comment).
            unsafe { f(self.table.ctx, state as i32, i32::from(providing_data)) }
        }
    }
    fn log(&self, level: LogLevel, msg: &str) {
        if let Some(f) = self.table.log {
            // SAFETY: the header's contract; `msg` is valid UTF-8 for the call.
            unsafe {
                f(
                    self.table.ctx,
                    level.to_abi(),
                    msg.as_ptr().cast(),
                    msg.len(),
                )
            }
        }
    }
}

/// What the opaque `fsd_driver*` points to.
pub struct Slot<D> {
    driver: D,
    host: Host,
}

/// # Safety
/// `(ptr, len)` describe readable memory for the lifetime of the returned slice, or ptr is null.
unsafe fn bytes<'a>(ptr: *const u8, len: usize) -> &'a [u8] {
    if ptr.is_null() || len == 0 {
        &[]
    } else {
        // SAFETY: the caller's contract.
        unsafe { std::slice::from_raw_parts(ptr, len) }
    }
}

/// Writes `msg` NUL-terminated and truncated into `(buf, cap)`.
///
/// # Safety
/// `(buf, cap)` is writable, or buf is null.
unsafe fn write_error(buf: *mut c_char, cap: usize, msg: &str) {
    if buf.is_null() || cap == 0 {
        return;
    }
    let mut n = msg.len().min(cap - 1);
    while !msg.is_char_boundary(n) {
        n -= 1;
    }
    // SAFETY: n + 1 <= cap bytes of `buf` are writable (caller's contract); the source is `msg`.
    unsafe {
        std::ptr::copy_nonoverlapping(msg.as_ptr(), buf.cast::<u8>(), n);
        *buf.add(n) = 0;
    }
}

fn panic_text(p: &(dyn std::any::Any + Send)) -> String {
    p.downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "non-string panic payload".into())
}

/// `frontseat_driver_load`.
///
/// # Safety
/// The frontseat_driver.h contract for `frontseat_driver_load`.
pub unsafe fn load<D: FrontseatDriver>(
    host: *const FsdHost,
    config: *const u8,
    config_len: usize,
    error: *mut c_char,
    error_cap: usize,
) -> *mut c_void {
    if host.is_null() {
        // SAFETY: the caller's contract for `error`.
        unsafe { write_error(error, error_cap, "no host table given") };
        return std::ptr::null_mut();
    }
    // SAFETY: `host` points to a valid fsd_host (caller's contract); the host checked our ABI
    // version, so its layout is ours.
    let table = unsafe { std::ptr::read(host) };
    if table.abi_version != abi::ABI_VERSION {
        let msg = format!(
            "host ABI version {} but the driver is built for {}",
            table.abi_version,
            abi::ABI_VERSION
        );
        // SAFETY: the caller's contract for `error`.
        unsafe { write_error(error, error_cap, &msg) };
        return std::ptr::null_mut();
    }
    let host = Host::new(Arc::new(CHost { table }));
    // SAFETY: the caller's contract for `config`.
    let cfg = unsafe { bytes(config, config_len) };
    let h = host.clone();
    match catch_unwind(AssertUnwindSafe(|| D::load(cfg, h))) {
        Ok(Ok(driver)) => Box::into_raw(Box::new(Slot { driver, host })).cast(),
        Ok(Err(reason)) => {
            // SAFETY: the caller's contract for `error`.
            unsafe { write_error(error, error_cap, &reason) };
            std::ptr::null_mut()
        }
        Err(p) => {
            let msg = format!("driver panicked while loading: {}", panic_text(&*p));
            // SAFETY: the caller's contract for `error`.
            unsafe { write_error(error, error_cap, &msg) };
            std::ptr::null_mut()
        }
    }
}

/// Runs `f` on the driver, mapping failures and panics onto the ABI's return codes.
fn guarded<D>(
    slot: &mut Slot<D>,
    what: &str,
    f: impl FnOnce(&mut D) -> Result<(), DriverFailure>,
) -> i32 {
    match catch_unwind(AssertUnwindSafe(|| f(&mut slot.driver))) {
        Ok(Ok(())) => abi::OK,
        Ok(Err(DriverFailure(reason))) => {
            slot.host.log(
                LogLevel::Error,
                &format!("driver failed in {what}: {reason}"),
            );
            abi::ERR_FATAL
        }
        Err(p) => {
            slot.host.log(
                LogLevel::Error,
                &format!("driver panicked in {what}: {}", panic_text(&*p)),
            );
            abi::ERR_FATAL
        }
    }
}

/// `frontseat_driver_send_*`: decodes an `M` and hands it to `f`.
///
/// # Safety
/// `driver` came from [`load`] with the same `D` and is not unloaded; `(msg, len)` is readable.
pub unsafe fn send<D: FrontseatDriver, M: Message + Default>(
    driver: *mut c_void,
    msg: *const u8,
    len: usize,
    what: &str,
    f: impl FnOnce(&mut D, M) -> Result<(), DriverFailure>,
) -> i32 {
    if driver.is_null() {
        return abi::ERR_FATAL;
    }
    // SAFETY: the caller's contract: a live Slot<D>, used by one thread at a time.
    let slot = unsafe { &mut *driver.cast::<Slot<D>>() };
    // SAFETY: the caller's contract for `(msg, len)`.
    let buf = unsafe { bytes(msg, len) };
    match M::decode(buf) {
        Ok(m) => guarded(slot, what, |d| f(d, m)),
        Err(e) => {
            slot.host
                .log(LogLevel::Warn, &format!("{what}: undecodable message: {e}"));
            abi::ERR_BAD_MESSAGE
        }
    }
}

/// `frontseat_driver_loop`.
///
/// # Safety
/// `driver` came from [`load`] with the same `D` and is not unloaded.
pub unsafe fn do_loop<D: FrontseatDriver>(driver: *mut c_void, now_us: u64) -> i32 {
    if driver.is_null() {
        return abi::ERR_FATAL;
    }
    // SAFETY: the caller's contract.
    let slot = unsafe { &mut *driver.cast::<Slot<D>>() };
    guarded(slot, "loop", |d| d.do_loop(Duration::from_micros(now_us)))
}

/// `frontseat_driver_frontseat_state`.
///
/// # Safety
/// `driver` came from [`load`] with the same `D` and is not unloaded.
pub unsafe fn frontseat_state<D: FrontseatDriver>(driver: *const c_void) -> i32 {
    if driver.is_null() {
        return FrontSeatState::FrontseatNotConnected as i32;
    }
    // SAFETY: the caller's contract.
    let slot = unsafe { &*driver.cast::<Slot<D>>() };
    catch_unwind(AssertUnwindSafe(|| slot.driver.frontseat_state() as i32))
        .unwrap_or(FrontSeatState::FrontseatNotConnected as i32)
}

/// `frontseat_driver_frontseat_providing_data`.
///
/// # Safety
/// `driver` came from [`load`] with the same `D` and is not unloaded.
pub unsafe fn providing_data<D: FrontseatDriver>(driver: *const c_void) -> i32 {
    if driver.is_null() {
        return 0;
    }
    // SAFETY: the caller's contract.
    let slot = unsafe { &*driver.cast::<Slot<D>>() };
    catch_unwind(AssertUnwindSafe(|| {
        i32::from(slot.driver.frontseat_providing_data())
    }))
    .unwrap_or(0)
}

/// `frontseat_driver_unload`.
///
/// # Safety
/// `driver` came from [`load`] with the same `D`; it is not used again.
pub unsafe fn unload<D: FrontseatDriver>(driver: *mut c_void) {
    if driver.is_null() {
        return;
    }
    // SAFETY: the caller's contract: ownership of the Box returns to us exactly once.
    let slot = unsafe { Box::from_raw(driver.cast::<Slot<D>>()) };
    // A panicking Drop must not unwind into C.
    let _ = catch_unwind(AssertUnwindSafe(move || drop(slot)));
}

/// Exports a [`FrontseatDriver`] as the nine functions of frontseat_driver.h. Use it once, in a
/// `crate-type = ["cdylib"]` crate: `frontseat_driver_sdk::export_driver!(MyDriver);`
#[macro_export]
macro_rules! export_driver {
    ($driver:ty) => {
        #[unsafe(no_mangle)]
        pub extern "C" fn frontseat_driver_abi_version() -> u32 {
            $crate::abi::ABI_VERSION
        }

        /// # Safety
        /// frontseat_driver.h.
        #[unsafe(no_mangle)]
        pub unsafe extern "C" fn frontseat_driver_load(
            host: *const $crate::abi::FsdHost,
            config: *const u8,
            config_len: usize,
            error: *mut ::std::ffi::c_char,
            error_cap: usize,
        ) -> *mut ::std::ffi::c_void {
            unsafe { $crate::export::load::<$driver>(host, config, config_len, error, error_cap) }
        }

        /// # Safety
        /// frontseat_driver.h.
        #[unsafe(no_mangle)]
        pub unsafe extern "C" fn frontseat_driver_send_command(
            driver: *mut ::std::ffi::c_void,
            msg: *const u8,
            len: usize,
        ) -> i32 {
            unsafe {
                $crate::export::send::<$driver, $crate::CommandRequest>(
                    driver,
                    msg,
                    len,
                    "send_command_to_frontseat",
                    |d, m| $crate::FrontseatDriver::send_command_to_frontseat(d, m),
                )
            }
        }

        /// # Safety
        /// frontseat_driver.h.
        #[unsafe(no_mangle)]
        pub unsafe extern "C" fn frontseat_driver_send_data(
            driver: *mut ::std::ffi::c_void,
            msg: *const u8,
            len: usize,
        ) -> i32 {
            unsafe {
                $crate::export::send::<$driver, $crate::InterfaceData>(
                    driver,
                    msg,
                    len,
                    "send_data_to_frontseat",
                    |d, m| $crate::FrontseatDriver::send_data_to_frontseat(d, m),
                )
            }
        }

        /// # Safety
        /// frontseat_driver.h.
        #[unsafe(no_mangle)]
        pub unsafe extern "C" fn frontseat_driver_send_raw(
            driver: *mut ::std::ffi::c_void,
            msg: *const u8,
            len: usize,
        ) -> i32 {
            unsafe {
                $crate::export::send::<$driver, $crate::Raw>(
                    driver,
                    msg,
                    len,
                    "send_raw_to_frontseat",
                    |d, m| $crate::FrontseatDriver::send_raw_to_frontseat(d, m),
                )
            }
        }

        /// # Safety
        /// frontseat_driver.h.
        #[unsafe(no_mangle)]
        pub unsafe extern "C" fn frontseat_driver_loop(
            driver: *mut ::std::ffi::c_void,
            now_us: u64,
        ) -> i32 {
            unsafe { $crate::export::do_loop::<$driver>(driver, now_us) }
        }

        /// # Safety
        /// frontseat_driver.h.
        #[unsafe(no_mangle)]
        pub unsafe extern "C" fn frontseat_driver_frontseat_state(
            driver: *const ::std::ffi::c_void,
        ) -> i32 {
            unsafe { $crate::export::frontseat_state::<$driver>(driver) }
        }

        /// # Safety
        /// frontseat_driver.h.
        #[unsafe(no_mangle)]
        pub unsafe extern "C" fn frontseat_driver_frontseat_providing_data(
            driver: *const ::std::ffi::c_void,
        ) -> i32 {
            unsafe { $crate::export::providing_data::<$driver>(driver) }
        }

        /// # Safety
        /// frontseat_driver.h.
        #[unsafe(no_mangle)]
        pub unsafe extern "C" fn frontseat_driver_unload(driver: *mut ::std::ffi::c_void) {
            unsafe { $crate::export::unload::<$driver>(driver) }
        }
    };
}
