//! The C ABI of `include/frontseat_driver.h`, in Rust: the version, the return codes, the
//! `fsd_host` callback table and the exported symbol names. Keep the two files in step; a change
//! that is not binary compatible bumps [`ABI_VERSION`].
#![forbid(unsafe_code)]

use std::ffi::{c_char, c_void};

/// `FRONTSEAT_DRIVER_ABI_VERSION`.
pub const ABI_VERSION: u32 = 1;

/// `FSD_OK`.
pub const OK: i32 = 0;
/// `FSD_ERR_BAD_MESSAGE`: logged and counted; the driver goes on.
pub const ERR_BAD_MESSAGE: i32 = -1;
/// `FSD_ERR_FATAL`: a driver failure (FS_ERROR, restart with backoff).
pub const ERR_FATAL: i32 = -2;

/// `FSD_LOG_*`.
pub const LOG_ERROR: i32 = 1;
pub const LOG_WARN: i32 = 2;
pub const LOG_INFO: i32 = 3;
pub const LOG_DEBUG: i32 = 4;

/// Capacity of the buffer the host gives `frontseat_driver_load` for its rejection reason.
pub const ERROR_CAP: usize = 1024;

pub type BytesFn = unsafe extern "C" fn(ctx: *mut c_void, msg: *const u8, len: usize);
pub type StateFn =
    unsafe extern "C" fn(ctx: *mut c_void, frontseat_state: i32, providing_data: i32);
pub type LogFn = unsafe extern "C" fn(ctx: *mut c_void, level: i32, msg: *const c_char, len: usize);

/// `fsd_host`.
#[repr(C)]
pub struct FsdHost {
    pub abi_version: u32,
    pub struct_size: u32,
    pub ctx: *mut c_void,
    pub command_response: Option<BytesFn>,
    pub data_from_frontseat: Option<BytesFn>,
    pub raw_from_frontseat: Option<BytesFn>,
    pub raw_to_frontseat: Option<BytesFn>,
    pub state_changed: Option<StateFn>,
    pub log: Option<LogFn>,
}

/// The exported functions, by the names the host looks up.
pub mod symbols {
    pub const ABI_VERSION: &str = "frontseat_driver_abi_version";
    pub const LOAD: &str = "frontseat_driver_load";
    pub const SEND_COMMAND: &str = "frontseat_driver_send_command";
    pub const SEND_DATA: &str = "frontseat_driver_send_data";
    pub const SEND_RAW: &str = "frontseat_driver_send_raw";
    pub const LOOP: &str = "frontseat_driver_loop";
    pub const FRONTSEAT_STATE: &str = "frontseat_driver_frontseat_state";
    pub const PROVIDING_DATA: &str = "frontseat_driver_frontseat_providing_data";
    pub const UNLOAD: &str = "frontseat_driver_unload";
    pub const ALL: [&str; 9] = [
        ABI_VERSION,
        LOAD,
        SEND_COMMAND,
        SEND_DATA,
        SEND_RAW,
        LOOP,
        FRONTSEAT_STATE,
        PROVIDING_DATA,
        UNLOAD,
    ];
}

pub type AbiVersionFn = unsafe extern "C" fn() -> u32;
pub type LoadFn = unsafe extern "C" fn(
    host: *const FsdHost,
    config: *const u8,
    config_len: usize,
    error: *mut c_char,
    error_cap: usize,
) -> *mut c_void;
pub type OpFn = unsafe extern "C" fn(driver: *mut c_void, msg: *const u8, len: usize) -> i32;
pub type LoopFn = unsafe extern "C" fn(driver: *mut c_void, now_us: u64) -> i32;
pub type QueryFn = unsafe extern "C" fn(driver: *const c_void) -> i32;
pub type UnloadFn = unsafe extern "C" fn(driver: *mut c_void);
