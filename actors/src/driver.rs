//! The driver contract: Goby3's `InterfaceBase` as a Rust trait.
//!
//! Five operations (send command / data / raw, frontseat state, providing data), a `do_loop` at
//! 10 Hz of simulated time, and the four signals, emitted through a `SignalSink` at the moment
//! the driver has them. A vehicle's extensions of Goby3's messages (Bluefin, Iver3, ArduPilot)
//! cross the contract as one generic [`DriverExtension`] each way, so the contract names no
//! vehicle and a driver refuses another vehicle's commands through [`refuse_extension`]. I/O happens in tasks the driver spawns in `start`; what they read comes
//! back as `DriverIoEvent`s handled on the driver actor, one at a time, so a driver is plain
//! single-threaded state.

use std::time::Duration;

use prost::Message as _;

pub use crate::proto::frontseat::protobuf::DriverExtension;
use crate::proto::goby::middleware::frontseat::protobuf::{
    CommandRequest, CommandResponse, FrontSeatState, InterfaceData, Raw,
};

/// Goby3's four driver signals.
pub trait SignalSink {
    fn command_response(&mut self, response: CommandResponse);
    fn data_from_frontseat(&mut self, data: InterfaceData);
    fn raw_from_frontseat(&mut self, raw: Raw);
    fn raw_to_frontseat(&mut self, raw: Raw);
    /// A vehicle-extended InterfaceData (Bluefin's `bluefin_data`, Iver3's `iver_state`), tagged
    /// with its type; the interface gates its navigation and publishes it on the vehicle's group
    /// (`frontseat::bluefin::bluefin_data_from_frontseat`, …). Only drivers with an extension emit it.
    fn extension_from_frontseat(&mut self, _ext: DriverExtension) {}
}

/// What a driver's I/O tasks observe and how they hand it over: defined with the links that
/// produce it.
pub use crate::link::{DriverIoEvent, IoSender};
/// How a driver writes a course at once from the helm's thread: defined with the lane that
/// calls it.
pub use crate::setpoint_lane::DirectCommand;

/// A [`SignalSink`] that keeps every signal, for driver tests (one for every driver).
#[derive(Debug, Default)]
pub struct RecordingSink {
    pub responses: Vec<CommandResponse>,
    pub data: Vec<InterfaceData>,
    pub extensions: Vec<DriverExtension>,
    pub raw_in: Vec<Raw>,
    pub raw_out: Vec<Raw>,
}

impl RecordingSink {
    /// The extension data of type `type_name` emitted so far, decoded (what does not decode is
    /// left out, so a test comparing lengths sees it).
    pub fn extensions_of<M: prost::Message + Default>(&self, type_name: &str) -> Vec<M> {
        self.extensions
            .iter()
            .filter_map(|e| e.decode::<M>(type_name))
            .filter_map(Result::ok)
            .collect()
    }
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
    fn extension_from_frontseat(&mut self, e: DriverExtension) {
        self.extensions.push(e);
    }
}

impl DriverExtension {
    /// `msg` (a vehicle's mirror message whose full proto name is `type_name`) as an extension
    /// of `vehicle` (in words, for refusals).
    pub fn encode<M: prost::Message>(type_name: &str, vehicle: &str, msg: &M) -> Self {
        Self {
            type_name: Some(type_name.to_string()),
            value: Some(msg.encode_to_vec()),
            vehicle: Some(vehicle.to_string()),
        }
    }

    /// The message, when this extension is of `type_name`: None for another type, an error
    /// for bytes that do not decode as it.
    pub fn decode<M: prost::Message + Default>(
        &self,
        type_name: &str,
    ) -> Option<Result<M, prost::DecodeError>> {
        (self.type_name() == type_name).then(|| M::decode(self.value()))
    }
}

/// How a driver answers an extension it does not speak: a command is refused (answered when a
/// response was requested, as Goby3's drivers answer nothing they do not know), data is ignored.
/// A mirror's base fields have Goby3's numbers, so the base request decodes from its bytes.
pub fn refuse_extension(sig: &mut dyn SignalSink, ext: &DriverExtension, driver: &str) {
    if !ext.type_name().ends_with(".CommandRequest") {
        return;
    }
    let base = CommandRequest::decode(ext.value()).unwrap_or_default();
    refuse_unsupported(
        sig,
        base.response_requested(),
        base.request_id,
        driver,
        ext.vehicle(),
    );
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
    /// A vehicle-extended CommandRequest or InterfaceData (Goby3's Bluefin and Iver3 extensions,
    /// our ArduPilot one) that passed the interface's gate, whole. A driver takes its vehicle's
    /// types (by `ext.type_name`) and hands the rest to [`refuse_extension`], the default.
    fn send_extension(&mut self, ext: &DriverExtension, _now: Duration, sig: &mut dyn SignalSink) {
        refuse_extension(sig, ext, self.name());
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
    /// Its way to write a course at once from the publisher's thread, while it has one (a
    /// connection that can take it): the setpoint lane (`crate::setpoint_lane`) then skips the
    /// actor hops. Asked after every message the DriverActor handles. None (the default): every
    /// course comes through `send_command_to_frontseat`.
    fn direct_command(&self) -> Option<std::sync::Arc<dyn DirectCommand>> {
        None
    }
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
