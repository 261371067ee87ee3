//! The driver contract: Goby3's `InterfaceBase` as a Rust trait.
//!
//! Five operations (send command / data / raw, frontseat state, providing data), a `do_loop` at
//! 10 Hz of simulated time, and the four signals, emitted through a `SignalSink` at the moment
//! the driver has them. I/O happens in tasks the driver spawns in `start`; what they read comes
//! back as `DriverIoEvent`s handled on the driver actor, one at a time, so a driver is plain
//! single-threaded state.

use std::time::Duration;

use crate::proto::goby::middleware::frontseat::protobuf::{
    CommandRequest, CommandResponse, FrontSeatState, InterfaceData, Raw,
};

/// Goby3's four driver signals.
pub trait SignalSink {
    fn command_response(&mut self, response: CommandResponse);
    fn data_from_frontseat(&mut self, data: InterfaceData);
    fn raw_from_frontseat(&mut self, raw: Raw);
    fn raw_to_frontseat(&mut self, raw: Raw);
}

/// Something the driver's own I/O tasks observed.
#[derive(Debug)]
pub enum DriverIoEvent {
    Connected(crate::link::LineWriter),
    Line(String),
    /// A CRC-checked binary frame, unescaped, start byte included (framed links only).
    Frame(Vec<u8>),
    /// Bytes that could not be a line (invalid UTF-8, oversized); the link goes on or closes.
    BadInput(String),
    Disconnected(String),
}

/// Where a driver's I/O tasks send what they observe (the driver actor's mailbox).
#[derive(Clone)]
pub struct IoSender {
    send: std::sync::Arc<dyn Fn(DriverIoEvent) -> bool + Send + Sync>,
}

impl IoSender {
    pub fn new(send: impl Fn(DriverIoEvent) -> bool + Send + Sync + 'static) -> Self {
        Self {
            send: std::sync::Arc::new(send),
        }
    }
    /// False once the driver actor is gone: the I/O task should end.
    pub fn send(&self, ev: DriverIoEvent) -> bool {
        (self.send)(ev)
    }
}

pub struct DriverContext {
    pub io: IoSender,
    pub clock: crate::clock::SimClock,
}

pub trait Driver: Send + 'static {
    fn name(&self) -> &str;
    /// Spawn I/O; called once on the driver actor after it started.
    fn start(&mut self, ctx: DriverContext);
    fn handle_io(&mut self, ev: DriverIoEvent, now: Duration, sig: &mut dyn SignalSink);
    fn send_command_to_frontseat(
        &mut self,
        req: &CommandRequest,
        now: Duration,
        sig: &mut dyn SignalSink,
    );
    fn send_data_to_frontseat(
        &mut self,
        data: &InterfaceData,
        now: Duration,
        sig: &mut dyn SignalSink,
    );
    fn send_raw_to_frontseat(&mut self, raw: &Raw, now: Duration, sig: &mut dyn SignalSink);
    /// Goby3's `loop()`, at 10 Hz of simulated time.
    fn do_loop(&mut self, now: Duration, sig: &mut dyn SignalSink);
    fn frontseat_state(&self) -> FrontSeatState;
    fn frontseat_providing_data(&self) -> bool;
    /// Orderly stop: close the frontseat connection cleanly.
    fn stop(&mut self) {}
}

/// Builds a fresh driver for every (re)start.
pub type DriverFactory = std::sync::Arc<dyn Fn() -> Box<dyn Driver> + Send + Sync>;

/// A Raw ASCII message as published on raw_in / raw_out (without the line ending).
pub fn raw_ascii(line: &str, description: &str) -> Raw {
    let mut r = Raw {
        raw: Some(line.as_bytes().to_vec()),
        description: if description.is_empty() {
            None
        } else {
            Some(description.to_string())
        },
        ..Default::default()
    };
    r.set_type(crate::proto::goby::middleware::frontseat::protobuf::raw::RawType::RawAscii);
    r
}
