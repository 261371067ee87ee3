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
    /// InterfaceData carrying Goby3's Bluefin extension (`bluefin_data`, field 1000), published
    /// on `frontseat::bluefin::bluefin_data_from_frontseat`. Only the Bluefin driver emits it.
    fn bluefin_data_from_frontseat(
        &mut self,
        _data: crate::proto::frontseat::protobuf::bluefin::InterfaceData,
    ) {
    }
    /// InterfaceData carrying Goby3's Iver3 extension (`iver_state`, field 1001), published on
    /// `frontseat::iver::iver_data_from_frontseat`. Only the Iver3 driver emits it.
    fn iver_data_from_frontseat(
        &mut self,
        _data: crate::proto::frontseat::protobuf::iver::InterfaceData,
    ) {
    }
}

/// What a driver's I/O tasks observe and how they hand it over: defined with the links that
/// produce it.
pub use crate::link::{DriverIoEvent, IoSender};

/// A [`SignalSink`] that keeps every signal, for driver tests (one for every driver).
#[derive(Debug, Default)]
pub struct RecordingSink {
    pub responses: Vec<CommandResponse>,
    pub data: Vec<InterfaceData>,
    pub bluefin: Vec<crate::proto::frontseat::protobuf::bluefin::InterfaceData>,
    pub iver: Vec<crate::proto::frontseat::protobuf::iver::InterfaceData>,
    pub raw_in: Vec<Raw>,
    pub raw_out: Vec<Raw>,
}

impl SignalSink for RecordingSink {
    fn command_response(&mut self, r: CommandResponse) {
        self.responses.push(r);
    }
    fn data_from_frontseat(&mut self, d: InterfaceData) {
        self.data.push(d);
    }
    fn raw_from_frontseat(&mut self, r: Raw) {
        self.raw_in.push(r);
    }
    fn raw_to_frontseat(&mut self, r: Raw) {
        self.raw_out.push(r);
    }
    fn bluefin_data_from_frontseat(
        &mut self,
        d: crate::proto::frontseat::protobuf::bluefin::InterfaceData,
    ) {
        self.bluefin.push(d);
    }
    fn iver_data_from_frontseat(
        &mut self,
        d: crate::proto::frontseat::protobuf::iver::InterfaceData,
    ) {
        self.iver.push(d);
    }
}

/// The answer of a driver to a vehicle-extended command it does not speak (`vehicle`'s).
fn refuse_unsupported(
    sig: &mut dyn SignalSink,
    response_requested: bool,
    request_id: Option<i32>,
    driver: &str,
    vehicle: &str,
) {
    if response_requested {
        sig.command_response(CommandResponse {
            request_successful: Some(false),
            request_id,
            error_code: Some(1),
            error_string: Some(format!(
                "driver `{driver}` does not take {vehicle} commands"
            )),
        });
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
    /// A CommandRequest with Goby3's Bluefin extension (`bluefin_command`, field 1000). Drivers
    /// other than Bluefin refuse it (answering when a response was requested).
    fn send_bluefin_command(
        &mut self,
        req: &crate::proto::frontseat::protobuf::bluefin::CommandRequest,
        _now: Duration,
        sig: &mut dyn SignalSink,
    ) {
        refuse_unsupported(
            sig,
            req.response_requested(),
            req.request_id,
            self.name(),
            "Bluefin",
        );
    }
    /// A CommandRequest with Goby3's Iver3 extension (`iver_command`, field 1001). Drivers other
    /// than Iver3 refuse it (answering when a response was requested).
    fn send_iver_command(
        &mut self,
        req: &crate::proto::frontseat::protobuf::iver::CommandRequest,
        _now: Duration,
        sig: &mut dyn SignalSink,
    ) {
        refuse_unsupported(
            sig,
            req.response_requested(),
            req.request_id,
            self.name(),
            "Iver3",
        );
    }
    /// A CommandRequest with our ArduPilot extension (`ardupilot_command`, field 1002: GUIDED,
    /// HOLD, arm, disarm). Drivers other than ArduPilot refuse it.
    fn send_ardupilot_command(
        &mut self,
        req: &crate::proto::frontseat::protobuf::ardupilot::CommandRequest,
        _now: Duration,
        sig: &mut dyn SignalSink,
    ) {
        refuse_unsupported(
            sig,
            req.response_requested(),
            req.request_id,
            self.name(),
            "ArduPilot",
        );
    }
    /// InterfaceData with Goby3's Bluefin extension (payload status, modem lines). Drivers other
    /// than Bluefin ignore it.
    fn send_bluefin_data(
        &mut self,
        _data: &crate::proto::frontseat::protobuf::bluefin::InterfaceData,
        _now: Duration,
        _sig: &mut dyn SignalSink,
    ) {
    }
    /// The interface's status, at every change (Bluefin reports an error state in `$BPSTS`).
    fn interface_status(
        &mut self,
        _status: &crate::proto::goby::middleware::frontseat::protobuf::InterfaceStatus,
    ) {
    }
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
