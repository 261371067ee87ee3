//! What the driver is configured with: the `[driver.ardupilot]` section read once into
//! [`Settings`] (the link, the firmware — Rover or Sub —, ids, timeouts and rates, the streams
//! asked for, the mode table and the Sub's switches), and the MAVLink framing its byte link cuts.

use std::collections::BTreeMap;
use std::time::Duration;

use crate::codec;
use crate::modes::Firmware;
use frontseat_config::{ArdupilotVehicle, InterfaceConfig, MavlinkAddress};

use frontseat_actors::drivers::kit::state_of;
use frontseat_actors::link::byte::{ByteLinkConfig, Transport};
use frontseat_actors::link::framing::{FrameCutter, Framing};
use frontseat_actors::link::serial::SerialSettings;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::FrontSeatState;

#[derive(Clone, Debug)]
pub struct Settings {
    /// None when the address did not parse (a config that skipped validation): never connects.
    pub link: Option<ByteLinkConfig>,
    pub address: String,
    pub firmware: Firmware,
    pub system_id: u8,
    pub component_id: u8,
    pub own_system_id: u8,
    pub own_component_id: u8,
    pub heartbeat_timeout: Duration,
    pub resend_period: Duration,
    pub course_timeout: Duration,
    pub verdict_after: Duration,
    pub ack_timeout: Duration,
    /// (message id, Hz) to ask for at each connection.
    pub streams: Vec<(u32, f64)>,
    pub modes: BTreeMap<u32, FrontSeatState>,
    pub allow_mode_commands: bool,
    /// Navigation waits for an EKF_STATUS_REPORT / GPS_RAW_INT when they are streamed: a
    /// position before them may be the backup estimate.
    pub require_ekf: bool,
    pub require_gps: bool,
    /// Sub: feed the pilot-input failsafe with a neutral MANUAL_CONTROL while alive.
    pub pilot_input_keepalive: bool,
    /// Sub: ALT_HOLD accepts the helm's course (depth, heading, open-loop thrust).
    pub alt_hold_accepts_commands: bool,
    /// Sub in ALT_HOLD: MANUAL_CONTROL x per m/s.
    pub thrust_per_mps: f64,
    /// Sub: depth comes from LOCAL_POSITION_NED (streamed).
    pub depth_from_local: bool,
}

impl Settings {
    pub fn from_config(cfg: &InterfaceConfig) -> Self {
        let c = &cfg.driver.ardupilot;
        let transport = match MavlinkAddress::parse(&c.address) {
            Ok(MavlinkAddress::TcpOut { host, port }) => Some(Transport::Tcp { host, port }),
            Ok(MavlinkAddress::UdpIn { host, port }) => Some(Transport::UdpIn { host, port }),
            Ok(MavlinkAddress::UdpOut { host, port }) => Some(Transport::UdpOut { host, port }),
            Ok(MavlinkAddress::Serial { path, baud }) => {
                Some(Transport::Serial(SerialSettings::new_8n1(path, baud)))
            }
            Err(_) => None,
        };
        let r = &c.stream_rates;
        use mavlink_ids::*;
        let is_sub = c.vehicle == ArdupilotVehicle::Sub;
        let local_hz = if is_sub { r.local_position_ned } else { 0.0 };
        Self {
            link: transport.map(|transport| ByteLinkConfig {
                transport,
                framing: Framing::Frames(mavlink_frames),
                backoff_initial: Duration::from_millis(c.reconnect_initial_ms.max(1)),
                backoff_max: Duration::from_millis(
                    c.reconnect_max_ms.max(c.reconnect_initial_ms).max(1),
                ),
            }),
            address: c.address.clone(),
            firmware: match c.vehicle {
                ArdupilotVehicle::Rover => Firmware::Rover,
                ArdupilotVehicle::Sub => Firmware::Sub,
            },
            system_id: c.system_id,
            component_id: c.component_id,
            own_system_id: c.own_system_id,
            own_component_id: c.own_component_id,
            heartbeat_timeout: secs(c.heartbeat_timeout),
            resend_period: secs(1.0 / c.resend_rate.clamp(1.0, 50.0)),
            course_timeout: secs(c.course_timeout),
            verdict_after: secs(c.target_verdict_after),
            ack_timeout: secs(c.ack_timeout),
            streams: [
                (GLOBAL_POSITION_INT, r.global_position_int),
                (ATTITUDE, r.attitude),
                (VFR_HUD, r.vfr_hud),
                (SYS_STATUS, r.sys_status),
                (GPS_RAW_INT, r.gps_raw_int),
                (EKF_STATUS_REPORT, r.ekf_status_report),
                (LOCAL_POSITION_NED, local_hz),
            ]
            .into_iter()
            .filter(|(_, hz)| hz.is_finite() && *hz > 0.0)
            .collect(),
            modes: c
                .modes
                .iter()
                .map(|m| (m.mode, state_of(m.state)))
                .collect(),
            allow_mode_commands: c.allow_mode_commands,
            require_ekf: r.ekf_status_report > 0.0,
            // A Sub's position comes from a DVL, underwater GPS or visual odometry: the EKF's
            // flags say whether it has one; GPS_RAW_INT says nothing under water.
            require_gps: r.gps_raw_int > 0.0 && !is_sub,
            pilot_input_keepalive: is_sub && c.pilot_input_keepalive,
            alt_hold_accepts_commands: is_sub && c.alt_hold_accepts_commands,
            thrust_per_mps: c.alt_hold_thrust_per_mps,
            depth_from_local: is_sub && local_hz > 0.0,
        }
    }
}

/// Message ids the driver asks streams of.
mod mavlink_ids {
    pub const GLOBAL_POSITION_INT: u32 = 33;
    pub const ATTITUDE: u32 = 30;
    pub const VFR_HUD: u32 = 74;
    pub const SYS_STATUS: u32 = 1;
    pub const GPS_RAW_INT: u32 = 24;
    pub const EKF_STATUS_REPORT: u32 = 193;
    pub const LOCAL_POSITION_NED: u32 = 32;
}

fn secs(s: f64) -> Duration {
    if s.is_finite() && s > 0.0 {
        Duration::from_secs_f64(s.min(1e6))
    } else {
        Duration::from_secs(1)
    }
}

/// MAVLink 1/2 frames of the ardupilotmega dialect on a byte link, CRC-checked by the codec's
/// bounded deframer.
pub fn mavlink_frames() -> Box<dyn FrameCutter> {
    Box::new(MavlinkFrames(codec::Deframer::new()))
}

struct MavlinkFrames(codec::Deframer);

impl FrameCutter for MavlinkFrames {
    fn feed(&mut self, bytes: &[u8], out: &mut dyn FnMut(Result<Vec<u8>, String>)) {
        self.0
            .feed(bytes, &mut |r| out(r.map_err(|e| format!("MAVLink: {e}"))))
    }
}
